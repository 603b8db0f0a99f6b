"""The result of a multibody run: its written series, peaks, first impacts and integrator statistics, with the
per-joint summary of ``simulate --mechanism``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from berryshaker.multibody import layout as L
from berryshaker.multibody.compiled import CompiledMechanism
from berryshaker.multibody.energy import energy_audit


@dataclass
class MultibodyResult:
    """A multibody run: the written series (times, states, element outputs, multipliers), every element's peak
    force, first impact and impact count (``first``, ``layout.FIRST_*``), the integrator's statistics (``info``,
    ``layout.INFO_*``), the integration's wall time, the start of the statistics window and the compiled
    mechanism.

    Attributes
    ----------
    t : numpy.ndarray
        Output times (s).
    y : numpy.ndarray
        States at the output times (m, rad; m/s, rad/s).
    elements : numpy.ndarray
        Element outputs (``layout.EO_*``: normal force N or torque N m, penetration m, its rate m/s, tangential
        force N).
    multipliers : numpy.ndarray
        Lagrange multipliers (N, N m).
    peaks : numpy.ndarray
        Largest |normal force| of each element over the statistics window (N).
    first : numpy.ndarray
        First contact of each element (``layout.FIRST_*``: s, m/s, N, flag, count).
    info : numpy.ndarray
        The integrator's statistics (``layout.INFO_*``: counts, time s, status, residual m).
    wall_time_s : float
        Wall time of the integration (s).
    stats_from : float
        Start of the statistics window (s).
    compiled : CompiledMechanism
        The compiled mechanism.
    """

    t: np.ndarray
    y: np.ndarray  # (n_out, 2n)
    elements: np.ndarray  # (n_out, nf, 4): normal force, penetration, its rate, tangential force
    multipliers: np.ndarray  # (n_out, m)
    peaks: np.ndarray
    first: np.ndarray
    info: np.ndarray
    wall_time_s: float
    stats_from: float
    compiled: CompiledMechanism = field(repr=False)

    def element_force(self, name: str) -> np.ndarray:
        """Normal force (or torque) of force element ``name`` at every output sample.

        Parameters
        ----------
        name : str
            The force element.

        Returns
        -------
        numpy.ndarray
            Normal force (N) or torque (N m) at every output sample.
        """
        return self.elements[:, self.compiled.frc_names.index(name), L.EO_FN]

    def reaction(self, name: str) -> np.ndarray:
        """Magnitude of the reaction force of an ideal joint (from its Lagrange multipliers), N.

        Parameters
        ----------
        name : str
            The ideal joint or driver.

        Returns
        -------
        numpy.ndarray
            Reaction force (N) or a driver's torque (N m) at every output sample.
        """
        k = self.compiled.con_names.index(name)
        r0, nr = self.compiled.con_rows[k]
        typ = self.compiled.model.ctype[k]
        lam = self.multipliers[:, r0:r0 + nr]
        if typ == L.CON_PRISMATIC:
            return np.abs(lam[:, 1])
        if typ == L.CON_DRIVER:
            return -lam[:, 0]  # torque applied by the driver on its body (N m)
        return np.sqrt(np.sum(lam**2, axis=1))

    def contact_onsets(self, names=None) -> dict[str, int]:
        """Impacts per clearance element over the statistics window: the integrator's located contact onsets
        (separated -> in contact on an accepted step) whose approach speed is at least
        :data:`berryshaker.multibody.contact_events.IMPACT_COUNT_SPEED` (1 mm/s).

        Counted by the integrator on every step, so the count does not depend on the output grid (the written
        series at 0.1 ms missed ~11 % of the onsets of the reference harvester).  Closings slower than 1 mm/s (a
        pin settling into its bore) are not impacts: their number moves with the tolerance (docs/multibody.md,
        "Impacts").  Not the count of steps cut back to an onset (``info[INFO_CUTS]``, ``event_cuts`` in
        :meth:`summary`), which counts every refinement.  ``names``: the elements to count (default every
        clearance element); a name that is no clearance element (e.g. a pair closed to an ideal joint) has none.

        Parameters
        ----------
        names : list of str, optional
            The elements to count (default every clearance element).

        Returns
        -------
        dict of str to int
            Impacts per element.
        """
        cm = self.compiled
        if names is None:
            names = [n for n, kind in zip(cm.frc_names, cm.frc_kinds) if kind.endswith("_clearance")]
        out = {}
        for name in names:
            if name not in cm.frc_names or not cm.frc_kinds[cm.frc_names.index(name)].endswith("_clearance"):
                out[name] = 0
                continue
            out[name] = int(self.first[cm.frc_names.index(name), L.FIRST_IMPACTS])
        return out

    def contact_episodes(self, name: str):
        """The contact episodes of a clearance element over the statistics window (the integrator's log:
        onset, approach speed, peak force, impulse, duration; :class:`~berryshaker.multibody.impacts.ContactEpisodes`).

        Parameters
        ----------
        name : str
            The force element.

        Returns
        -------
        ContactEpisodes
            Its episodes (none for an element that is not a contact, or a run without a log).
        """
        from berryshaker.multibody.impacts import episodes_from_log

        k = self.compiled.frc_names.index(name)
        return episodes_from_log(self.first[k], float(self.t[-1]) - self.stats_from)

    def summary(self) -> dict:
        """The JSON of ``simulate --mechanism``: per joint force statistics (clearance joints: contact
        fraction, first impact, ``contact_onsets``), driver torques, integrator statistics.

        The onset keys mean what they mean in the harvester summaries (``drives.simulation``):
        ``contact_onsets`` impacts per clearance joint (:meth:`contact_onsets`: located onsets closing at
        >= 1 mm/s over the statistics window), ``contact_onsets_located`` their total, ``event_cuts`` the integrator steps cut
        back to an onset over the whole run (every refinement counts).

        Returns
        -------
        dict
            Per joint and driver statistics (forces N, torques N m, times s), integrator statistics.
        """
        cm = self.compiled
        onsets = self.contact_onsets()
        sel = self.t >= self.stats_from - 1e-12
        out = {"model": "multibody", "mechanism": cm.spec.mechanism.name, "joints": {}, "drivers": {},
               "duration_s": float(self.t[-1]),
               "statistics_over": (f"t >= {self.stats_from:.6g} s (whole driver revolutions after the first)"
                                   if self.stats_from > 0 else "the whole run"),
               "steps": int(self.info[L.INFO_ACCEPTED]), "rejected_steps": int(self.info[L.INFO_REJECTED]),
               "contact_onsets": onsets, "contact_onsets_located": int(sum(onsets.values())),
               "event_cuts": int(self.info[L.INFO_CUTS]),
               "max_constraint_residual": float(self.info[L.INFO_MAX_RESIDUAL]), "wall_time_s": self.wall_time_s}
        for k, (name, kind) in enumerate(zip(cm.frc_names, cm.frc_kinds)):
            if not kind.endswith("_clearance"):
                continue
            f = np.abs(self.elements[sel, k, L.EO_FN])
            pen = self.elements[:, k, L.EO_PEN]
            entry = {"type": kind, "force_N": _stats(f, self.peaks[k]),
                     "contact_fraction": float(np.mean(pen[sel] > 0)), "contact_onsets": onsets[name]}
            if self.first[k, L.FIRST_DONE] > 0:
                entry["first_impact"] = {"time_s": float(self.first[k, L.FIRST_TIME]),
                                         "impact_velocity_m_s": float(self.first[k, L.FIRST_V_IMP]),
                                         "peak_force_N": float(self.first[k, L.FIRST_PEAK])}
            out["joints"][name] = entry
        if cm.acc_start >= 0:
            out["energy"] = energy_audit(self)
        for k, name in enumerate(cm.con_names):
            typ = cm.model.ctype[k]
            if typ == L.CON_DRIVER:
                tq = self.reaction(name)[sel]
                out["drivers"][name] = {"torque_Nm": {"peak": float(np.max(np.abs(tq))), "mean": float(np.mean(tq)),
                                                      "rms": float(np.sqrt(np.mean(tq**2)))}}
            else:
                f = self.reaction(name)[sel]
                out["joints"][name] = {"type": _CON_KIND[typ], "force_N": _stats(f, 0.0)}
        return out


_CON_KIND = {L.CON_REVOLUTE: "revolute", L.CON_PRISMATIC: "prismatic", L.CON_POINT_LINE: "point_on_line",
             L.CON_CAM_ROLLER: "cam_roller"}


def _stats(f: np.ndarray, peak: float) -> dict:
    if f.size == 0:
        return {"peak": float(peak), "mean": 0.0, "rms": 0.0, "p50": 0.0, "p95": 0.0, "p99": 0.0}
    p50, p95, p99 = np.percentile(f, (50, 95, 99))  # one partition for the three (the same order statistics)
    return {"peak": float(max(peak, f.max())), "mean": float(f.mean()), "rms": float(np.sqrt(np.mean(f**2))),
            "p50": float(p50), "p95": float(p95), "p99": float(p99)}
