"""Typed results of the study step ``fruit_force`` (:func:`berryshaker.study.steps.fruit_force.run`):
the coupled drive-pasts at the configured clearances and at the level sets (:class:`DrivePast`, the summary of
:meth:`berryshaker.harvest.coupled.FruitForceResult.summary` as :class:`FruitForceSummary`) and the perturbed
starts' peak stem forces (:class:`FruitStartSet`), gathered in :class:`FruitForceStep`.  Their JSON forms are the
dicts the step wrote before (:mod:`berryshaker.records`); summary.json leaves out the plotted series
(:func:`berryshaker.study.tables.strip_series`), so :attr:`DrivePast.distance` and :attr:`DrivePast.forces` are
optional.
"""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.records import JsonRecord, optional
from berryshaker.study.statistic_records import MomentStatistics, StartStatistic


@dataclass(frozen=True)
class Eq17Verdict(JsonRecord):
    """What a peak stem force does to the fruit by eq. 17 (:class:`berryshaker.plant.response.HarvestVerdict`).

    Attributes
    ----------
    peak_force_N : float
        The peak stem force judged (N).
    ripe : str
        What happens to a ripe fruit: "picked", "partly picked" or "left on the bush".
    unripe : str
        What happens to an unripe fruit: "kept", "partly shed" or "shed".
    meets_eq17 : bool
        Whether F_a(max) <= F <= F_b(min): every ripe fruit off, every unripe fruit kept.
    """

    peak_force_N: float
    ripe: str
    unripe: str
    meets_eq17: bool


@dataclass(frozen=True, kw_only=True)
class FruitPosition(JsonRecord):
    """The stem force of one named fruit (root, middle, end) over a drive-past.

    Attributes
    ----------
    z_m : float
        Height of the fruit along the branch (m).
    peak_force_N : float
        Peak stem force (N): the force compared with the bond (eq. 17).
    rms_force_N : float
        RMS stem force over the drive-past (N).
    peak_at_distance_m : float
        Machine-to-plant distance at the peak (m; negative before the comb centre).
    eq17 : Eq17Verdict
        The eq. 17 verdict of the peak.
    rigid_peak_force_N : float or None
        Peak of eq. 16, m0 x branch acceleration (N); absent when not computed.
    study_range_N : list of float or None
        The study's range of this fruit's force, [low, high] (N); absent when the study gives none.
    within_study_range : bool or None
        Whether the peak lies in that range; absent with it.
    """

    z_m: float
    peak_force_N: float
    rms_force_N: float
    peak_at_distance_m: float
    eq17: Eq17Verdict
    rigid_peak_force_N: float | None = optional()
    study_range_N: list[float] | None = optional()
    within_study_range: bool | None = optional()


@dataclass(frozen=True, kw_only=True)
class PedicelSummary(JsonRecord):
    """The pedicel (fruit stem) model of a drive-past (absent when the fruit is rigid).

    Attributes
    ----------
    stiffness_N_m : float
        Stem stiffness (N/m).
    damping_N_s_m : float
        Stem damping (N s/m).
    natural_frequency_hz : float
        Natural frequency of the fruit on its stem (Hz).
    damping_ratio : float
        Damping ratio of the fruit on its stem (1).
    include_weight : bool
        Whether the fruit's weight loads the stem.
    coupling : str
        "one_way" or "two_way" (the fruit's reaction on the branch).
    mode_damping : str or None
        How the branch modes are damped (two-way coupling only; absent otherwise).
    """

    stiffness_N_m: float
    damping_N_s_m: float
    natural_frequency_hz: float
    damping_ratio: float
    include_weight: bool
    coupling: str
    mode_damping: str | None = optional()


@dataclass(frozen=True)
class ContactPeak(JsonRecord):
    """One comb-branch contact over a drive-past.

    Attributes
    ----------
    peak_N : float
        Peak normal force (N).
    impacts : int
        Number of contact onsets.
    """

    peak_N: float
    impacts: int



@dataclass(frozen=True)
class BushSample(JsonRecord):
    """The sampled bush of a drive-past with the ``branches`` load model.

    Attributes
    ----------
    branches : int
        Branches of the bush.
    members : int
        Branches simulated as members.
    reached : int
        Members the comb reaches.
    modes_per_member : int
        Modes kept per member.
    seed : int
        Seed of the bush's sample.
    """

    branches: int
    members: int
    reached: int
    modes_per_member: int
    seed: int


@dataclass(frozen=True, kw_only=True)
class FruitForceSummary(JsonRecord):
    """Summary of one coupled drive-past (:meth:`berryshaker.harvest.coupled.FruitForceResult.summary`).

    Attributes
    ----------
    positions : dict of str to FruitPosition
        Per named fruit (root, middle, end) its stem force (N) and eq. 17 verdict.
    study_ranges_N : dict of str to list of float
        The study's range of each fruit's force, [low, high] (N).
    contact : dict of str to ContactPeak
        Per comb-branch contact its peak force (N) and impacts.
    fruit_model : str
        "pedicel" or "rigid (eq. 16)".
    pedicel : PedicelSummary or None
        The pedicel model (absent when rigid).
    rises_root_to_end : bool
        Whether the peak force rises from root to end.
    load_model : str
        The combs' load model ("branches" or "aggregate").
    load_moment_Nm : dict of str to MomentStatistics
        Per comb (left, right) the bush's load moment (N m).
    bush : BushSample or None
        The sampled bush (``branches`` load model only; absent otherwise).
    steps : int
        Integrator steps of the run.
    wall_time_s : float
        Wall time of the run (s).
    clearance_mm : dict of str to float
        Clearance per pair (mm).
    """

    positions: dict[str, FruitPosition]
    study_ranges_N: dict[str, list[float]]
    contact: dict[str, ContactPeak]
    fruit_model: str
    pedicel: PedicelSummary | None = optional()
    rises_root_to_end: bool
    load_model: str
    load_moment_Nm: dict[str, MomentStatistics]
    bush: BushSample | None = optional()
    steps: int
    wall_time_s: float
    clearance_mm: dict[str, float]


@dataclass(frozen=True)
class BandLevels(JsonRecord):
    """One link's signal of a drive-past split at the impact band's cutoff
    (:func:`berryshaker.harvest.transmission.impact_transmission`).

    Attributes
    ----------
    unit : str
        Unit of the two RMS values ("N" for a force, "m/s^2" for the branch's acceleration).
    shaking_band_rms : float
        RMS of the fluctuation below the cutoff (N, or m/s^2 for an acceleration: ``unit``).
    impact_band_rms : float
        RMS above the cutoff, the part the clearance impacts make (N, or m/s^2 for an acceleration: ``unit``).
    impact_share : float
        The impact band's share of the mean-square fluctuation (dimensionless, 0..1).
    """

    unit: str
    shaking_band_rms: float
    impact_band_rms: float
    impact_share: float


@dataclass(frozen=True, kw_only=True)
class DrivePast(JsonRecord):
    """One coupled drive-past (:func:`berryshaker.study.runs.fruit_force_run`).

    Attributes
    ----------
    summary : FruitForceSummary
        The run's summary (forces N, moments N m, clearances mm).
    distance : list of float or None
        Machine-to-plant distance of the plotted series (m), decimated; absent in summary.json.
    forces : dict of str to list of float or None
        Stem force per named fruit along ``distance`` (N), decimated; absent in summary.json.
    peaks_exact : dict of str to float
        Exact peak stem force per named fruit (N).
    transmission : dict of str to BandLevels or None
        The shaking and impact bands of each link from the pins to the fruit, in chain order
        (:func:`berryshaker.harvest.transmission.impact_transmission`).
    """

    summary: FruitForceSummary
    distance: list[float] | None = optional()
    forces: dict[str, list[float]] | None = optional()
    peaks_exact: dict[str, float]
    transmission: dict[str, BandLevels] | None = optional()



@dataclass(frozen=True)
class FruitStartSet(JsonRecord):
    """The perturbed starts of one clearance set (:func:`berryshaker.study.steps.fruit_force.fruit_start_statistics`).

    Attributes
    ----------
    positions : dict of str to StartStatistic
        Per named fruit its peak stem force over the starts (N).
    starts : int
        Finished starts.
    """

    positions: dict[str, StartStatistic]
    starts: int


@dataclass(frozen=True)
class FruitForceStep(JsonRecord):
    """Data of the study step ``fruit_force``: the fruit harvesting force (N) of the machine driving past a branch.

    Attributes
    ----------
    chosen : DrivePast or None
        The drive-past at the configured clearances (None when its run failed).
    rows : dict of str to DrivePast
        The drive-pasts at the level sets, by clearance row ("14", "15", "16" for the reference machine); failed
        ones left out.
    level_rows : list of int
        The clearance rows of level sets 1-3.
    starts : dict of str to FruitStartSet
        The perturbed starts per set ("chosen" and the level rows); sets with fewer than two finished starts left
        out.
    branch_class : float
        Diameter scale of the fruit-force branch's class (1).
    """

    chosen: DrivePast | None
    rows: dict[str, DrivePast]
    level_rows: list[int]
    starts: dict[str, FruitStartSet]
    branch_class: float


__all__ = ["BandLevels", "Eq17Verdict", "FruitPosition", "PedicelSummary", "ContactPeak", "BushSample",
           "FruitForceSummary", "DrivePast", "FruitStartSet", "FruitForceStep"]
