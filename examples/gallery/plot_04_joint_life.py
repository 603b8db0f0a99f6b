"""
Joint life: ISO fit, wear, service interval
===========================================

A pin-in-bore joint of the comb drive (pair C, the connecting-rod pin) is drawn with an ISO 286 fit.  The fit
gives the clearance it starts with; the pin and bore wear by Archard's law under the collision forces the
clearance causes; the service interval is the operating time until the clearance reaches its service limit.
``berryshaker fits`` and ``berryshaker wear`` do the same from the command line (docs/life.md).
"""

# %%
# The fit
# -------
# A 20 mm pin with an H8/f7 fit (hole basis).  ISO 286 gives the limit deviations of hole and shaft; the
# diametral clearance lies between the largest hole on the smallest shaft and the reverse.  The machine
# description's ``size`` of a pin in a bore is the radial clearance, half the diametral one.
import matplotlib.pyplot as plt

from berryshaker.config import load_machine
from berryshaker.life.fits import fit_summary, parse_fit
from berryshaker.life.joint_loads import joint_loads, joint_wear_models
from berryshaker.life.service import service_limits
from berryshaker.life.wear import clearance_size_from_fit
from berryshaker.life.wear import wear_life

fit = parse_fit("20 H8/f7")
limits = fit_summary(fit)
for part in ("hole", "shaft"):
    zone = limits[part]
    print(f"{part} {zone['class']}: {zone['lower_deviation_um']:+g} .. {zone['upper_deviation_um']:+g} um")
print(f"diametral clearance {limits['clearance_min_mm']:.3f} .. {limits['clearance_max_mm']:.3f} mm")
start = clearance_size_from_fit(fit, "pin-in-bore", which="mean")
print(f"radial clearance at the fit's mean: {start * 1e3:.4f} mm")

# %%
# Loads on the joint
# ------------------
# One multibody run of the reference machine with pair C at that clearance gives the normal force and the
# sliding speed of the pin in its bore over a steady revolution (two drive revolutions, the first being the
# start-up).

machine = load_machine()  # the reference machine (groove cam)
loads, outputs = joint_loads(machine, {"C": start}, revolutions=2)
t, force, speed = loads["C"]
print(f"pair C: peak normal force {force.max():.0f} N, mean sliding speed {speed.mean() * 1e3:.1f} mm/s")

# %%
# Wear and the service interval
# -----------------------------
# Archard's law turns force and sliding speed into worn volume, and the pin-in-bore geometry turns volume
# into clearance.  ``wear_life`` advances the clearance in steps of operating hours and asks for the loads at
# each new clearance.  To keep this example to seconds the loads of the run above stand for every
# clearance (a first estimate: the clearance grows linearly); ``berryshaker wear`` re-simulates the machine
# at each step instead.  The service limit is the one ``berryshaker wear`` uses by default.

wear_models = joint_wear_models(machine, joints=["C"])
limit = service_limits(machine, joints=["C"])["C"]
life = wear_life(machine, 20000.0, {"clearance:C": limit}, simulate=lambda clearances: (loads, outputs),
                 joints=wear_models, initial_clearances={"C": start}, max_growth=0.05e-3, stop_at_limits=True)
interval = life.maintenance_interval_hours
print(f"service limit {limit * 1e3:.3f} mm; service interval "
      + ("not reached" if interval is None else f"{interval:.0f} operating hours"))

# %%
# The clearance over the joint's life, with the fit's range and the service limit.

fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
ax.plot(life.hours, life.clearance["C"] * 1e3, "o-", label="pair C, radial clearance")
ax.axhspan(limits["radial_clearance_min_mm"], limits["radial_clearance_max_mm"], alpha=0.2, label="H8/f7 as made")
ax.axhline(limit * 1e3, color="tab:red", ls="--", label="service limit")
ax.set_xlabel("operating hours (h)")
ax.set_ylabel("clearance (mm)")
ax.legend()
plt.show()
