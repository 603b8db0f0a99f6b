"""The drawing's numbers (docs/life.md, "The drawing"): the cam groove's width with its running clearance and
tolerance band (:func:`groove_width`, written by ``cam-profile``), and every pair's fit checked against the clearance
the description gives (:func:`fit_checks`, run by ``config validate``).

The described ``size`` of a pair is the clearance the runs use: the study's levels are worn states (0.1-0.75 mm),
while a new machine has its fit's running clearance (tens of micrometres).  A fit therefore may give less than the
described size -- the joint then wears to it, and the note says so -- but never more: a size below the fit's
smallest clearance cannot be built with that fit (it is refused), and a size beyond the pair's service limit is a
worn-out joint (a note).
"""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.errors import ConfigError

#: the groove width's tolerance class when the cam pair gives no fit [assumed]: H8 on the roller diameter (a milled
#: groove's usual class; give ``clearance.<pair>.fit`` to choose it)
DEFAULT_GROOVE_CLASS = "H8"


@dataclass(frozen=True)
class GrooveWidth:
    """The cam groove's width on the drawing (m): roller diameter, width limits and the running clearance.

    Attributes
    ----------
    pair : str
        The roller-in-groove pair.
    roller_diameter : float
        The roller's nominal diameter 2 r_r (m; the groove's nominal width).
    width_min, width_max : float
        The groove width's limits (m): nominal + the hole class's EI and ES.
    clearance_min, clearance_max : float
        Running clearance (free travel, m): width minus roller diameter at the limits of both parts.
    tolerance : str
        The width's tolerance class and where it comes from.
    """

    pair: str
    roller_diameter: float
    width_min: float
    width_max: float
    clearance_min: float
    clearance_max: float
    tolerance: str

    @property
    def width_mean(self) -> float:
        """The width at the middle of its tolerance band (m)."""
        return 0.5 * (self.width_min + self.width_max)

    def note(self) -> str:
        """The width and running clearance in words (mm), for the drawing's title block.

        Returns
        -------
        str
            Width with its deviations, its tolerance and the running clearance (mm).
        """
        d = self.roller_diameter * 1e3
        return (f"groove width {d:.3f} mm +{(self.width_max * 1e3 - d):.3f}/{(self.width_min * 1e3 - d):+.3f} "
                f"({self.tolerance}); running clearance (free travel) {self.clearance_min * 1e3:.3f} .. "
                f"{self.clearance_max * 1e3:.3f} mm with the roller d {d:g} mm")


def groove_width(machine) -> GrooveWidth:
    """The groove width of a groove-cam machine's cam pair from its fit (ISO 286, hole = groove width, shaft =
    roller diameter, at the roller diameter), or, when it gives none, the roller diameter plus the described size
    (the running clearance) plus a band as wide as :data:`DEFAULT_GROOVE_CLASS`'s zone, the roller exact.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description (its roller radius and its roller-in-groove pair).

    Returns
    -------
    GrooveWidth
        Width limits and running clearance (m).

    Raises
    ------
    ConfigError
        A machine without a roller-in-groove pair.
    """
    from berryshaker.life.fits import parse_fit
    from berryshaker.life.iso286_limits import tolerance_zone

    pairs = [p for p in machine.pair_names if machine.clearance[p].kind == "roller-in-groove"]
    if not pairs:
        raise ConfigError("cam-profile: the machine has no roller-in-groove clearance pair")
    p = pairs[0]
    d = 2.0 * machine.cam.roller_radius
    fit = machine.clearance[p].fit
    if fit:
        f = parse_fit(fit, d * 1e3)
        if f.hole is not None:
            return GrooveWidth(p, d, f.hole.min_size, f.hole.max_size, f.clearance_min, f.clearance_max,
                               f"{f.hole.designation} of clearance.{p}.fit = {fit!r}, roller {f.shaft.designation}")
        lo, hi = f.clearance_min, f.clearance_max  # an explicit range: the roller exact
        return GrooveWidth(p, d, d + lo, d + hi, lo, hi, f"clearance.{p}.fit = {fit!r}, roller exact")
    # no fit: the described size is the running clearance, the width's band the width of an H8 zone above it
    size = machine.clearance[p].size
    band = tolerance_zone(DEFAULT_GROOVE_CLASS, d * 1e3).tolerance_um * 1e-6
    return GrooveWidth(p, d, d + size, d + size + band, size, size + band,
                       f"the described running clearance clearance.{p}.size = {size * 1e3:g} mm plus an "
                       f"{DEFAULT_GROOVE_CLASS}-wide band ({band * 1e6:.0f} um) [assumed: clearance.{p}.fit not given], "
                       "roller exact")


def fit_checks(machine) -> tuple[list[str], list[str]]:
    """Every pair's fit against its described clearance: errors (a fit that cannot give it) and notes (why it may).

    Parameters
    ----------
    machine : MachineBase
        The machine description.

    Returns
    -------
    (list of str, list of str)
        Errors naming the field and the fix; notes for pairs whose size is a worn state of their fit or beyond
        their service limit.
    """
    from berryshaker.life.fits import parse_fit
    from berryshaker.life.joint_loads import joint_geometry
    from berryshaker.life.service import service_limits
    from berryshaker.life.wear import clearance_size_from_fit

    errors, notes = [], []
    limits = service_limits(machine)
    for p in machine.pair_names:
        pair = machine.clearance[p]
        g = joint_geometry(machine, p)
        size = pair.size
        conv = "radial" if g.is_pin else "free travel"
        if size > limits[p]:
            notes.append(f"{p}: size {size * 1e3:g} mm ({conv}) is beyond the pair's service limit "
                         f"{limits[p] * 1e3:g} mm: a worn-out joint, outside the range the harvest was tested in")
        if not pair.fit:
            continue
        f = parse_fit(pair.fit, g.diameter * 1e3)
        kind = "revolute" if g.is_pin else "point-line"
        lo, hi = (clearance_size_from_fit(f, kind, w) for w in ("min", "max"))
        if size == 0.0:
            continue  # an ideal joint: the fit is the drawing's, the runs close the clearance
        if size < lo:
            errors.append(f"clearance.{p}.fit = {pair.fit!r} gives {lo * 1e3:.4g} .. {hi * 1e3:.4g} mm ({conv}) at "
                          f"{g.diameter * 1e3:g} mm, more than the described size {size * 1e3:g} mm: no part made to "
                          f"it is that tight; give a tighter fit or a size of at least {lo * 1e3:.4g} mm")
        elif size > hi:
            notes.append(f"{p}: size {size * 1e3:g} mm is a worn state of the fit {pair.fit} (new "
                         f"{lo * 1e3:.4g} .. {hi * 1e3:.4g} mm {conv}): the joint wears to it before the "
                         f"service limit {limits[p] * 1e3:g} mm")
    return errors, notes
