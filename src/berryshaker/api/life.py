"""The Python API of the machine's life: :func:`fit_table` (``berryshaker fits``), :func:`service_limits` (``wear``'s
default limits) and :func:`wear` (``wear``), laid out as :class:`pandas.DataFrame` objects whose column names carry
their units in brackets (see :mod:`berryshaker.api`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from berryshaker.api.names import _names
from berryshaker.errors import ConfigError


# ---- life: fits, service limits, wear --------------------------------------------------------------------
def fit_table(size_mm: float, fits: str | Sequence[str] | None = None) -> pd.DataFrame:
    """Limits and clearances of ISO 286 fits at one nominal diameter, as ``berryshaker fits`` (one row per fit).

    A thin call of :func:`berryshaker.life.fits.parse_fit` and :func:`berryshaker.life.fits.fit_summary`.

    Parameters
    ----------
    size_mm : float
        Nominal diameter (mm), 0 < size_mm <= 500.
    fits : str or sequence of str, optional
        Fit designations, e.g. ``["H7/f7", "H8/e8"]`` or ``"H7/f7,H8/e8"``, or explicit diametral ranges
        (``"0.02..0.06 mm"``); default the candidates of ``berryshaker tolerance``
        (:data:`berryshaker.life.tolerance.CANDIDATE_FITS`).

    Returns
    -------
    pandas.DataFrame
        One row per fit (index ``fit``): ``nominal [mm]``, ``kind`` (clearance, transition...), ``basis``,
        ``hole``, ``hole_upper_deviation [um]``, ``hole_lower_deviation [um]``, ``hole_tolerance [um]``, the same
        of the ``shaft`` (NaN for a range), then the DIAMETRAL clearance ``clearance_min [mm]``,
        ``clearance_max [mm]``, ``clearance_mean [mm]`` and the RADIAL one (half; the ``size`` of a pin in a bore
        in a machine description) ``radial_clearance_min [mm]``, ``radial_clearance_max [mm]``.

    Raises
    ------
    ConfigError
        A designation ISO 286 does not define here, or a size outside 0..500 mm.

    Examples
    --------
    >>> from berryshaker import api
    >>> float(api.fit_table(20.0, ["H7/f7"]).loc["H7/f7", "clearance_max [mm]"])
    0.062
    """
    from berryshaker.life.fits import fit_summary, parse_fit

    if fits is None:
        from berryshaker.life.tolerance import CANDIDATE_FITS

        fits = list(CANDIDATE_FITS)
    names = _names(fits, "fits")
    if not names:
        raise ConfigError("fits: name at least one fit, e.g. ['H7/f7', 'H8/e8']")
    if isinstance(size_mm, bool) or not isinstance(size_mm, (int, float, np.floating, np.integer)):
        raise ConfigError(f"size_mm={size_mm!r}: give the nominal diameter in mm as a number, e.g. 20.0")
    rows = []
    for name in names:
        s = fit_summary(parse_fit(name, float(size_mm)))
        row = {"fit": name, "nominal [mm]": math.nan if s["nominal_mm"] is None else s["nominal_mm"],
               "kind": s["kind"], "basis": s["basis"]}
        for part in ("hole", "shaft"):
            z = s[part] or {}
            row[part] = z.get("class")
            row[f"{part}_upper_deviation [um]"] = z.get("upper_deviation_um", math.nan)
            row[f"{part}_lower_deviation [um]"] = z.get("lower_deviation_um", math.nan)
            row[f"{part}_tolerance [um]"] = z.get("tolerance_um", math.nan)
        for key in ("clearance_min", "clearance_max", "clearance_mean", "radial_clearance_min",
                    "radial_clearance_max"):
            row[f"{key} [mm]"] = s[f"{key}_mm"]
        rows.append(row)
    return pd.DataFrame(rows).set_index("fit")


def service_limits(machine, joints: str | Sequence[str] | None = None) -> pd.DataFrame:
    """The clearance at which each joint is due for service, the default limit of ``berryshaker wear``.

    A thin call of :func:`berryshaker.life.service.service_limits`: the smaller of the joint's largest test level
    and 2.5 % of its pin (roller) diameter, never its built size (docs/life.md, "Service limit").

    Parameters
    ----------
    machine : MachineBase
        A machine description (:func:`~berryshaker.api.load_machine`).
    joints : str or sequence of str, optional
        Clearance pairs (default every pair).

    Returns
    -------
    pandas.DataFrame
        One row per joint (index ``joint``): ``design_size [mm]`` (radial for a pin, free travel for a roller),
        ``largest_test_level [mm]`` and ``service_limit [mm]``.

    Raises
    ------
    ConfigError
        A joint that is not a clearance pair of the machine.

    Examples
    --------
    >>> from berryshaker import api
    >>> limits = api.service_limits(api.load_machine())
    >>> bool((limits["service_limit [mm]"] <= limits["largest_test_level [mm]"]).all())
    True
    """
    from berryshaker.life.service import service_limits as limits_of

    limits = limits_of(machine, _names(joints, "joints") or None)
    sizes, levels = machine.clearance_sizes(), machine.clearance_levels()
    return pd.DataFrame([{"joint": j, "design_size [mm]": sizes[j] * 1e3,
                          "largest_test_level [mm]": max(levels[j]) * 1e3, "service_limit [mm]": v * 1e3}
                         for j, v in limits.items()]).set_index("joint")


def wear(machine, hours: float = 2000.0, joints: str | Sequence[str] | None = None,
         limits: Mapping[str, float] | None = None, revolutions: int = 2, load_direction: str = "fixed",
         slip: float | None = None, from_fit: bool = False,
         cache: str | Path | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Clearance growth of the joints by Archard wear and the maintenance interval, as ``berryshaker wear``.

    A thin call of :func:`berryshaker.life.service.machine_wear`: it simulates the multibody drive, wears the
    joints in adaptive steps of operating hours and re-simulates.  Cost: one multibody run per wear state (a few
    seconds each, often ten or more states); each is cached, so a repeated call is fast.

    Parameters
    ----------
    machine : MachineBase
        A machine description (:func:`~berryshaker.api.load_machine`).
    hours : float
        Operating hours to simulate (h).
    joints : str or sequence of str, optional
        Joints that wear (default every pair); the others stay at their size.
    limits : dict, optional
        Limits keyed ``"clearance:<joint>"`` (m), ``"peak_force:<joint>"`` or ``"mean_force:<joint>"`` (N), or an
        output name (SI); default each wearing joint's :func:`service_limits`.
    revolutions : int
        Drive revolutions per simulation.
    load_direction : {"fixed", "rotating"}
        Load direction on the pins (fixed is conservative).
    slip : float, optional
        Roller slip ratio (1; default :data:`berryshaker.life.joint_loads.DEFAULT_SLIP`).
    from_fit : bool
        Start each wearing joint from its fit's mean clearance, not its size.
    cache : str or Path, optional
        Run cache folder (default ``~/.cache/berryshaker/runs``).

    Returns
    -------
    joints : pandas.DataFrame
        One row per joint (index ``joint``): ``wears``, ``material_pair``, ``size_convention``, ``fit``,
        ``diameter [mm]``, ``bearing_length [mm]``, ``start_clearance [mm]``, ``end_clearance [mm]`` and
        ``maintenance_interval [h]`` (NaN: not reached).  ``joints.attrs["result"]`` holds the command's whole
        result (limits, governing limit, simulations, message).
    history : pandas.DataFrame
        One row per joint and wear state: ``joint``, ``hours [h]``, ``clearance [mm]`` and, for a wearing joint,
        ``design_force [N]`` (the static-equivalent load), ``peak_force [N]`` (the largest sample, an extreme),
        ``mean_force [N]``, ``growth_rate [um/h]``.

    Raises
    ------
    ConfigError
        Hours outside (0, 1e7], or a joint that is not a clearance pair.

    Examples
    --------
    >>> from berryshaker import api
    >>> joints, history = api.wear(api.load_machine(), hours=500.0, joints=["C"])  # doctest: +SKIP
    >>> history[history["joint"] == "C"].plot(x="hours [h]", y="clearance [mm]")  # doctest: +SKIP
    """
    from berryshaker.life.service import machine_wear
    from berryshaker.runs.runner import SweepRunner

    if isinstance(hours, bool) or not isinstance(hours, (int, float, np.floating, np.integer)) or not (
            math.isfinite(hours) and 0 < hours <= 1e7):
        raise ConfigError(f"hours={hours!r}: expected operating hours in (0, 1e7]")
    names = _names(joints, "joints")
    unknown = [j for j in names if j not in machine.pair_names]
    if unknown:
        raise ConfigError(f"joints: {', '.join(unknown)} not a clearance pair of {machine.machine.name}; pairs: "
                          f"{', '.join(machine.pair_names)}")
    with SweepRunner(workers=1, cache_dir=cache, progress=False) as runner:
        res = machine_wear(machine, float(hours), dict(limits) if limits else None, runner=runner,
                           revolutions=revolutions, load_direction=load_direction, slip=slip,
                           joints=names or None, from_fit=from_fit)
    rows, hist = [], []
    for j, d in res["joints"].items():
        mi = d["maintenance_interval_h"]
        rows.append({"joint": j, "wears": d["wears"], "material_pair": d["material_pair"],
                     "size_convention": d["size_convention"], "fit": d["fit"], "diameter [mm]": d["diameter_mm"],
                     "bearing_length [mm]": d["bearing_length_mm"], "start_clearance [mm]": d["clearance_mm"][0],
                     "end_clearance [mm]": d["clearance_mm"][-1],
                     "maintenance_interval [h]": math.nan if mi is None else mi})
        for k, h in enumerate(d["hours"]):
            hist.append({"joint": j, "hours [h]": h, "clearance [mm]": d["clearance_mm"][k],
                         "design_force [N]": d["design_force_N"][k] if d["wears"] else math.nan,
                         "peak_force [N]": d["peak_force_N"][k] if d["wears"] else math.nan,
                         "mean_force [N]": d["mean_force_N"][k] if d["wears"] else math.nan,
                         "growth_rate [um/h]": d["growth_rate_um_per_h"][k] if d["wears"] else math.nan})
    summary = pd.DataFrame(rows).set_index("joint")
    summary.attrs["result"] = res
    return summary, pd.DataFrame(hist)
