"""The gallery of worked examples (examples/gallery/plot_*.py) runs as written and computes what it says
(scikit-fem's tests/test_examples.py).

Each script runs in a temporary working folder (they write their files there) with matplotlib's non-interactive
backend, once per suite: the documentation build does not execute them (docs/conf.py, ``plot_gallery``).
They are kept to seconds each (the reduced model, small sweeps, one multibody run).  Each script's numbers are then
checked from its globals (:data:`CHECKS`, one function per script, none may be missing): against a closed form where
there is one (the 3-4-5 follower law's peaks, ISO 286 limit deviations, a made-up field response's effects), else
against a stored value with a tolerance the model's convergence allows (between rtol 1e-7, the MLSD model's default,
and 1e-8 or 1e-9 its mean forces move by < 2 %, its RMS forces by < 5 % and its peaks by up to 3.5 %: means are held
to 3 %, RMS to 3-6 %, and no peak is stored).
"""

from __future__ import annotations

import math
import runpy
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

GALLERY = Path(__file__).resolve().parents[1] / "examples" / "gallery"
SCRIPTS = sorted(GALLERY.glob("plot_*.py"))


def _follower_peaks(stroke_m: float, speed_rpm: float, rise_deg: float) -> tuple[float, float]:
    """Peak velocity (m/s) and acceleration (m/s^2) of the 3-4-5 polynomial rise s = h (10 x^3 - 15 x^4 + 6 x^5),
    x = theta / beta: 15/8 h w/b (at x = 1/2) and 10/sqrt(3) h (w/b)^2 (at x = 1/2 - sqrt(3)/6)."""
    rate = speed_rpm * 2 * math.pi / 60 / math.radians(rise_deg)
    return 15 / 8 * stroke_m * rate, 10 / math.sqrt(3) * stroke_m * rate**2


def _check_own_machine(g):
    """The edited machine (135 rpm, 44 mm stroke, A = 0.4 mm) against the follower law's closed form, and the MLSD
    model's mean and RMS forces (stored at rtol 1e-7; 1e-8 and 1e-9 move means < 2 %, RMS < 5 %)."""
    assert g["machine"].machine.name == "my harvester" and not g["problems"]
    assert g["machine"].clearance_sizes()["A"] == pytest.approx(0.4e-3)
    v, a = _follower_peaks(0.044, 135.0, 120.0)
    assert g["cam"]["max_velocity_m_s"] == pytest.approx(v, rel=1e-4)  # 0.5569 m/s
    assert g["cam"]["max_acceleration_m_s2"] == pytest.approx(a, rel=1e-4)  # 11.57 m/s^2
    forces = g["stats"]["collision_force_N"]
    for pair, mean, rms in (("A", 722.3, 1393.2), ("B", 686.3, 1325.6), ("C", 314.4, 1017.3), ("F", 318.6, 1023.5)):
        assert forces[pair]["mean"] == pytest.approx(mean, rel=0.03), pair
        assert forces[pair]["rms"] == pytest.approx(rms, rel=0.06), pair
    assert forces["C"]["peak"] > forces["A"]["peak"]  # the pins' stiffer contact strikes harder (22 against 11 kN)


def _check_clearance_sweep(g):
    """The grid is 0.1 .. 0.7 mm in seven points; the RMS force at A (stored, rtol 1e-7 against 1e-9: < 1.5 %) and its
    peak grow with the clearance."""
    assert [float(p[0]) for p in g["points"]] == pytest.approx(np.linspace(0.1, 0.7, 7))
    rms = [s["collision_force_N"]["A"]["rms"] for s in g["summaries"]]
    assert rms[0] == pytest.approx(928.5, rel=0.03) and rms[3] == pytest.approx(1051.3, rel=0.03)
    assert rms[-1] == pytest.approx(1090.5, rel=0.03)
    peak = [s["collision_force_N"]["A"]["peak"] for s in g["summaries"]]
    assert peak[-1] > 1.25 * peak[0]  # 11.3 against 8.2 kN (8.5 kN at rtol 1e-9)


def _check_field_test(g):
    """The made-up response's effects come back: efficiency = picked mass per minute, whose level means over speed
    differ by 0.012 kg/min per r/min x 40 r/min = 0.48 kg/min and over amplitude by 0.02 x 20 = 0.40 kg/min; clearance
    has no effect on it.  The noise (SD 0.03 kg) gives a range's SE of 0.03 sqrt(2/6) = 0.017 kg/min: 4 SE allowed."""
    eff = g["analysis"].responses["efficiency"].factors
    assert eff["speed"].range == pytest.approx(0.48, abs=0.07)
    assert eff["amplitude"].range == pytest.approx(0.40, abs=0.07)
    assert eff["clearance_A"].range < 0.07 and not eff["clearance_A"].significant
    assert eff["speed"].significant and eff["speed"].best_level == 3
    assert g["analysis"].responses["damage"].factors["clearance_A"].best_level == 1  # damage grows with clearance
    assert g["analysis"].optimum.levels["speed"] == 3


def _check_joint_life(g):
    """ISO 286-2 for 20 mm (over 18 to 30): H8 = 0 .. +33 um, f7 = -41 .. -20 um, so 20 .. 74 um diametral and a
    radial mean of 23.5 um; with the loads of one run standing for every clearance, the clearance grows linearly in
    hours and reaches the service limit at the reported interval."""
    lim = g["limits"]
    assert (lim["hole"]["lower_deviation_um"], lim["hole"]["upper_deviation_um"]) == (0, 33)
    assert (lim["shaft"]["lower_deviation_um"], lim["shaft"]["upper_deviation_um"]) == (-41, -20)
    assert (lim["clearance_min_mm"], lim["clearance_max_mm"]) == pytest.approx((0.020, 0.074))
    assert g["start"] == pytest.approx(0.0235e-3)
    hours, c = np.asarray(g["life"].hours), np.asarray(g["life"].clearance["C"])
    slope, offset = np.polyfit(hours, c, 1)
    assert np.abs(c - (slope * hours + offset)).max() < 1e-3 * (c.max() - c.min())
    assert g["interval"] == pytest.approx((g["limit"] - g["start"]) / slope, rel=0.02)


def _check_python_api(g):
    """The push rod's peak speed is the 3-4-5 law's 15/8 h w/b (40 mm, 120 rpm, 120 deg: 0.45 m/s); the fit table
    is ISO 286-2 at 20 mm (H7 +21, g6 -7/-20, f7 -20/-41, H8 +33, e8 -40/-73, H9 +52, d9 -65/-117 um), radial = half;
    the field sheet's efficiency range over C is the level means' range of the sheet itself (0.25 kg/min per level
    plus the fixed scatter) and C's best level the third."""
    v, _ = _follower_peaks(0.040, 120.0, 120.0)
    assert g["kin"]["push_rod_velocity [m/s]"].abs().max() == pytest.approx(v, rel=1e-4)
    radial = {"H7/g6": (0.0035, 0.0205), "H7/f7": (0.010, 0.031), "H8/e8": (0.020, 0.053), "H9/d9": (0.0325, 0.0845)}
    for fit, (lo, hi) in radial.items():
        row = g["fits"].loc[fit]
        assert (row["radial_clearance_min [mm]"], row["radial_clearance_max [mm]"]) == pytest.approx((lo, hi)), fit
    sheet, table = g["sheet"], g["tables"]["range_efficiency"]
    means = sheet.groupby("C_level")["efficiency_kg_min"].mean()
    assert table.loc["C", "R [kg/min]"] == pytest.approx(means.max() - means.min(), abs=1e-3)
    assert table.loc["C", "R [kg/min]"] == pytest.approx(0.5, abs=0.08)  # 2 x 0.25, the scatter at most 0.04 each
    assert g["tables"]["optimum_levels"].loc["C", "level"] == 3
    c = g["table"]["collision_force_C_rms [N]"].to_numpy()
    assert np.all(np.diff(c) > 0)  # the RMS force at C grows with its clearance (700, 755, 795 N)


#: the numbers each example is checked on, by script name
CHECKS = {"plot_01_own_machine": _check_own_machine, "plot_02_clearance_sweep": _check_clearance_sweep,
          "plot_03_field_test": _check_field_test, "plot_04_joint_life": _check_joint_life,
          "plot_05_python_api": _check_python_api}


def test_every_example_has_its_checked_numbers():
    assert sorted(CHECKS) == [s.stem for s in SCRIPTS]


def test_gallery_is_not_empty():
    """The gallery has its four examples (own machine, clearance sweep, field test, joint life) at least."""
    assert len(SCRIPTS) >= 4, [s.name for s in SCRIPTS]


@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_example_runs(script, tmp_path, monkeypatch):
    """The script runs to its end, draws at least one figure and computes its numbers (:data:`CHECKS`)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(plt, "show", lambda *a, **k: None)  # Agg cannot show; sphinx-gallery collects figures
    plt.close("all")
    try:
        names = runpy.run_path(str(script), run_name="__main__")
        assert plt.get_fignums(), f"{script.name} drew no figure"
        CHECKS[script.stem](names)
    finally:
        plt.close("all")
