"""What one study step produces (:class:`StepResult`): the one type every step of :mod:`berryshaker.study.pipeline`
returns, kept apart from the pipeline so that step modules (e.g. :mod:`berryshaker.study.life_step`) import it
without importing the pipeline that calls them; and what the whole study produces (:class:`StudyResults`), every
step's data as its typed record."""

from __future__ import annotations

from dataclasses import dataclass, field

from berryshaker.drives.kinematics_record import KinematicsSummary
from berryshaker.records import JsonRecord
from berryshaker.study.claims import ClaimVerdict
from berryshaker.study.fruit_force_records import FruitForceStep
from berryshaker.study.harvest_records import HarvestResponse, Validation
from berryshaker.study.l9_records import VirtualL9
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
        rates %; :class:`berryshaker.study.l9_records.VirtualL9`).
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
    failures : list of dict
        Failed runs: step, run, inputs, error.
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
    failures: list = field(default_factory=list)
