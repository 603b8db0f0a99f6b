"""Runs that keep only their summary write only the statistics window (``series="statistics"``), and the engine's
per-call overhead.

* The summary of a ``series="statistics"`` run is that of a whole run, bit for bit, on both drives, with the
  imposed speed and with the powered driveline (whose energy audit snaps its window to the nearest sample), over
  2 and 3 revolutions; the start-up revolution's samples are not written.
* An unknown ``series`` is refused with a message naming the field and its choices.
* The contact laws reach the compiled core as entry points with a stable identity (the batch groups runs by it)
  that compute what the laws' dispatchers compute.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from berryshaker.config import reference_machine
from berryshaker.contact.laws import LawEntryPoint, get_law, law_names, law_table
from berryshaker.drives.simulation import simulate_multibody
from berryshaker.errors import ConfigError
from berryshaker.multibody.perturbation import RandomInitialPerturbation


def _same(a: dict, b: dict) -> bool:
    a, b = dict(a), dict(b)
    a.pop("wall_time_s"), b.pop("wall_time_s")
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


@pytest.mark.parametrize("drive, driveline, revolutions", [("groove_cam", None, 2), ("groove_cam", "powered", 3),
                                                           ("crank_rocker", None, 2)])
def test_statistics_series_gives_the_whole_runs_summary(drive, driveline, revolutions):
    machine = reference_machine(drive)
    pert = RandomInitialPerturbation((3, 0))
    whole, s_whole = simulate_multibody(machine, revolutions=revolutions, driveline=driveline,
                                        initial_perturbation=pert)
    window, s_window = simulate_multibody(machine, revolutions=revolutions, driveline=driveline,
                                          initial_perturbation=pert, series="statistics")
    assert _same(s_whole, s_window)
    # the start state, the sample before the window, then the window: the first revolution is not written
    inside = whole.t >= whole.stats_from - 1e-12
    assert len(window.t) == int(inside.sum()) + 2
    assert np.array_equal(window.t[2:], whole.t[inside]) and window.t[0] == 0.0
    assert np.array_equal(window.elements[2:], whole.elements[inside])
    assert np.array_equal(window.y[-1], whole.y[-1])


def test_unknown_series_is_refused():
    with pytest.raises(ConfigError, match="series must be one of 'whole', 'statistics'"):
        simulate_multibody(reference_machine(), series="window")


def test_law_entry_points_are_stable_and_compute_the_laws():
    first, again = law_table(), law_table()
    assert all(isinstance(e, LawEntryPoint) for e in first)
    assert all(a is b for a, b in zip(first, again))  # the batch's structure key uses their identity
    args = (2e-6, 0.03, 0.05, 1e10, 1.5, 0.8, 1e-3, 1e-5)
    for name, entry in zip(law_names(), first):
        assert entry(*args) == get_law(name).kernel(*args)
        assert entry.__wrapper_address__() == entry.__wrapper_address__() != 0
