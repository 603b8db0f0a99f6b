"""Two (or more) machine descriptions side by side: comb swing, collision force per clearance pair, drive moment,
comb load moments and, optionally, the fruit force of a drive-past.  Drives may differ (a groove cam beside a
crank-rocker): pairs are listed by each machine's own names."""

from __future__ import annotations


def compare_machines(machines: dict[str, object], revolutions: int = 3, fruit_force: bool = True) -> dict:
    """Simulate each machine (multibody model, its configured clearances) and collect comparable numbers.

    Parameters
    ----------
    machines : dict
        Label -> machine description.
    revolutions : int
        Drive-shaft revolutions of the multibody run (statistics over 2..N).
    fruit_force : bool
        Also drive each machine past its branch (slower: one coupled run each).

    Returns
    -------
    dict
        Per label: ``drive``, ``comb_swing_deg`` (left, right: peak-to-peak), ``comb_frequency_hz``,
        ``collision_force_N`` (per pair: static_equivalent, mean, rms and peak, the extreme), ``drive_moment_Nm``
        (design, fatigue_equivalent, rms, mean and peak, the extreme),
        ``load_moment_Nm`` (left, right: rms) and, with ``fruit_force``, ``fruit_force_peak_N`` per position.
    """
    from berryshaker.drives import drive_of
    from berryshaker.drives.simulation import simulate_multibody

    out = {}
    for label, m in machines.items():
        drive = drive_of(m)
        kin = drive.kinematics_summary(m, drive.check(m))
        _, s = simulate_multibody(m, None, revolutions=revolutions)
        row = {
            "drive": m.DRIVE, "machine": m.machine.name,
            "comb_swing_deg": {side: kin["combs"][side]["swing_deg"]["max"] - kin["combs"][side]["swing_deg"]["min"]
                               for side in ("left", "right")},
            "comb_frequency_hz": kin["drive"]["comb_frequency_hz"],
            "clearance_mm": s["clearance_mm"], "collision_force_N": s["collision_force_N"],
            "drive_moment_Nm": s["drive_moment_Nm"],
            "load_moment_Nm": {side: v["rms"] for side, v in s["load_moment_Nm"].items()},
        }
        if fruit_force and m.plant is not None:
            from berryshaker.harvest.coupled import simulate_fruit_force

            ff = simulate_fruit_force(m, None).summary()
            row["fruit_force_peak_N"] = {n: p["peak_force_N"] for n, p in ff["positions"].items()}
        out[label] = row
    return out
