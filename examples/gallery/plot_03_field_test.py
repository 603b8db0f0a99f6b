"""
Field test: plan an L9 sheet, fill it, analyse it
=================================================

The study tuned its harvester with an orthogonal field test (study sec. 2.6, 3.5): three factors at three
levels in an L9 array, each run timed and its berries weighed.  ``berryshaker doe plan`` writes the sheet and
``berryshaker doe analyze`` reads it back; this example does both through the library, with results made up
from a known response so the analysis can be checked against it.
"""

# %%
# Plan the sheet
# --------------
# Three factors with their levels and units, an L9 array and two replicates of each run (a replicate is a
# block: a field day or a row of bushes shared by every run).  The sheet has one row per run and replicate,
# the levels in the units given, and empty response columns for the field crew.
import matplotlib.pyplot as plt
import numpy as np

from berryshaker.experiment.field_results import analyze_sheet
from berryshaker.experiment.field_sheet import parse_factor, plan_table

factors = [
    parse_factor("clearance_A=0.25,0.5,0.75mm"),
    parse_factor("speed=100,120,140rpm"),
    parse_factor("amplitude=30,40,50mm"),
]
sheet = plan_table("L9", factors, replicates=2)
print(sheet[["run", "replicate", "order", "clearance_A_mm", "speed_rpm", "amplitude_mm"]].to_string(index=False))

# %%
# Fill in synthetic results
# -------------------------
# In the field the crew writes the time of each run and the masses of picked, unripe and damaged fruit.
# Here a made-up response stands in: picking grows with speed and amplitude, damage grows with speed and
# clearance, and each replicate (block) shifts every run alike, with a little noise on top.
rng = np.random.default_rng(7)
speed = sheet["speed_rpm"].to_numpy()
amplitude = sheet["amplitude_mm"].to_numpy()
clearance = sheet["clearance_A_mm"].to_numpy()
block = np.where(sheet["replicate"].to_numpy() == 1, 0.0, 0.15)

sheet["duration_s"] = 60.0
sheet["picked_mass_kg"] = 2.0 + 0.012 * (speed - 100) + 0.02 * (amplitude - 30) + block + rng.normal(0, 0.03, len(sheet))
sheet["unripe_mass_kg"] = 0.10 + 0.002 * (amplitude - 30) + rng.normal(0, 0.005, len(sheet))
sheet["damaged_mass_kg"] = 0.05 + 0.001 * (speed - 100) + 0.2 * (clearance - 0.25) + rng.normal(0, 0.004, len(sheet))
sheet.to_csv("field_sheet.csv", index=False)

# %%
# Analyse it
# ----------
# ``analyze_sheet`` reads the sheet as ``doe analyze`` does: the harvest indexes (efficiency in kg/min, unripe
# and damage rates in %) from the masses, and, with replicates, a randomised-complete-block analysis whose
# error is the run x replicate interaction.  The senses say which way is better.

results, analysis = analyze_sheet("field_sheet.csv", {"efficiency": True, "unripe": False, "damage": False})
print(f"{results.replicates} replicates of {len(results.levels)} runs; factors {results.factor_names}")
print(analysis.text)

# %%
# Main effects
# ------------
# The mean of each response at each level of each factor, the picture behind the analysis: efficiency should
# climb with speed and amplitude, damage with speed and clearance, as the made-up response says.

sheet["efficiency"] = sheet["picked_mass_kg"] / (sheet["duration_s"] / 60.0)
sheet["damage"] = 100.0 * sheet["damaged_mass_kg"] / sheet["picked_mass_kg"]
fig, axes = plt.subplots(2, 3, figsize=(9, 5), sharey="row", constrained_layout=True)
for j, (col, label) in enumerate([("clearance_A_mm", "clearance A (mm)"), ("speed_rpm", "speed (r/min)"),
                                  ("amplitude_mm", "amplitude (mm)")]):
    means = sheet.groupby(col)[["efficiency", "damage"]].mean()
    axes[0, j].plot(means.index, means["efficiency"], "o-")
    axes[1, j].plot(means.index, means["damage"], "s-", color="tab:red")
    axes[1, j].set_xlabel(label)
axes[0, 0].set_ylabel("efficiency (kg/min)")
axes[1, 0].set_ylabel("damage rate (%)")
fig.suptitle("Main effects of the synthetic L9 field test")
plt.show()
