"""The reference study's published numbers, in one place (docs/study.md).  Nothing else types them.

Everything here is from the study's text [study], or, where its tables were lost, the reconstruction
documented in docs/study.md ("The reference machine"; marked [reconstructed]).  Units are in the names.
"""

from __future__ import annotations

#: clearance pairs of the study's machine, in transmission order
PAIRS = ("A", "B", "C", "F")

#: clearance levels 1/2/3 (mm) of the lost Table 5 [reconstructed; consistent with the optimum and regression]
CLEARANCE_LEVELS_MM: dict[str, tuple[float, float, float]] = {
    "A": (0.25, 0.50, 0.75),
    "B": (0.20, 0.40, 0.60),
    "C": (0.10, 0.15, 0.20),
    "F": (0.10, 0.15, 0.20),
}

#: the study's model-check case (Table 3): every pair at this level [study]
MODEL_CHECK_LEVEL = 2

#: eq. 18 F values of the MLSD-vs-ADAMS comparison and their critical values, per pair [study]
EQ18_F = {"A": (2.3153, 3.20), "B": (2.5109, 3.15), "C": (2.1335, 3.089), "F": (4.6904, 3.092)}

#: the field test's chosen combination and what it gave [study]
CHOSEN_LEVELS = {"A": 1, "B": 1, "C": 1, "F": 3}
CHOSEN_CODE = "A1B1C1F3"
FIELD_RESULT = {"efficiency_kg_min": 3.93, "unripe_rate_pct": 3.1, "damage_rate_pct": 2.8}

#: best level combination per index in the range analysis [study]
BEST_PER_INDEX = {"efficiency": "A1B1C1F3", "unripe": "A1B1C2F1", "damage": "A1B1C2F3"}

#: index senses and the study's priority Y1 (efficiency) > Y3 (damage) > Y2 (unripe) as weights [study order;
#: the numeric weights are ours, assumed]
SENSES = {"efficiency": True, "unripe": False, "damage": False}
PRIORITY_WEIGHTS = {"efficiency": 0.5, "damage": 0.3, "unripe": 0.2}

#: slider clearance at which efficiency peaks (claim 7) [study]
EFFICIENCY_PEAK_B_MM = 0.4

#: fruit harvesting force ranges (N) at the root, middle and end of a branch (claim 5) [study]
FRUIT_FORCE_N = {"root": (0.25, 0.4), "middle": (0.65, 0.9), "end": (0.8, 1.2)}

#: bond force ranges of eq. 17: ripe fruit Fa, unripe fruit Fb (N) [study]
RIPE_BOND_N = (0.26, 0.30)
UNRIPE_BOND_N = (1.0, 3.6)

#: field settings [study]
WALKING_SPEED_M_MIN = 30.0
CAM_SPEED_RPM = 120.0
TEST_DURATION_S = 10.0
PLANT_SPACING_M = 1.5
CAM_INERTIA_KG_M2 = 0.0176

#: the study's eight claims (docs/study.md, "What the study claims")
CLAIMS = {
    1: "The MLSD model and the multibody contact simulation agree (eq. 18).",
    2: "Collision force falls along the chain: A > B > C > F.",
    3: "Any clearance raises the collision force above the clearance-free mechanism; more clearance, more force.",
    4: "Comb output load moment: left > right; largest without clearance; falls as clearance grows.",
    5: "Fruit force rises from root to end (0.25-0.4, 0.65-0.9, 0.8-1.2 N) and falls as clearance grows.",
    6: "Hence some ripe fruit stays at the root, the middle picks cleanly, the end also sheds some unripe fruit.",
    7: "More clearance: lower efficiency, lower unripe shedding, lower damage; efficiency peaks at B = 0.4 mm.",
    8: "Cam clearance A has the largest effect; best: efficiency A1B1C1F3, unripe A1B1C2F1, damage A1B1C2F3; "
       "chosen A1B1C1F3 giving 3.93 kg/min, 3.1 %, 2.8 %.",
}
