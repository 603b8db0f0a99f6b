"""Independent reference models used by the tests and benchmarks (need the ``test`` extra)."""
