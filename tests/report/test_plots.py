"""Figures drawn from synthetic data: the drawn peak is the data peak, every axis and colour bar has a
unit, one colour bar per surface figure, legends off the data, no offset tick labels."""

from __future__ import annotations

import numpy as np
import pytest

from berryshaker.report import plots as P
from berryshaker.report.style import (
    PAIR_COLOURS,
    audit_figure,
    decimate_minmax,
    decimate_minmax_shared,
    has_unit,
    pyplot,
    require_unit,
)


def _impulsive(n=120_001, seed=0):
    """A slow oscillation with one-sample impact spikes that striding (every 27th sample) misses."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.5, n)
    y = 50 * np.sin(2 * np.pi * 2 * t) + rng.normal(0, 2, n)
    spikes = (np.array([0.0083, 0.25, 0.6481, 0.8333]) * n).astype(int)
    spikes += (spikes % 27 == 0)  # none on the 27-sample grid
    assert np.all(spikes % 27 != 0)
    y[spikes] = [900.0, -750.0, 1234.5678901234, 640.0]
    return t, y


def _drawn_lines_extremes(fig):
    ys = [np.asarray(line.get_ydata(), float) for ax in fig.axes for line in ax.get_lines()
          if len(line.get_ydata()) > 2]
    return max(float(np.max(y)) for y in ys), min(float(np.min(y)) for y in ys)


def _close(data):
    pyplot().close(data["figure"])


# ---- style helpers ---------------------------------------------------------------------------------
def test_decimate_minmax_keeps_extremes_exactly_and_striding_does_not():
    t, y = _impulsive()
    xd, yd = decimate_minmax(t, y, 500)
    assert len(xd) <= 2 * 500 + 2
    assert yd.max() == y.max() and yd.min() == y.min()
    assert np.all(np.diff(xd) > 0)  # time order kept
    assert set(zip(xd.tolist(), yd.tolist())) <= set(zip(t.tolist(), y.tolist()))  # samples, not averages
    assert y[::27].max() < 0.9 * y.max()  # the bug this replaces
    # short series come back whole
    _xs, ys = decimate_minmax(t[:100], y[:100], 500)
    assert np.array_equal(ys, y[:100])


def test_decimate_minmax_shared_keeps_every_series_peak():
    t, y = _impulsive()
    z = -0.5 * y[::-1]
    xd, out = decimate_minmax_shared(t, {"y": y, "z": z}, 300)
    assert out["y"].max() == y.max() and out["z"].min() == z.min() and out["z"].max() == z.max()
    assert len(xd) == len(out["y"]) == len(out["z"])


def test_unit_helper_refuses_labels_without_unit():
    assert has_unit("force [N]") and has_unit("s (mm)") and has_unit("ratio [-]")
    with pytest.raises(ValueError, match="no unit"):
        require_unit("level of A")
    with pytest.warns(UserWarning):
        assert require_unit("efficiency", strict=False).endswith("[unit?]")


# ---- figures ---------------------------------------------------------------------------------------
def test_fruit_force_figure_draws_the_table_peak(tmp_path):
    t, y = _impulsive()
    d = 0.5 * t  # distance [m]
    forces = {"root": 3e-4 * y, "middle": 7e-4 * y, "end": 1e-3 * y}
    peaks = {k: float(np.max(np.abs(v))) for k, v in forces.items()}
    ranges = {"root": (0.25, 0.4), "middle": (0.65, 0.9), "end": (0.8, 1.2)}
    data = P.plot_fruit_force(d, forces, ranges, tmp_path / "ff.png", peaks=peaks, return_figure=True)
    for k in forces:
        assert abs(data["fruit"][k]["peak_abs"] - peaks[k]) <= 1e-12
        assert data["fruit"][k]["peak_matches_table"]
    hi, lo = _drawn_lines_extremes(data["figure"])  # read back from the drawn Line2D objects
    assert abs(hi - forces["end"].max()) <= 1e-12 and abs(lo - forces["end"].min()) <= 1e-12
    assert not audit_figure(data["figure"])
    _close(data)
    # a series thinned by striding before it gets here is flagged, not silently drawn low
    strided = {k: v[::27] for k, v in forces.items()}
    data = P.plot_fruit_force(d[::27], strided, ranges, tmp_path / "ff2.png", peaks=peaks)
    assert not data["fruit"]["end"]["peak_matches_table"]


def test_time_series_multibody_under_mlsd_with_zoom(tmp_path):
    t, y = _impulsive()
    data = P.plot_time_series(t, {"multibody": y, "MLSD": 0.9 * y}, "collision force at A (N)",
                              tmp_path / "ts.png", "Pair A", zoom="peak", return_figure=True)
    fig = data["figure"]
    for name, s in (("multibody", y), ("MLSD", 0.9 * y)):
        assert abs(data["series"][name]["max"] - s.max()) <= 1e-12
        assert abs(data["series"][name]["min"] - s.min()) <= 1e-12
    main = fig.axes[0]
    lines = {ln.get_label(): ln for ln in main.get_lines()}
    mb, ml = lines["multibody"], lines["MLSD"]
    assert mb.get_zorder() < ml.get_zorder() and mb.get_linewidth() > ml.get_linewidth()
    assert mb.get_linestyle() == "-" and ml.get_linestyle() == "--"
    assert data["zoom"] is not None and data["zoom"][0] < t[np.argmax(y)] < data["zoom"][1]
    assert len(fig.axes) == 2
    assert not audit_figure(fig)
    _close(data)


def test_joint_forces_one_panel_per_joint(tmp_path):
    t, y = _impulsive(40_001)
    forces = {p: np.abs(y) * s for p, s in zip("ABCF", (1.0, 0.7, 0.4, 0.2))}
    data = P.plot_joint_forces(t, forces, tmp_path / "jf.png", "A 0.25 mm, B 0.2 mm, C 0.1 mm, F 0.2 mm",
                               return_figure=True)
    fig = data["figure"]
    assert len(fig.axes) == 4
    for ax, p in zip(fig.axes, "ABCF"):
        assert abs(data["series"][p]["peak_abs"] - forces[p].max()) <= 1e-12
        assert ax.get_lines()[0].get_color().lower() == PAIR_COLOURS[p].lower()
        assert f"at {p}" in ax.get_ylabel()
    assert "0.25 mm" in fig._suptitle.get_text()
    assert not audit_figure(fig)
    _close(data)


def test_bars_reference_bar_hatched_and_legend_off_data(tmp_path):
    labels = ["none", "0.25 mm", "0.5 mm", "0.75 mm"]
    series = {"multibody peak": [10, 300, 420, 510], "MLSD peak": [11, 280, 400, 530],
              "multibody mean": [5, 40, 45, 50]}
    data = P.plot_bars(series, labels, "peak collision force at A [N]", tmp_path / "bars.png", "A alone",
                       pair="A", reference_index=0, return_figure=True)
    fig = data["figure"]
    ax = fig.axes[0]
    assert ax.get_ylabel() == "peak collision force at A [N]"
    assert "joint reaction" in ax.get_xticklabels()[0].get_text()
    assert "xx" in (ax.patches[0].get_hatch() or "")
    assert [float(p.get_height()) for p in ax.patches[:4]] == series["multibody peak"]
    assert ax.get_legend() is not None
    assert not audit_figure(fig)
    _close(data)


L9 = np.array([[1, 1, 1, 1], [1, 2, 2, 2], [1, 3, 3, 3], [2, 1, 2, 3], [2, 2, 3, 1], [2, 3, 1, 2],
               [3, 1, 3, 2], [3, 2, 1, 3], [3, 3, 2, 1]])  # the standard L9(3^4) orthogonal array
LEVELS_MM = {"A": [0.25, 0.5, 0.75], "B": [0.2, 0.4, 0.6], "C": [0.1, 0.15, 0.2], "F": [0.1, 0.15, 0.2]}


def _l9_analysis():
    """A range analysis built here from synthetic responses (the figure tests do not depend on the
    analysis module): level means, range, best level, and an ANOVA error with C pooled."""
    values = np.array([[LEVELS_MM[p][L9[i, j] - 1] for j, p in enumerate("ABCF")] for i in range(9)])
    rng = np.random.default_rng(3)
    ys = {"efficiency": 3.9 - 1.2 * values[:, 0] + 0.3 * np.cos(10 * values[:, 1]) + rng.normal(0, 0.03, 9),
          "unripe": 3 + 2 * values[:, 0] + rng.normal(0, 0.1, 9),
          "damage": 2.8 + values[:, 1] + rng.normal(0, 0.1, 9)}
    senses = {"efficiency": True, "unripe": False, "damage": False}
    res = {"responses": {}, "composite": {"score": [0.0] * 9}}
    for r, y in ys.items():
        fac = {}
        for j, p in enumerate("ABCF"):
            k = [float(y[L9[:, j] == lv].mean()) for lv in (1, 2, 3)]
            best = int(np.argmax(k) if senses[r] else np.argmin(k)) + 1
            fac[p] = {"level_means": k, "range": max(k) - min(k), "best_level": best}
        ss_c = 3 * sum((m - y.mean()) ** 2 for m in fac["C"]["level_means"])
        res["responses"][r] = {"factors": fac, "maximize": senses[r],
                               "anova": {"error": {"ss": ss_c, "df": 2, "ms": ss_c / 2}, "pooled": ["C"]}}
    res["runs"] = [{"levels": {p: int(L9[i, j]) for j, p in enumerate("ABCF")},
                    "clearance_mm": {p: float(values[i, j]) for j, p in enumerate("ABCF")}} for i in range(9)]
    return res, values, ys


def _quadratic_model(values, y):
    """Least-squares main-effects quadratic (1, x, x^2 per factor) as a callable, for the surfaces."""
    def design(X):
        X = np.atleast_2d(X)
        return np.column_stack([np.ones(len(X))] + [X[:, j] ** e for j in range(X.shape[1]) for e in (1, 2)])

    coef = np.linalg.lstsq(design(values), y, rcond=None)[0]
    return lambda X: design(X) @ coef


def test_main_effects_units_levels_in_mm_and_error_bars(tmp_path):
    res, _, _ = _l9_analysis()
    data = P.plot_main_effects(res, tmp_path / "me.png", "Virtual L9", return_figure=True)
    fig = data["figure"]
    assert "kg/min" in fig.axes[0].get_ylabel()
    assert "%" in fig.axes[4].get_ylabel()
    assert fig.axes[-4].get_xlabel() == "A [mm]"
    assert [t.get_text() for t in fig.axes[0].get_xticklabels()] == ["0.25", "0.5", "0.75"]
    eff = data["responses"]["efficiency"]
    assert eff["factors"]["A"]["errors"] is not None
    se = float(eff["factors"]["A"]["errors"][0])
    lo, hi = eff["ylim"]
    assert hi - lo >= 2 * 4 * se  # at least +-4 standard errors: noise is not blown up
    assert "standard error" in fig._suptitle.get_text()
    labels = fig.axes[3].get_legend().get_texts()
    assert any("best level" in t.get_text() for t in labels)
    assert not audit_figure(fig)
    _close(data)


def test_response_surfaces_one_colour_bar_shared_scale(tmp_path):
    _, values, ys = _l9_analysis()
    y = ys["efficiency"]
    data = P.plot_response_surfaces(values, y, list("ABCF"), None, "efficiency", tmp_path / "rs.png",
                                    model=_quadratic_model(values, y), return_figure=True)
    fig = data["figure"]
    cbars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(cbars) == 1 and data["n_colorbars"] == 1
    assert "kg/min" in cbars[0].get_ylabel()
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>" and ax.get_visible()]
    assert len(panels) == 6
    clims = {tuple(np.round(c.get_clim(), 12)) for ax in panels for c in ax.collections if hasattr(c, "get_clim")
             and c.get_array() is not None and c.get_label() != "test runs"}
    assert len(clims) == 1  # one colour scale for all panels
    for ax, (a, b) in zip(panels, [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]):
        x0, x1 = ax.get_xlim()
        y0, y1 = ax.get_ylim()
        assert x0 < values[:, a].min() and x1 > values[:, a].max()  # design points not on the edge
        assert y0 < values[:, b].min() and y1 > values[:, b].max()
    assert not audit_figure(fig)
    _close(data)


def test_colour_bar_of_a_flat_surface_has_no_offset(tmp_path):
    """A constant response once gave a colour bar reading "1e-14+2.86"."""
    _, values, _ = _l9_analysis()
    y = np.full(9, 2.86)
    data = P.plot_response_surfaces(values, y, list("ABCF"), None, "damage", tmp_path / "flat.png",
                                    model=lambda X: np.full(len(X), 2.86) + 1e-14 * X[:, 0], return_figure=True)
    fig = data["figure"]
    fig.canvas.draw()
    cbar = next(ax for ax in fig.axes if ax.get_label() == "<colorbar>")
    assert cbar.yaxis.get_offset_text().get_text() == ""
    assert not audit_figure(fig)
    _close(data)


def test_main_effects_ring_marks_ties_and_no_ring_on_a_flat_factor(tmp_path):
    """The red ring names the best level; tied levels share it and a factor with R = 0 has none."""
    res, _, _ = _l9_analysis()
    fa = res["responses"]["efficiency"]["factors"]
    fa["A"]["level_means"] = [2.0, 2.0, 2.0]
    fa["A"]["range"], fa["A"]["best_level"] = 0.0, 1
    fa["B"]["level_means"] = [1.0, 3.0, 3.0]
    fa["B"]["range"], fa["B"]["best_level"] = 2.0, 2
    data = P.plot_main_effects(res, tmp_path / "me.png", "ties", return_figure=True)
    fig = data["figure"]

    def rings(ax):
        return sum(len(ln.get_xdata()) for ln in ax.get_lines() if ln.get_markersize() == 12)

    assert rings(fig.axes[0]) == 0
    assert rings(fig.axes[1]) == 2
    _close(data)


def test_harvest_response_draws_the_table_rows_sorted_with_a_frequency_axis(tmp_path):
    rows = [{"ripe_removal_pct": 70.0, "unripe_shed_pct": 0.5, "damage_rate_pct": 2.0, "shaking_frequency_hz": 2.5},
            {"ripe_removal_pct": 8.0, "unripe_shed_pct": 0.0, "damage_rate_pct": 0.8, "shaking_frequency_hz": 1.0},
            {"ripe_removal_pct": 18.0, "unripe_shed_pct": 0.1, "damage_rate_pct": 3.0, "shaking_frequency_hz": 2.0}]
    x = [150.0, 60.0, 120.0]
    data = P.plot_harvest_response(x, rows, "cam speed [rpm]", tmp_path / "removal.svg", "removal",
                                   frequency_hz=[r["shaking_frequency_hz"] for r in rows], return_figure=True)
    fig = data["figure"]
    ax = fig.axes[0]
    assert list(data["x"]) == [60.0, 120.0, 150.0]
    assert list(data["series"]["ripe_removal_pct"]) == [8.0, 18.0, 70.0]
    lines = {ln.get_label(): list(ln.get_ydata()) for ln in ax.get_lines()}
    assert lines["ripe removal (% of ripe mass)"] == [8.0, 18.0, 70.0]
    assert ax.get_xlabel() == "cam speed [rpm]" and "[%]" in ax.get_ylabel()
    assert list(data["frequency_hz"]) == [1.0, 2.0, 2.5]
    assert ax.get_legend() is not None
    assert not audit_figure(fig)
    _close(data)
    assert (tmp_path / "removal.svg").read_text().lstrip().startswith("<?xml")


def test_harvest_response_draws_sd_bars_and_an_amplitude_axis(tmp_path):
    """A drive-geometry sweep (e.g. cam.stroke) draws the replicate means with +- SD bars and the finger
    amplitude as the top axis; a non-monotonic amplitude gets no axis (the map would not be a function)."""
    rows = [{"ripe_removal_pct": m, "ripe_removal_pct_sd": 2.0, "unripe_shed_pct": 0.1, "damage_rate_pct": 1.0,
             "damage_rate_pct_sd": 0.2, "finger_amplitude_mm": a} for m, a in ((20.0, 56.0), (36.0, 74.0), (60.0, 92.0))]
    data = P.plot_harvest_response([30.0, 40.0, 50.0], rows, "cam.stroke [mm]", tmp_path / "amp.png", "amplitude",
                                   amplitude_mm=[r["finger_amplitude_mm"] for r in rows], return_figure=True)
    fig = data["figure"]
    assert list(data["amplitude_mm"]) == [56.0, 74.0, 92.0]
    assert list(data["series"]["ripe_removal_pct_sd"]) == [2.0, 2.0, 2.0]
    assert [c.get_xlabel() for c in fig.axes[0].child_axes] == ["finger amplitude [mm]"]
    assert not audit_figure(fig)
    _close(data)
    bent = P.plot_harvest_response([30.0, 40.0, 50.0], rows, "x [mm]", tmp_path / "bent.png",
                                   amplitude_mm=[56.0, 92.0, 74.0], return_figure=True)
    assert "amplitude_mm" not in bent
    _close(bent)


def test_shaking_amplitude_follows_the_drive_geometry(machine):
    """The comb swing of the reference machine (+-9.5 deg, its TOML comment) and the finger amplitude at the
    striking radius grow with the cam stroke; the swing is nearly proportional to the stroke for these small angles."""
    import math

    from berryshaker.config import machine_from_dict
    from berryshaker.harvest.virtual import shaking_amplitude

    ref = shaking_amplitude(machine)
    assert ref["comb_swing_deg"] == pytest.approx(9.5, abs=0.1)
    assert ref["finger_amplitude_mm"] == pytest.approx(math.radians(ref["comb_swing_deg"]) * 450.0, rel=1e-9)
    amps = []
    for stroke in (0.03, 0.05):
        d = machine.model_dump()
        d["cam"]["stroke"] = stroke
        amps.append(shaking_amplitude(machine_from_dict(d))["comb_swing_deg"])
    assert amps[0] < ref["comb_swing_deg"] < amps[1]
    assert amps[1] / amps[0] == pytest.approx(5.0 / 3.0, rel=0.05)


def _tradeoff_records():
    """Ten candidates in the layout of the reference study's trade-off (runs 1 and 2 and the recommended set
    crowded at low force and torque); the recommended set is not an L9 run."""
    pts = {"run 1 (A1B1C1F1)": (3.92, 30800, 251), "run 2 (A1B2C2F2)": (3.92, 28400, 311),
           "run 3 (A1B3C3F3)": (4.06, 35900, 370), "run 4 (A2B1C2F3)": (4.04, 30600, 338),
           "run 5 (A2B2C3F1)": (4.01, 32100, 365), "run 6 (A2B3C1F2)": (4.14, 33200, 416),
           "run 7 (A3B1C3F2)": (3.95, 33600, 352), "run 8 (A3B2C1F3)": (4.07, 30700, 433),
           "run 9 (A3B3C2F1)": (4.17, 35400, 465), "recommended (A1B1C1F3)": (3.93, 21900, 263)}
    recs = []
    for name, (eff, force, torque) in pts.items():
        r = {"name": name, "efficiency": eff, "efficiency_lo": eff - 0.17, "efficiency_hi": eff + 0.17,
             "drive_torque_design_Nm": torque, "drive_torque_design_Nm_lo": torque - 33, "drive_torque_design_Nm_hi": torque + 33,
             "dominated": not name.startswith(("run 1 ", "recommended"))}
        for p, f in zip("ABCF", (0.3 * force, 0.3 * force, force, 0.98 * force)):
            r[f"design_force_N:{p}"], r[f"design_force_N:{p}_lo"], r[f"design_force_N:{p}_hi"] = f, 0.75 * f, 1.25 * f
        recs.append(r)
    return recs


def test_tradeoff_labels_clear_of_markers_and_each_other_and_a_torque_legend(tmp_path):
    """The trade-off figure: the recommended set is a starred marker named in the legend (no text label lying
    over runs 1 and 2); no run label covers another label or any marker; the torque panel's colour is its
    own, not a joint's, and the legend says which panel each colour belongs to."""
    data = P.plot_tradeoff(_tradeoff_records(), tmp_path / "tradeoff.png", return_figure=True)
    fig = data["figure"]
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    axes = [ax for ax in fig.axes if ax.get_xlabel()]
    assert len(axes) == 2
    for ax in axes:
        texts = [t for t in ax.texts if t.get_text()]
        assert len(texts) == 9 and not any("recommended" in t.get_text() for t in texts)
        boxes = [t.get_window_extent(renderer) for t in texts]
        for i in range(len(boxes)):
            for j in range(i + 1, len(boxes)):
                assert not boxes[i].overlaps(boxes[j]), (texts[i].get_text(), texts[j].get_text())
        marks = ax.transData.transform([(line.get_xdata()[0], line.get_ydata()[0]) for line in ax.get_lines()
                                        if line.get_marker() in ("o", "*") and len(line.get_xdata()) == 1])
        assert len(marks) == 10
        px = fig.dpi / 72.0
        for b, t in zip(boxes, texts):
            for X, Y in marks:  # 3 points of marker radius must stay clear of every label
                assert not (b.x0 - 3 * px < X < b.x1 + 3 * px and b.y0 - 3 * px < Y < b.y1 + 3 * px), t.get_text()
    legend = [t.get_text() for t in fig.axes[-1].get_legend().get_texts()]
    assert "recommended: A1B1C1F3" in legend and "right: design drive torque" in legend
    assert "left: largest force at joint C" in legend and "force at joint B" not in " ".join(legend)
    torque_colours = {line.get_color() for line in axes[1].get_lines() if line.get_marker() in ("o", "*")}
    assert torque_colours.isdisjoint({c.lower() for c in PAIR_COLOURS.values()} | set(PAIR_COLOURS.values()))
    assert not audit_figure(fig)
    _close(data)


# ---- print resolution, SVG beside, nothing cut at the canvas' edge (issue 45) ------------------------------------
def _inside_canvas(fig) -> list[str]:
    """Texts (axis labels, tick labels, titles) and legends whose drawn extent leaves the canvas."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    W, H = fig.canvas.get_width_height()
    out = []
    artists = [*fig.legends, *fig.texts]
    for ax in fig.axes:
        artists += [ax.xaxis.label, ax.yaxis.label, ax.title, ax._left_title, ax._right_title, *ax.texts]
        for axis in (ax.xaxis, ax.yaxis):  # the tick labels drawn: those inside the axis' view
            lo, hi = sorted(axis.get_view_interval())
            artists += [tk.label1 for tk in axis.get_major_ticks() if lo - 1e-9 * abs(hi - lo) <= tk.get_loc() <= hi
                        + 1e-9 * abs(hi - lo)]
        if ax.get_legend() is not None:
            artists.append(ax.get_legend())
    for a in artists:
        if not a.get_visible() or (hasattr(a, "get_text") and not a.get_text()):
            continue
        b = a.get_window_extent(r)
        if b.x0 < -0.5 or b.y0 < -0.5 or b.x1 > W + 0.5 or b.y1 > H + 0.5:
            out.append(f"{type(a).__name__} {getattr(a, 'get_text', lambda: '')()!r}: {b}")
    return out


def test_figures_print_at_300_dpi_with_an_svg_beside_and_nothing_cut(tmp_path):
    from PIL import Image

    from berryshaker.report.style import PRINT_DPI, canvas_overflow

    t = np.linspace(0, 2 * np.pi, 400)
    pitch = np.array([0.1 * np.cos(t), 0.08 * np.sin(t)])
    res, _, _ = _l9_analysis()
    drawn = [P.plot_groove(pitch, pitch * 0.9, pitch * 1.1, 0.07, tmp_path / "groove_profile.png",
                           return_figure=True),
             P.plot_main_effects(res, tmp_path / "me.png", "Virtual L9", return_figure=True),
             P.plot_bars({"multibody peak": [1.0, 2.0]}, ["none", "0.25 mm"], "collision force at joint A [N]",
                         tmp_path / "bars.png", pair="A", reference_index=0, return_figure=True)]
    assert PRINT_DPI == 300
    for data in drawn:
        fig = data["figure"]
        assert _inside_canvas(fig) == [], data["path"]
        assert max(canvas_overflow(fig)) == 0.0
        png = Image.open(data["path"])
        assert png.info["dpi"] == pytest.approx((300, 300), abs=0.5)
        w, h = fig.get_size_inches()
        assert png.size == (round(w * 300), round(h * 300))
        svg = tmp_path / (data["path"].rsplit("/", 1)[1].replace(".png", ".svg"))
        assert svg.is_file() and svg.read_text(encoding="utf-8").lstrip().startswith("<?xml")
        _close(data)


# ---- Minitab-style effect figures: they draw the analysis table (issue 45) --------------------------------------
def test_pareto_residual_and_interaction_plots_draw_the_analysis_table(tmp_path):
    from pathlib import Path

    from scipy import stats

    from berryshaker.experiment.analysis import interaction_means, main_effect_residuals, standardized_effects
    from berryshaker.experiment.field_results import analyze_sheet

    sheet = Path(__file__).parents[1] / "data" / "minitab_l9_replicated.csv"
    fr, res = analyze_sheet(sheet, {"efficiency": True, "damage": False})
    ra = res.responses["efficiency"]
    y = fr.responses_replicated["efficiency"]
    err = ra.anova.error
    own = {f: (a.error.ms, a.error.df) for f, a in ra.anova.factors.items()}  # each factor against its own error
    eff = standardized_effects(fr.levels, y, fr.factor_names, err.ms, err.df, factor_errors=own)
    for f in fr.factor_names:  # a factor's contrasts carry its ANOVA F: sum of t^2 = df x F
        row = ra.anova.factors[f]
        assert sum(t["t"] ** 2 for t in eff["terms"] if t["factor"] == f) == pytest.approx(row.df * row.f)
    assert eff["critical_t"] == pytest.approx(stats.t.ppf(0.975, min(e[1] for e in own.values())))
    d = P.plot_pareto_effects(eff, tmp_path / "pareto.png", return_figure=True)
    ax = d["figure"].axes[0]
    widths = [p.get_width() for p in sorted(ax.patches, key=lambda p: -p.get_y())]  # top to bottom
    np.testing.assert_allclose(widths, sorted((abs(t["t"]) for t in eff["terms"]), reverse=True))
    assert d["terms"][0] == "C (linear)" and ax.get_lines()[0].get_xdata()[0] == pytest.approx(eff["critical_t"])
    assert not audit_figure(d["figure"])
    _close(d)
    rr = main_effect_residuals(fr.levels, y, fr.factor_names, blocks=True)
    assert rr["ss"] == pytest.approx(err.ss + ra.anova.lack_of_fit.ss)  # error + lack of fit
    order = np.random.default_rng(0).permutation(rr["residuals"].size) + 1  # a test order
    d = P.plot_residuals(rr, tmp_path / "res.png", unit="kg/min", order=order, return_figure=True)
    axn, axf, axh, axo = d["figure"].axes[:4]  # Minitab's four in one (issue 58: the histogram and order were missing)
    np.testing.assert_array_equal(axf.get_lines()[0].get_ydata(), rr["residuals"])
    np.testing.assert_array_equal(axn.get_lines()[0].get_xdata(), np.sort(rr["residuals"]))
    assert axf.get_ylabel() == "residual [kg/min]" and not audit_figure(d["figure"])
    counts, edges = np.histogram(rr["residuals"], bins=len(d["histogram"][0]))
    np.testing.assert_array_equal([p.get_height() for p in axh.patches], counts)
    assert sum(counts) == rr["residuals"].size and axh.get_xlabel() == "residual [kg/min]"
    line = axo.get_lines()[0]
    np.testing.assert_array_equal(line.get_xdata(), np.arange(1, order.size + 1))  # in test order
    np.testing.assert_array_equal(line.get_ydata(), rr["residuals"][np.argsort(order)])
    assert axo.get_xlabel() == "test order [-]"
    _close(d)
    cells = interaction_means(fr.levels, y, fr.factor_names)
    d = P.plot_interactions(cells, tmp_path / "int.png", unit="kg/min", level_values=fr.level_values,
                            factor_units=fr.units, return_figure=True)
    panel = next(a for a in d["figure"].axes if a.get_title().startswith("A x C"))
    obs = y.reshape(-1)
    lv = np.repeat(fr.levels, y.shape[1], axis=0)
    for b, line in enumerate(panel.get_lines(), start=1):  # one line per level of C, over the levels of A
        want = [obs[(lv[:, 0] == a) & (lv[:, 2] == b)].mean() for a in (1, 2, 3)]
        np.testing.assert_allclose(line.get_ydata(), want)
        np.testing.assert_array_equal(line.get_xdata(), [0.25, 0.5, 0.75])
    assert panel.get_xlabel() == "A [mm]" and not audit_figure(d["figure"])
    _close(d)


def test_doe_figures_take_the_sheets_units(tmp_path):
    """`doe analyze --plot` of a Minitab worksheet: axes read the header's units, never "[unit?]"."""
    from pathlib import Path

    from berryshaker.experiment.field_results import analyze_sheet

    text = (Path(__file__).parents[1] / "data" / "minitab_l9_replicated.csv").read_text(encoding="utf-8")
    text = text.replace("C (mm)", "Speed (rpm)").replace(",Unripe (%),Damage (%)", "").splitlines()
    sheet = "\n".join([text[0]] + [",".join(ln.split(",")[:9]) for ln in text[1:]]) + "\n"
    fr, res = analyze_sheet(sheet, {"efficiency": True})
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a label without unit warns
        names = P.write_doe_figures(fr, res, tmp_path)
    assert names == ["main_effects.png", "surface_efficiency.png", "pareto_efficiency.png",
                     "residuals_efficiency.png", "interactions_efficiency.png"]
    for n in names:
        assert (tmp_path / n).is_file() and (tmp_path / n).with_suffix(".svg").is_file()
    svg = (tmp_path / "main_effects.svg").read_text(encoding="utf-8") + (tmp_path / "surface_efficiency.svg").read_text(
        encoding="utf-8")
    assert "unit?" not in svg


def test_signals_one_panel_per_unit_with_the_data_peak(tmp_path):
    """``berryshaker plot``'s figure: one panel per unit, the drawn peak the data's (decimated against time), each
    pair's force in the pair's colour (F_A is pair A, not F), every axis with its unit; a phase plot draws every
    sample."""
    t, y = _impulsive()
    ys = {"F_A": (y, "N"), "F_C": (0.5 * y, "N"), "drive_moment": (np.cos(t), "N m")}
    data = P.plot_signals(("time", t, "s"), ys, tmp_path / "s.png", "signals", return_figure=True)
    fig = data["figure"]
    assert list(data["panels"]) == ["N", "N m"] and data["decimated"]
    for name, (v, unit) in ys.items():
        drawn = data["panels"][unit][name]
        assert drawn["peak_abs"] == drawn["input_peak_abs"] == float(np.max(np.abs(v)))
        assert len(drawn["x"]) < len(t)
    lines = {ln.get_label(): ln for ax in fig.axes for ln in ax.get_lines()}
    assert lines["F_A"].get_color().lower() == PAIR_COLOURS["A"].lower()
    assert lines["F_C"].get_color().lower() == PAIR_COLOURS["C"].lower()
    assert [ax.get_ylabel() for ax in fig.axes[:2]] == ["F_A, F_C [N]", "drive_moment [N m]"]
    assert fig.axes[1].get_xlabel() == "time [s]" and not audit_figure(fig)
    pyplot().close(fig)
    angle = np.linspace(0.0, 2 * np.pi, 500)
    phase = P.plot_signals(("theta_D", np.sin(angle), "rad"), {"T_l": (np.cos(angle), "N m")}, tmp_path / "p.svg")
    assert not phase["decimated"] and len(phase["panels"]["N m"]["T_l"]["x"]) == 500
    assert (tmp_path / "p.svg").read_text().startswith("<?xml") and not (tmp_path / "s.svg").exists()
