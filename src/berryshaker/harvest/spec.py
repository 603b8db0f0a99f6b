"""The virtual-harvest section of a machine description: plant population and picking-outcome model
(docs/harvest.md)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from berryshaker.quantity_fields import NonNegAngle, display_unit, quantity_validator
from berryshaker.quantity_fields import StrictModel as _Strict

#: default relative tolerance of every coupled machine-plant run (fruit force, stem-force envelopes, the
#: virtual harvest's replicates), chosen by the ensemble study in tests/harvest/test_coupled_tolerance.py: over 16
#: replicates (3 branch classes each) at the recommended clearances, the loosest rtol at which no harvest
#: index or machine load of a replicate differs from rtol 1e-7 beyond 2 standard errors of the paired
#: difference (docs/harvest.md, "Solver tolerance of the coupled runs"); it was 1e-6.  The test keeps it by its own
#: rule: against 10x tighter, every response's mean paired difference within one replicate SD, SE <= 0.5 SD
COUPLED_RTOL = 1e-5

#: velocity scale (m/s) of every coupled run's error control (``simulation.velocity_scale``: a velocity's error
#: is held absolutely below rtol x this speed).  Applied as a number to every velocity state: the machine's
#: (m/s, rad/s) and the branch's mass-normalised modal ones (m sqrt(kg)/s, rtol x |phi(z)| m/s at a point of
#: mode shape phi(z): ~10x looser at the branch tip; the study checks the stem-force tables they feed).
#: Chosen by benchmarks/studies/coupled_velocity_scale_study.py: the loosest scale at which no response of 16
#: replicates differs from rtol 1e-7 at the engine's 0.1 m/s beyond 2 standard errors (docs/harvest.md,
#: "Solver tolerance of the coupled runs"); it was the engine's 0.1 m/s
COUPLED_VELOCITY_SCALE = 1.0


#: largest count of bushes, branches and replicates a description may ask for: the virtual harvest runs every
#: one of them (a replicate is a coupled run carrying every branch class), so more is a slip of the number, not a plan
MAX_COUNT = 1000
#: seed families are numpy SeedSequence entropies: 0 .. 2**32 - 1
MAX_SEED = 2**32 - 1


#: former median bruising heights -> the fields that replace them (read from what Brown et al. 1996 report)
RENAMED_BRUISE_FIELDS = {
    "bruise_height_padded": 'safe_drop_height_padded = "1.2 m" (cushioning prevented bruising up to it) with '
                            "safe_fractile = 0.05 (P(bruise) there)",
    "bruise_height_hard": 'extensive_drop_height_hard = "0.15 m" (extensive bruising above it) with '
                          "extensive_fractile = 0.5 (P(bruise) there)",
}


class HarvestSpec(_Strict):
    """Plant population and picking-outcome model of the virtual harvest (docs/harvest.md).

    Counts are bounded (1 .. :data:`MAX_COUNT`), fractions lie in 0 .. 1, seeds in 0 .. :data:`MAX_SEED`,
    so a description that loads also runs (nothing accepted here fails later at use).
    """

    branches_per_bush: int = Field(12, ge=1, le=MAX_COUNT)
    branch_classes: tuple[Annotated[float, Field(gt=0, le=10)], ...] = Field(
        (0.85, 1.0, 1.15), min_length=1, max_length=20)  # diameter scale factors of the reference branch
    fruit_zone: tuple[Annotated[float, Field(ge=0, le=1)], Annotated[float, Field(ge=0, le=1)]] = (
        0.1, 0.95)  # fruit along the branch, fractions of its length
    fruit_mass_cv: float = Field(0.2, ge=0, lt=1)  # coefficient of variation of fruit mass
    yield_per_bush: Annotated[float, quantity_validator("mass"), Field(gt=0, json_schema_extra=display_unit("kg"))] = 0.5  # [calibrated]
    unripe_fraction: float = Field(0.1, gt=0, lt=1)  # of the fruit mass on the bush [assumed; unripe rate held out]
    # detachment (docs/harvest.md, "Bond"): "pull_shear" = lognormal strengths by mode of loading (Kong et al. 2014),
    # "study_eq17" = the study's uniform bands of eq. 17 on the stem-force magnitude (the labelled alternative)
    bond_model: Literal["pull_shear", "study_eq17"] = "pull_shear"
    ripe_pull: Annotated[float, quantity_validator("force"), Field(gt=0, le=100, json_schema_extra=display_unit("N"))] = 0.47
    ripe_shear: Annotated[float, quantity_validator("force"), Field(gt=0, le=100, json_schema_extra=display_unit("N"))] = 0.23
    unripe_pull: Annotated[float, quantity_validator("force"), Field(gt=0, le=100, json_schema_extra=display_unit("N"))] = 2.05
    unripe_shear: Annotated[float, quantity_validator("force"), Field(gt=0, le=100, json_schema_extra=display_unit("N"))] = 1.0
    bond_cv: float = Field(0.24, ge=0, lt=2)  # CV of a ripe fruit's strengths (lognormal)
    # cumulative detachment (docs/harvest.md, "Bond"; berryshaker.plant.pedicel.miner): a fruit comes off when its
    # Miner sum over the drive-past's load cycles, sum_i (g_i / s)^beta (Basquin 1910: N_f = (s / g)^beta; Miner
    # 1945), reaches 1; beta dimensionless [assumed: no blueberry pedicel fatigue exponent is published], >= 3 (the
    # stem-load tables carry beta = 3 ... 30 and the peak; a large value, e.g. 1e9, is detachment at the single
    # largest load)
    miner_exponent: float = 8.0
    unripe_bond_cv: float = Field(0.40, ge=0, lt=2)  # CV of an unripe fruit's strengths (lognormal)
    # ripeness stages (docs/harvest.md, "Ripeness stages"): unripe_fraction is the mass share of green + pink + red
    # fruit (what a field test counts as unripe), unripe_stage_mix the shares of green, pink and red within it
    # [assumed 0.5 / 0.25 / 0.25]; unripe_pull / unripe_shear / unripe_bond_cv are the green fruit's; pink and red
    # pulls default to the geometric interpolation between green and blue in the stage index [assumed rule]
    unripe_stage_mix: tuple[Annotated[float, Field(ge=0, le=1)], Annotated[float, Field(ge=0, le=1)],
                            Annotated[float, Field(ge=0, le=1)]] = (0.5, 0.25, 0.25)
    pink_pull: Annotated[float, quantity_validator("force"), Field(gt=0, le=100, json_schema_extra=display_unit("N"))] | None = None
    red_pull: Annotated[float, quantity_validator("force"), Field(gt=0, le=100, json_schema_extra=display_unit("N"))] | None = None
    # damage (docs/harvest.md, "Bruising"): "impact" = bruising of published drop tests at the fruit's impacts, added
    # up as a cumulative drop height (a finger's strike on a share of the fruit, the fall onto the catching surface); "stem_acceleration" = the Weibull law in
    # the acceleration of the stem force with damage_acceleration and damage_shape (the former model, kept as a
    # labelled alternative)
    damage_model: Literal["impact", "stem_acceleration"] = "impact"
    catcher_drop: Annotated[float, quantity_validator("length"), Field(ge=0, le=5, json_schema_extra=display_unit("m"))] = 0.0
    catcher_surface: Literal["padded", "hard"] = "padded"
    # bruising thresholds from what the drop tests give (Brown et al. 1996; docs/harvest.md "Bruising"): a fruit's
    # equivalent drop height at which it bruises is lognormal with CV bruise_cv; its median per surface is read from a
    # height at which a stated share of the fruit bruises.  Padded: cushioning prevented bruising up to 0.6-1.2 m, a
    # safe height, P(bruise) = safe_fractile there [assumed 5 %]; hard: extensive bruising above 150 mm, read as the
    # height at which extensive_fractile of the fruit bruise [assumed 0.5: "extensive" as most of the fruit]
    safe_drop_height_padded: Annotated[float, quantity_validator("length"), Field(gt=0, le=10, json_schema_extra=display_unit("m"))] = 1.2
    safe_fractile: float = Field(0.05, gt=0, lt=0.5)
    extensive_drop_height_hard: Annotated[float, quantity_validator("length"), Field(gt=0, le=10, json_schema_extra=display_unit("m"))] = 0.15
    extensive_fractile: float = Field(0.5, gt=0, lt=1)
    # share of the detached fruit a comb finger strikes (at a phase of its swing uniform over the cycle) [assumed]
    strike_probability: float = Field(0.5, ge=0, le=1)
    bruise_cv: float = Field(0.3, gt=0, lt=2)
    damage_acceleration: Annotated[float, quantity_validator("acceleration"), Field(gt=0, json_schema_extra=display_unit("m/s^2"))] = 300.0
    damage_shape: float = Field(2.0, gt=0, le=100)  # Weibull shape of the damage probability [assumed]
    # berryshaker 0.1's bushes sampled per virtual run: read (and checked) so an older file loads, but not used: the
    # model's expectation is exact (quadrature) and a virtual field result covers operation.test_duration
    bushes: int | None = Field(None, ge=1, le=MAX_COUNT)
    # bush-to-bush CV of the yield (lognormal) [assumed]: a field test passes about 3 bushes, so its efficiency
    # scatters by about 0.3 / sqrt(3.3) = 16 % from the bushes alone (docs/harvest.md, "Virtual field test")
    bush_yield_cv: float = Field(0.3, ge=0, lt=2)
    # seed family of the virtual tests: start k draws each kind of randomness from its own stream
    # SeedSequence(seed, spawn_key=(k, stream, ...)) (berryshaker.harvest.virtual.seeds)
    seed: int = Field(2024, ge=0, le=MAX_SEED)
    # starts of each virtual test run (docs/harvest.md, "Replicates"): each start is one field test (its machine's
    # start and every branch class's drive phase in its drive-past, its bushes and counted fruit); the count is chosen by
    # berryshaker doe virtual --convergence (tests/study/test_l9_convergence.py holds it)
    replicates: int = Field(8, ge=2, le=MAX_COUNT)
    # sequential replication of a reported set (the recommendation, the calibration): starts are added in batches of
    # ``replicates`` until every harvest response's standard error is at most se_target x its mean, or max_replicates
    se_target: float = Field(0.03, gt=0, lt=1)
    max_replicates: int = Field(32, ge=2, le=MAX_COUNT)
    initial_eccentricity: float = Field(1.0, ge=0, le=1)  # of each joint's free radius [assumed]
    start_phase_spread: NonNegAngle = 3.141592653589793  # drive phase at arrival +- this (rad) [assumed]
    tolerance_replicates: int = Field(2, ge=0, le=MAX_COUNT)  # replicates re-run at rtol 1e-7 for the tolerance check

    @model_validator(mode="before")
    @classmethod
    def _renamed_bruise_heights(cls, data):
        if isinstance(data, dict):
            for old, new in RENAMED_BRUISE_FIELDS.items():
                if old in data:
                    raise ValueError(f"harvest.{old} (a median bruising height) is no longer read: give the height the "
                                     f"drop tests report, {new} (docs/harvest.md \"Bruising\")")
        return data

    @model_validator(mode="after")
    def _miner_exponent_in_the_tables(self):
        if not self.miner_exponent >= 3.0:  # NaN fails too
            raise ValueError(f"miner_exponent = {self.miner_exponent} is below 3: the Basquin exponent of the cumulative "
                             "detachment is read between the stem-load tables' exponents 3 ... 30 and the peak (a large "
                             "value, e.g. 1e9: the single largest load); give a value >= 3")
        return self

    @model_validator(mode="after")
    def _stage_mix_sums_to_one(self):
        total = sum(self.unripe_stage_mix)
        if abs(total - 1.0) > 1e-6:
            raise ValueError(f"unripe_stage_mix = {list(self.unripe_stage_mix)} sums to {total:g}: give the shares of "
                             "green, pink and red fruit within the unripe mass, summing to 1")
        return self

    @model_validator(mode="after")
    def _max_covers_replicates(self):
        if self.max_replicates < self.replicates:
            raise ValueError(f"max_replicates = {self.max_replicates} is below replicates = {self.replicates}: the "
                             "sequential starts of a reported set begin with replicates starts; raise max_replicates "
                             "or lower replicates")
        return self
