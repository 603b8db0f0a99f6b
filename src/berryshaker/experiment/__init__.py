"""Experiments: clearance levels and rows of the study's (lost) Table 5, orthogonal designs."""

from berryshaker.experiment.clearance_rows import CLEARANCE_LEVELS_MM, clearance_row, parse_clearance_spec

__all__ = ["CLEARANCE_LEVELS_MM", "clearance_row", "parse_clearance_spec"]
