"""ISO 286 tables (standard tolerances and fundamental deviations) for nominal sizes up to 500 mm.

The published tables, not the derivation formulas, are the source of truth: ISO rounds the formula
results in a way that simple rounding does not reproduce (see :mod:`berryshaker.life.iso286_limits` for the
formulas and ``tests/life/test_fits.py`` for how far they are from these tables).

Sources
-------
ISO 286-1:2010 "Geometrical product specifications (GPS) -- ISO code system for tolerances on linear
sizes -- Part 1: Basis of tolerances, deviations and fits", Table 1 (standard tolerance grades IT1..IT18),
Annex A (IT01, IT0), Tables 2 and 3 (fundamental deviations of shafts and holes, with the Delta values).
ISO 286-2:2010 (tables of limit deviations) is the same data evaluated per tolerance class.  The values
were entered from the standard's tables and cross-checked against two independent, hand-entered public
transcriptions (the PyPI packages ``isofits`` 1.0 -- full limit tables for 3..400 mm -- and
``pressfit`` 0.1.0); the comparison is described in docs/life.md.

Conventions
-----------
All values in micrometres (um).  Size ranges are "over a, up to and including b" (a < D <= b); the first
range is "up to and including 3 mm" and its geometric mean uses a = 1 mm, as in ISO 286-1.
"""

from __future__ import annotations

#: Upper bounds (mm) of the ISO 286-1 main size ranges used for the IT table and most deviations.
MAIN_RANGE_UPPER_MM: tuple[float, ...] = (3, 6, 10, 18, 30, 50, 80, 120, 180, 250, 315, 400, 500)

#: Upper bounds (mm) of the intermediate size ranges used for the deviations of shafts a, b, c
#: (and holes A, B, C).  The splits 10-14/14-18 and 18-24/24-30 carry equal values for these letters
#: and are merged here.
INTERMEDIATE_RANGE_UPPER_MM: tuple[float, ...] = (3, 6, 10, 18, 30, 40, 50, 65, 80, 100, 120, 140, 160,
                                                  180, 200, 225, 250, 280, 315, 355, 400, 450, 500)

#: Standard tolerances ITn (um) per main size range.  Keys are the grade names "01", "0", "1".."18".
STANDARD_TOLERANCE_UM: dict[str, tuple[float, ...]] = {
    "01": (0.3, 0.4, 0.4, 0.5, 0.6, 0.6, 0.8, 1, 1.2, 2, 2.5, 3, 4),
    "0": (0.5, 0.6, 0.6, 0.8, 1, 1, 1.2, 1.5, 2, 3, 4, 5, 6),
    "1": (0.8, 1, 1, 1.2, 1.5, 1.5, 2, 2.5, 3.5, 4.5, 6, 7, 8),
    "2": (1.2, 1.5, 1.5, 2, 2.5, 2.5, 3, 4, 5, 7, 8, 9, 10),
    "3": (2, 2.5, 2.5, 3, 4, 4, 5, 6, 8, 10, 12, 13, 15),
    "4": (3, 4, 4, 5, 6, 7, 8, 10, 12, 14, 16, 18, 20),
    "5": (4, 5, 6, 8, 9, 11, 13, 15, 18, 20, 23, 25, 27),
    "6": (6, 8, 9, 11, 13, 16, 19, 22, 25, 29, 32, 36, 40),
    "7": (10, 12, 15, 18, 21, 25, 30, 35, 40, 46, 52, 57, 63),
    "8": (14, 18, 22, 27, 33, 39, 46, 54, 63, 72, 81, 89, 97),
    "9": (25, 30, 36, 43, 52, 62, 74, 87, 100, 115, 130, 140, 155),
    "10": (40, 48, 58, 70, 84, 100, 120, 140, 160, 185, 210, 230, 250),
    "11": (60, 75, 90, 110, 130, 160, 190, 220, 250, 290, 320, 360, 400),
    "12": (100, 120, 150, 180, 210, 250, 300, 350, 400, 460, 520, 570, 630),
    "13": (140, 180, 220, 270, 330, 390, 460, 540, 630, 720, 810, 890, 970),
    "14": (250, 300, 360, 430, 520, 620, 740, 870, 1000, 1150, 1300, 1400, 1550),
    "15": (400, 480, 580, 700, 840, 1000, 1200, 1400, 1600, 1850, 2100, 2300, 2500),
    "16": (600, 750, 900, 1100, 1300, 1600, 1900, 2200, 2500, 2900, 3200, 3600, 4000),
    "17": (1000, 1200, 1500, 1800, 2100, 2500, 3000, 3500, 4000, 4600, 5200, 5700, 6300),
    "18": (1400, 1800, 2200, 2700, 3300, 3900, 4600, 5400, 6300, 7200, 8100, 8900, 9700),
}

#: Fundamental deviation es (upper deviation, um) of shafts a, b, c per intermediate size range
#: (ISO 286-1 Table 2).  Shafts a and b are not defined for nominal sizes up to 1 mm.
SHAFT_UPPER_DEVIATION_INTERMEDIATE_UM: dict[str, tuple[float, ...]] = {
    "a": (-270, -270, -280, -290, -300, -310, -320, -340, -360, -380, -410, -460, -520, -580, -660, -740,
          -820, -920, -1050, -1200, -1350, -1500, -1650),
    "b": (-140, -140, -150, -150, -160, -170, -180, -190, -200, -220, -240, -260, -280, -310, -340, -380,
          -420, -480, -540, -600, -680, -760, -840),
    "c": (-60, -70, -80, -95, -110, -120, -130, -140, -150, -170, -180, -200, -210, -230, -240, -260, -280,
          -300, -330, -360, -400, -440, -480),
}

#: Fundamental deviation es (upper deviation, um) of shafts d..h per main size range (ISO 286-1 Table 2).
SHAFT_UPPER_DEVIATION_UM: dict[str, tuple[float, ...]] = {
    "d": (-20, -30, -40, -50, -65, -80, -100, -120, -145, -170, -190, -210, -230),
    "e": (-14, -20, -25, -32, -40, -50, -60, -72, -85, -100, -110, -125, -135),
    "f": (-6, -10, -13, -16, -20, -25, -30, -36, -43, -50, -56, -62, -68),
    "g": (-2, -4, -5, -6, -7, -9, -10, -12, -14, -15, -17, -18, -20),
    "h": (0,) * 13,
}

#: Fundamental deviation ei (lower deviation, um) of shafts k, m, n, p per main size range
#: (ISO 286-1 Table 2).  The k row applies to grades IT4..IT7 only; every other grade of k has ei = 0.
SHAFT_LOWER_DEVIATION_UM: dict[str, tuple[float, ...]] = {
    "k": (0, 1, 1, 1, 2, 2, 2, 3, 3, 4, 4, 4, 5),
    "m": (2, 4, 6, 7, 8, 9, 11, 13, 15, 17, 20, 21, 23),
    "n": (4, 8, 10, 12, 15, 17, 20, 23, 27, 31, 34, 37, 40),
    "p": (6, 12, 15, 18, 22, 26, 32, 37, 43, 50, 56, 62, 68),
}

#: Grades IT3..IT8 for which ISO 286-1 Table 3 tabulates Delta = ITn - IT(n-1) (used by holes K..ZC).
DELTA_GRADES: tuple[int, ...] = (3, 4, 5, 6, 7, 8)

#: ISO 286-1 Table 3 special case: hole M6 over 250 up to 315 mm has ES = -9 um (not -20 + Delta = -11).
M6_250_315_UPPER_DEVIATION_UM: float = -9.0
