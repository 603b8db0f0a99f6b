"""
Sweep a clearance
=================

How do the collision forces grow with the clearance of one pair?  ``berryshaker sweep --param
clearance.A.size=0.1..0.7mm --points 7`` answers it on a grid (or a Latin hypercube, or Monte Carlo over a
tolerance), through a cached, parallel runner.  This example runs the same points through the library, one
after the other, with the reduced (MLSD) model: a fraction of a second per point.
"""

# %%
# The points
# ----------
# A sweep parameter is a dotted key of the machine description with a range and its unit.  Every point's
# machine is validated like a configuration file before the first run (values, clearance limits, assembly
# over the cycle).
import matplotlib.pyplot as plt

from berryshaker.config import load_machine
from berryshaker.runs.sweep import model_run, overrides_of, parse_param, sample_params, validate_points

machine = load_machine()  # the reference machine; load_machine("my.toml") for yours
params = [parse_param("clearance.A.size=0.1..0.7mm", machine)]
points = sample_params(params, "grid", 7, seed=0)
validate_points(machine, params, points, revolutions=3)
print(f"clearance A ({params[0].unit}):", [float(p[0]) for p in points])  # in the parameter's unit

# %%
# The runs
# --------
# ``model_run`` is what each worker of the sweep runs: apply the point's overrides (``overrides_of`` turns the
# point into SI), simulate, summarise.
data = machine.model_dump(mode="json")
summaries = [model_run(data, overrides_of(params, point), model="mlsd", revolutions=3) for point in points]
for point, s in zip(points, summaries):
    f = s["collision_force_N"]
    print(f"A = {point[0]:.2f} mm: peak force A {f['A']['peak']:7.0f} N, B {f['B']['peak']:7.0f} N; "
          f"drive moment peak {s['drive_moment_Nm']['peak']:.1f} N m")

# %%
# Peak and RMS collision force of pair A against its clearance: the impacts grow harder as the roller travels
# further across its groove before it strikes the other wall.

size_mm = [float(p[0]) for p in points]
fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
ax.plot(size_mm, [s["collision_force_N"]["A"]["peak"] for s in summaries], "o-", label="peak")
ax.plot(size_mm, [s["collision_force_N"]["A"]["rms"] for s in summaries], "s-", label="rms")
ax.set_xlabel("clearance A, free travel (mm)")
ax.set_ylabel("collision force at A (N)")
ax.legend()
plt.show()
