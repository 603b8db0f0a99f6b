"""
The Python API: results as pandas tables
========================================

``berryshaker.api`` is the command line for Python and Jupyter: the same library calls as ``berryshaker
kinematics``, ``simulate``, ``sweep``, ``fits`` and ``doe analyze``, with the results as pandas DataFrames whose
column names carry their units (``"peak_force [N]"``, ``"clearance.C.size [mm]"``).  This example uses nothing
else from berryshaker and takes a few seconds: the reduced (MLSD) model, a sweep of three points, a field sheet
written here (docs/python_api.md).
"""

# %%
# The machine and its kinematics
# ------------------------------
# ``load_machine()`` is the built-in reference machine (a groove cam); ``load_machine("my.toml")`` reads yours
# (``berryshaker config init my.toml`` writes an editable copy).  ``kinematics`` gives one row per cam angle.
import matplotlib.pyplot as plt
import pandas as pd

from berryshaker import api

pd.set_option("display.width", 120)  # wide tables print whole
pd.set_option("display.max_columns", 12)

machine = api.load_machine()
kin = api.kinematics(machine)
swing = kin["left_comb_angle [rad]"]
print(f"{len(kin)} cam angles; left comb swings {(swing.max() - swing.min()) * 180 / 3.141592653589793:.2f} deg; "
      f"push rod peak velocity {kin['push_rod_velocity [m/s]'].abs().max():.3f} m/s")

# %%
# One simulation
# --------------
# ``simulate`` returns a summary per joint and the time series.  Clearances are given with their unit (or as
# numbers in metres); pairs left out keep the description's size.  Two revolutions: the first is the start-up,
# statistics are over the second.
summary, series = api.simulate(machine, clearance={"C": "0.2 mm"}, model="mlsd", revolutions=2)
print(summary.round(1))
print(f"drive moment peak {summary.attrs['summary']['drive_moment_Nm']['peak']:.1f} N m; "
      f"{len(series)} samples of {len(series.columns)} series, e.g. {', '.join(series.columns[5:8])}")

# %%
# A sweep of three points
# -----------------------
# ``sweep`` validates every point's machine, then runs them through the cached runner of ``berryshaker sweep``
# (one row per point).  The cache folder is given here so the example leaves nothing behind it; by default it
# is ``~/.cache/berryshaker/runs``, shared with the command line.
table = api.sweep(machine, {"clearance.C.size": ["0.1 mm", "0.2 mm", "0.3 mm"]}, model="mlsd", revolutions=2,
                  workers=1, cache="berryshaker-runs")
print(table[["clearance.C.size [mm]", "status", "collision_force_C_peak [N]", "collision_force_C_rms [N]",
             "drive_moment_peak [N m]"]].round(1).to_string(index=False))

# %%
# The fit to draw
# ---------------
# Pair C is a pin in a bore.  ``fit_table`` lists ISO 286 fits at its diameter; the machine description's
# ``size`` of a pin is the radial clearance, half the diametral one of the fit tables.
fits = api.fit_table(20.0, ["H7/g6", "H7/f7", "H8/e8", "H9/d9"])
print(fits[["radial_clearance_min [mm]", "radial_clearance_max [mm]"]])
print(api.service_limits(machine))

# %%
# A field test
# ------------
# ``plan_field_sheet`` is ``berryshaker doe plan``: an L9 sheet, here of three clearances with two replicates.
# The responses would be measured in the field; here they are made up from the levels so the example runs
# anywhere.  ``analyze_field_sheet`` takes the filled sheet (a DataFrame or a CSV file) and returns the tables
# of ``berryshaker doe analyze``.
sheet = api.plan_field_sheet({"A": "0.25,0.5,0.75mm", "B": "0.2,0.4,0.6mm", "C": "0.1,0.2,0.3mm"}, replicates=2)
wobble = [0.02 * ((3 * k) % 5 - 2) for k in range(len(sheet))]  # a fixed, repeatable field scatter
sheet["efficiency_kg_min"] = [3.2 + 0.25 * c - 0.05 * a + w
                              for a, c, w in zip(sheet["A_level"], sheet["C_level"], wobble)]
sheet["damage_rate_pct"] = [1.8 + 0.2 * a + 0.03 * b - w
                            for a, b, w in zip(sheet["A_level"], sheet["B_level"], wobble)]
tables = api.analyze_field_sheet(sheet, maximize="efficiency", minimize="damage")
print(tables["range_efficiency"].round(3))
print(tables["optimum_levels"])

# %%
# The figure
# ----------
# Columns with units in their names make labelled plots one line each: the sweep's collision force at C
# against its clearance, and the range of each factor in the field test.
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.8), constrained_layout=True)
for stat, marker in (("peak", "o-"), ("rms", "s-")):
    col = f"collision_force_C_{stat} [N]"
    ax1.plot(table["clearance.C.size [mm]"], table[col], marker, label=stat)
ax1.set_xlabel("clearance.C.size [mm]")
ax1.set_ylabel("collision force at C [N]")
ax1.set_yscale("log")  # peak and rms differ twentyfold
ax1.set_title("sweep (MLSD)")
ax1.legend()
tables["range_efficiency"]["R [kg/min]"].plot.bar(ax=ax2, rot=0)
ax2.set_ylabel("range R of efficiency [kg/min]")
ax2.set_title("field test: which clearance matters")
plt.show()
