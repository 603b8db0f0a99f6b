"""
Your own machine: describe it, check its kinematics, simulate it
================================================================

A harvester is described in a TOML file with units on every dimensional value.  ``berryshaker config init
my.toml`` writes an annotated copy of the reference machine (a groove cam driving a push rod and a double
rocker, docs/study.md) to edit; ``examples/crank_rocker_harvester.toml`` is another drive.  This example edits
that copy in a script, loads and validates it, checks the kinematics of the ideal drive (study eq. 1-3), and
simulates the clearance joints with the reduced (MLSD) model (eq. 4-12).
"""

# %%
# Describe the machine
# --------------------
# Start from the reference description and change what differs on your machine: here a faster cam shaft and
# a longer stroke, and a looser groove at pair A.
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from berryshaker.config import load_machine, reference_toml_text, validate_machine
from berryshaker.drives import drive_of

text = reference_toml_text()
for old, new in [('name = "berryshaker reference harvester"', 'name = "my harvester"'),
                 ('speed = "120 rpm"', 'speed = "135 rpm"'), ('stroke = "40 mm"', 'stroke = "44 mm"')]:
    assert old in text, old
    text = text.replace(old, new, 1)
Path("my_harvester.toml").write_text(text, encoding="utf-8")

machine = load_machine("my_harvester.toml")
machine = machine.with_clearances({"A": 0.4e-3})  # SI inside the package: 0.4 mm
problems = validate_machine(machine)
print(machine.machine.name, "-", "valid" if not problems else problems)
print("clearance sizes (mm):", {p: round(c * 1e3, 3) for p, c in machine.clearance_sizes().items()})

# %%
# Kinematics of the ideal drive
# -----------------------------
# ``check`` refuses a drive that does not assemble over the whole cycle or whose groove undercuts; the
# summary gives the follower law's peaks against their closed forms, the pressure angle, and the swing of
# each comb (what ``berryshaker kinematics`` prints).

drive = drive_of(machine)
kin = drive.check(machine)
summary = drive.kinematics_summary(machine, kin)
cam, combs = summary["cam"], summary["combs"]
print(f"cam: max follower speed {cam['max_velocity_m_s']:.3f} m/s, acceleration "
      f"{cam['max_acceleration_m_s2']:.2f} m/s^2, pressure angle {cam['pressure_angle_deg']['min']:.1f} .. "
      f"{cam['pressure_angle_deg']['max']:.1f} deg")
for side, c in combs.items():
    swing = c["swing_deg"]
    print(f"{side} comb: swing {swing['min']:.2f} .. {swing['max']:.2f} deg, tip speed {c['max_tip_speed_m_s']:.2f} m/s")

# %%
# Clearance joints in the reduced model
# -------------------------------------
# Three cam revolutions of the MLSD model (statistics over revolutions 2 and 3): the collision force of each
# clearance pair and the cam's drive moment (``berryshaker simulate --model mlsd``).
result = drive.reduced_model(machine, machine.clearance_sizes(), revolutions=3)
stats = result.summary()
for pair, st in stats["collision_force_N"].items():
    print(f"pair {pair}: peak {st['peak']:.0f} N, mean {st['mean']:.0f} N, rms {st['rms']:.0f} N")
print(f"drive moment: peak {stats['drive_moment_Nm']['peak']:.1f} N m")

# %%
# The forces of pairs A and C over the last revolution.

period = 2 * np.pi / machine.drive_speed
last = result.t >= result.t[-1] - period
fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
for pair in ("A", "C"):
    ax.plot(result.t[last] * 1e3, np.abs(result.series(f"F_{pair}_N")[last]), label=f"pair {pair}")
ax.set_xlabel("time (ms)")
ax.set_ylabel("collision force (N)")
ax.legend()
plt.show()
