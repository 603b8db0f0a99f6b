"""Convergence of the fruit force with the number of branch modes kept in the coupled simulation.

The study's eq. 16 (m0 x branch acceleration) does not converge with modes under the comb's point
impacts: the branch acceleration at the fruit contains the direct (feed-through) response to the
sub-millisecond contact force, sum_k phi_k(z_m) phi_k(z_c) F(t), whose terms do not decay with k (it
tends to a spatial delta function).  The stem force of a fruit on a compliant pedicel
(berryshaker.plant.pedicel) sees the branch through the transfer function (k + i w c)/(k - m w^2 + i w c),
which falls as 1/w^2 above the stem frequency, so each added mode contributes less: the force converges.
:func:`fruit_force_convergence` measures it on a machine description.
"""

from __future__ import annotations

import time

import numpy as np

from berryshaker.config import Machine, machine_from_dict


def fruit_force_convergence(machine: Machine, modes=(8, 16, 24, 30), clearance: dict | None = None,
                            rtol: float = 1e-6) -> list[dict]:
    """Peak stem force and eq. 16 force at each fruit position against the number of branch modes.

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.
    modes : sequence of int
        Mode counts to run (the engine caps them at 30: multibody.spec.ModalBodySpec via
        plant.contact.n_modes le=30).
    clearance : dict, optional
        Clearance sizes (m) for the run.
    rtol : float
        Integrator tolerance.

    Returns
    -------
    list of dict
        One row per mode count: ``n_modes``, ``highest_mode_hz``, ``wall_time_s``, and per fruit name
        ``<name>_stem_N`` (peak stem force), ``<name>_rigid_N`` (eq. 16 peak), ``<name>_stem_rel`` (stem
        force relative to the row with the most modes, minus 1), ``contact_peak_N`` (largest comb force).
    """
    from berryshaker.harvest.coupled import simulate_fruit_force
    from berryshaker.plant.modes import branch_modes

    rows = []
    for n in modes:
        d = machine.model_dump()
        d["plant"]["contact"]["n_modes"] = int(n)
        m = machine_from_dict(d)
        t0 = time.perf_counter()
        r = simulate_fruit_force(m, clearance, rtol=rtol)
        row = {"n_modes": int(n), "wall_time_s": time.perf_counter() - t0,
               "highest_mode_hz": float(branch_modes(m.plant.branch, int(n)).frequency_hz[-1]),
               "contact_peak_N": float(max(np.max(f) for f in r.contact_force.values()))}
        for name in r.fruit_force:
            row[f"{name}_stem_N"] = float(np.max(np.abs(r.fruit_force[name])))
            row[f"{name}_rigid_N"] = float(np.max(np.abs(r.rigid_force[name])))
        rows.append(row)
    ref = rows[int(np.argmax([r["n_modes"] for r in rows]))]
    for row in rows:
        for key in [k for k in row if k.endswith("_stem_N")]:
            row[key.replace("_stem_N", "_stem_rel")] = row[key] / ref[key] - 1.0
    return rows


def smallest_converged_modes(rows: list[dict], tolerance: float = 0.03) -> int:
    """Smallest mode count whose stem forces are all within ``tolerance`` of the row with the most modes."""
    ok = [r["n_modes"] for r in rows
          if all(abs(v) <= tolerance for k, v in r.items() if k.endswith("_stem_rel"))]
    return min(ok)
