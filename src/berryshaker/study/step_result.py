"""What one study step is (:class:`Step`: its name, its run, its plan and its report sections, declared once in
its module of :mod:`berryshaker.study.steps`) and produces (:class:`StepResult`: the one type every step returns),
kept apart from the pipeline so that the step modules import them without importing the pipeline that runs them;
and what the whole study produces (:class:`StudyResults`), every step's data as its typed record."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Callable

from berryshaker.drives.kinematics_record import KinematicsSummary
from berryshaker.records import JsonRecord, optional
from berryshaker.study.claims import ClaimVerdict
from berryshaker.study.fruit_force_records import FruitForceStep
from berryshaker.study.harvest_records import HarvestResponse, Validation
from berryshaker.study.l9.records import Estimate, VirtualL9
from berryshaker.study.life_drive_records import ClearanceLife, PoweredDrive
from berryshaker.study.mechanics_records import ClearanceRows, ModelAgreement


@dataclass
class StepResult:
    """What one study step produced: its data as a typed record, figure files (relative names) and a note for the report
    (e.g. why a step was skipped).

    Attributes
    ----------
    name : str
        The step's name.
    data : JsonRecord or None
        Its results as a typed record (the step's field of :class:`StudyResults`; None when it produced none).
    figures : list of str
        Figure files it wrote, relative to the output folder.
    note : str
        A note for the report (e.g. why the step was skipped).
    seconds : float
        Wall time of the step (s).
    """

    name: str
    data: JsonRecord | None
    figures: list[str] = field(default_factory=list)
    note: str = ""
    seconds: float = 0.0


@dataclass(frozen=True)
class Step:
    """One step of the study: what runs it, what it plans and what renders it.  Each module of
    :mod:`berryshaker.study.steps` declares one (its ``STEP``); the step table (:data:`berryshaker.study.steps.STEPS`)
    names them in order.

    Attributes
    ----------
    key : str
        Its name in the timings (``summary.json``'s ``timings_s``).
    run : callable
        ``run(ctx) -> StepResult``.
    result : str
        Its :class:`StepResult`'s name: the key of its data in the results (a field of :class:`StudyResults`, or
        a key of its ``other``), and of its note.
    sections : tuple of callable
        The renderers of its report sections, in order (``render(inp) -> (title, parts)``, reading a
        :class:`berryshaker.report.sections.SectionInput`); the report numbers them in the steps' order.
    plan : callable or None
        ``plan(ctx) -> list[PlannedRuns]``: the runs it will ask for, known before it starts (the study starts them
        ahead in idle workers); None when they are not known before it runs.
    """

    key: str
    run: Callable[..., StepResult]  # run(ctx: StudyContext): study/step_context.py imports this module
    result: str
    sections: tuple = ()
    plan: Callable[..., list] | None = None  # plan(ctx: StudyContext) -> list[PlannedRuns]


@dataclass(frozen=True)
class StudyResults(JsonRecord):
    """The study's results: each step's data under its step's result name (None when the step produced none), the
    claims' verdicts and the failed runs.  summary.json's ``results`` is :meth:`to_json` of it without the plotted
    series (:func:`berryshaker.study.tables.strip_series`); :meth:`from_json` reads it back, e.g. to re-check the
    claims or re-render the report of a saved study.

    Attributes
    ----------
    kinematics : KinematicsSummary or None
        Step ``kinematics``: the drive's kinematics summary (lengths mm, angles deg, speeds m/s, frequency Hz).
    agreement : ModelAgreement or None
        Step ``model_agreement``: the reduced model against the multibody model (eq. 18; forces N).
    rows : ClearanceRows or None
        Step ``clearance_rows``: collision forces (N) and load moments (N m) per clearance row, the model check.
    fruit_force : FruitForceStep or None
        Step ``fruit_force``: the fruit harvesting force (N) along the comb (eq. 16-17).
    l9 : VirtualL9 or None
        Step ``virtual_l9``: the replicated virtual L9 and its recommendation (clearances mm, efficiency kg/min,
        rates %; :class:`berryshaker.study.l9.records.VirtualL9`).
    clearance_life : ClearanceLife or None
        Step ``clearance_life``: clearance growth by wear (mm against h) and the recommended fits.
    powered_drive : PoweredDrive or None
        Step ``powered_drive``: speed ripple (%), input power (W) and energy lost per joint (J/rev).
    harvest_response : HarvestResponse or None
        Step ``harvest_response``: harvest indexes against drive speed (r/min) and the calibration.
    validation : Validation or None
        Step ``validation``: the harvest model against the published record.
    claims : list of ClaimVerdict
        The claims' verdicts (:func:`berryshaker.study.claims.check_claims`).
    failures : list of FailedRun
        Failed runs: step, run, inputs, error.
    other : dict or None
        The data of the steps whose result has no field here, by result name (a step added to the step table
        needs no field: its data is here, read with :meth:`step_data`; read back from JSON as its JSON form).
        None (and left out of the JSON form) when every step has its field.
    """

    kinematics: KinematicsSummary | None = None
    agreement: ModelAgreement | None = None
    rows: ClearanceRows | None = None
    fruit_force: FruitForceStep | None = None
    l9: VirtualL9 | None = None
    clearance_life: ClearanceLife | None = None
    powered_drive: PoweredDrive | None = None
    harvest_response: HarvestResponse | None = None
    validation: Validation | None = None
    claims: list[ClaimVerdict] = field(default_factory=list)
    failures: list[FailedRun] = field(default_factory=list)
    other: dict[str, Any] | None = optional()

    @classmethod
    def of_steps(cls, results: dict, failures: list) -> StudyResults:
        """The results of the steps run, each under its result name: a field where there is one, else in
        :attr:`other`.

        Parameters
        ----------
        results : dict
            Each step's data by its result name.
        failures : list of FailedRun
            Failed runs.

        Returns
        -------
        StudyResults
            The results (without the claims' verdicts).
        """
        own = {f.name for f in fields(cls)} - {"claims", "failures", "other"}
        other = {k: v for k, v in results.items() if k not in own}
        return cls(**{k: v for k, v in results.items() if k in own}, failures=failures, other=other or None)

    def step_data(self, name: str) -> Any:
        """A step's data by its result name, whether it has a field or sits in :attr:`other`.

        Parameters
        ----------
        name : str
            The step's result name (``Step.result``).

        Returns
        -------
        object
            Its data (a record; its JSON form when read back from JSON into ``other``), or None.
        """
        if name in {f.name for f in fields(self)} - {"claims", "failures", "other"}:
            return getattr(self, name)
        return (self.other or {}).get(name)


@dataclass(frozen=True)
class FailedRun(JsonRecord):
    """A run of the study that failed (the step that needed it says "not comparable" or leaves it out).

    Attributes
    ----------
    step : str
        The step's progress label (e.g. "rows 1-16, multibody", "virtual L9").
    run : int or str
        The run's number in its step's map (1-based), or "" when the step failed as a whole.
    inputs : str
        The run's inputs in words (clearances in mm, seed ...).
    error : str
        The error it ended with.
    """

    step: str
    run: int | str
    inputs: str
    error: str


@dataclass(frozen=True)
class StudyOptimum(JsonRecord):
    """The study's recommended clearances (the virtual L9's recommendation) with their harvest indexes, as
    summary.json's head gives them.

    Attributes
    ----------
    code : str
        The level code of the recommended set (e.g. "A1B1C1F3").
    name : str or None
        The set named by its clearances (mm).
    clearance_mm : dict of str to float
        Clearance per pair (mm).
    efficiency_kg_min : float
        Mean harvest efficiency over its starts (kg/min).
    unripe_rate_pct : float
        Mean unripe rate (% of the unripe mass).
    damage_rate_pct : float
        Mean damage rate (% of the picked mass).
    study : dict
        The reference study's chosen code and its field result (kg/min, %).
    fitted : list of str
        The indexes fitted at these clearances (calibration targets: not evidence).
    starts : int or None
        Perturbed starts the means and intervals come from.
    intervals : dict of str to Estimate or None
        Per response, mean, SD and 95 % interval of the mean (the response's unit).
    basis : dict or None
        Per pair, why its level was chosen.
    statement : str or None
        The recommendation in words.
    """

    code: str
    name: str | None
    clearance_mm: dict[str, float]
    efficiency_kg_min: float
    unripe_rate_pct: float
    damage_rate_pct: float
    study: dict
    fitted: list[str]
    starts: int | None
    intervals: dict[str, Estimate] | None
    basis: dict | None
    statement: str | None


@dataclass(frozen=True, kw_only=True)
class StudySummary(JsonRecord):
    """The head of summary.json (:func:`berryshaker.study.pipeline.study_summary`): what the study found in brief,
    what failed, how long it took.  summary.json is its JSON form with the steps' ``results`` and the machine
    (``machine_si``) after it.

    Attributes
    ----------
    package : str
        "berryshaker".
    version : str
        The package version that ran the study.
    machine : str
        The machine's name.
    drive : str
        Its comb drive (e.g. "groove_cam").
    claims : list of ClaimVerdict
        The reference study's claims with their verdicts.
    optimum : StudyOptimum or None
        The recommended clearances (None without a virtual L9).
    failures : list of FailedRun
        The runs that failed.
    timings_s : dict of str to float
        Wall time per step and ``total`` (s).
    runs : dict
        The runner's run counts (runs, cached, computed, failed) and compute times (s).
    l9_replicates : dict, optional
        Per response the pooled replicate SD and its dof, the significant factors and p values, the paired
        differences; the solver-tolerance check (:func:`berryshaker.study.pipeline.l9_summary`).
    tradeoff : list of dict, optional
        The trade-off table's rows (columns in ``tradeoff_columns``; each in its column's unit).
    tradeoff_columns : list of str, optional
        The trade-off table's columns.
    """

    package: str
    version: str
    machine: str
    drive: str
    claims: list[ClaimVerdict]
    optimum: StudyOptimum | None
    failures: list[FailedRun]
    timings_s: dict[str, float]
    runs: dict
    l9_replicates: dict | None = optional()
    tradeoff: list[dict] | None = optional()
    tradeoff_columns: list[str] | None = optional()
