"""Typed results of the study steps ``harvest_response`` (:func:`berryshaker.study.steps.harvest_response.run`:
:class:`HarvestResponse`, its rows :class:`HarvestSpeedRow` and its :class:`Calibration`) and ``validation``
(:func:`berryshaker.study.steps.validation.run`: :class:`Validation`, one :class:`ValidationRow` per
published number).  Their JSON forms are the dicts the steps wrote before (:mod:`berryshaker.records`).
"""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.records import JsonRecord, optional


@dataclass(frozen=True)
class ResponseSpread(JsonRecord):
    """One harvest response over a setting's starts (:func:`berryshaker.harvest.virtual.replicate_response`).

    Attributes
    ----------
    mean : float
        Mean of the model's expectation over the starts (its unit).
    sd : float
        The model's start-to-start SD (its unit).
    field_sd : float
        The field's test-to-test SD: of the counted field results (its unit).
    count_sd : float
        The counting noise of one field test (RMS over the starts; its unit).
    unit : str
        The response's unit.
    """

    mean: float
    sd: float
    field_sd: float
    count_sd: float
    unit: str


@dataclass(frozen=True, kw_only=True)
class HarvestSpeedRow(JsonRecord):
    """The harvest responses at one drive speed over perturbed starts
    (:func:`berryshaker.harvest.virtual.replicate_response`).

    Attributes
    ----------
    speed_rpm : float
        Drive-shaft speed (r/min).
    responses : dict of str to ResponseSpread
        Every harvest response (berryshaker.harvest.virtual.RESPONSES) by name.
    replicates : int
        Starts averaged.
    shaking_frequency_hz : float
        Comb shaking frequency (Hz).
    comb_swing_deg : float or None
        Comb swing (deg); absent when the shaking amplitude is not known.
    finger_amplitude_mm : float or None
        Finger-tip amplitude (mm); absent with it.
    """

    speed_rpm: float
    responses: dict[str, ResponseSpread]
    replicates: int
    shaking_frequency_hz: float
    comb_swing_deg: float | None = optional()
    finger_amplitude_mm: float | None = optional()

    @classmethod
    def from_columns(cls, speed_rpm: float, row: dict) -> "HarvestSpeedRow":
        """The record of one :func:`berryshaker.harvest.virtual.replicate_response` row (its columns).

        Parameters
        ----------
        speed_rpm : float
            Drive-shaft speed (r/min).
        row : dict
            The row's columns.

        Returns
        -------
        HarvestSpeedRow
            Its responses by name.
        """
        from berryshaker.harvest.virtual import RESPONSES

        spreads = {n: ResponseSpread(mean=row[r.column], sd=row[f"{r.column}_sd"], field_sd=row[f"{r.column}_field_sd"],
                                     count_sd=row[f"{r.column}_count_sd"], unit=r.unit) for n, r in RESPONSES.items()}
        extra = {k: row[k] for k in ("comb_swing_deg", "finger_amplitude_mm") if k in row}
        return cls(speed_rpm=float(speed_rpm), responses=spreads, replicates=int(row["replicates"]),
                   shaking_frequency_hz=float(row["shaking_frequency_hz"]), **extra)


@dataclass(frozen=True)
class CalibrationParameter(JsonRecord):
    """One plant or picking parameter with its provenance (:func:`berryshaker.harvest.calibration.calibration_table`).

    Attributes
    ----------
    parameter : str
        The parameter's name.
    value : float or int or str
        Its value in ``unit`` (a text where several values share a row, e.g. "12 / 4 / 1.2").
    unit : str
        The unit of ``value``.
    tag : str
        Provenance tag, e.g. "[assumed]", "[published]", "[calibrated]".
    target_or_source : str
        The target it was fitted to or the source it comes from.
    """

    parameter: str
    value: float | int | str
    unit: str
    tag: str
    target_or_source: str


@dataclass(frozen=True)
class HeldOutComparison(JsonRecord):
    """A model value compared with the study's (not fitted to it, unless the quantity says "fitted").

    Attributes
    ----------
    quantity : str
        The quantity, with its unit where it has one (e.g. "root fruit peak force (N)").
    model : float
        The model's value (the quantity's unit).
    study : str
        The study's value or range, as text.
    inside : bool or None
        Whether the model value lies in the study's range (None for a single value).
    """

    quantity: str
    model: float
    study: str
    inside: bool | None


@dataclass(frozen=True)
class Calibration(JsonRecord):
    """The calibration table (:func:`berryshaker.harvest.calibration.calibration_table`).

    Attributes
    ----------
    parameters : list of CalibrationParameter
        Every plant and picking parameter with its value, provenance and target or source.
    held_out : list of HeldOutComparison
        The comparisons with the study.
    """

    parameters: list[CalibrationParameter]
    held_out: list[HeldOutComparison]


@dataclass(frozen=True)
class HarvestResponse(JsonRecord):
    """Data of the study step ``harvest_response``: the harvest indexes against drive speed at the configured
    clearances, and the calibration.

    Attributes
    ----------
    rows : list of HarvestSpeedRow
        One per drive speed that ran (r/min, rates %, efficiency kg/min), in order of speed.
    configured_rpm : float
        The configured drive-shaft speed (r/min).
    calibration : Calibration
        Every parameter's provenance and the held-out comparisons.
    """

    rows: list[HarvestSpeedRow]
    configured_rpm: float
    calibration: Calibration


@dataclass(frozen=True)
class ValidationRow(JsonRecord):
    """One published number against the model (:func:`berryshaker.study.validation.validate`).

    Attributes
    ----------
    id : str
        Its id in the published record.
    quantity : str
        What was published.
    case : str
        The validation case (operating point) it is compared at.
    source : str
        The full citation.
    source_key : str
        The source's key in the record.
    published : float
        The published value, read as the model's response (the row's unit, ``unit``).
    unit : str
        Unit of ``published``, ``model`` and the interval.
    model : float or None
        The model's value (replicate mean; the input for a model input; the row's unit); None when not comparable.
    lo : float or None
        Low end of the interval the verdict uses (the row's unit); None when not comparable.
    hi : float or None
        High end of that interval (the row's unit); None when not comparable.
    noise_lo : float or None
        Low end of the start-to-start noise's interval alone (the row's unit).
    noise_hi : float or None
        High end of that interval (the row's unit).
    verdict : str
        "consistent", "not reproduced (...)", "no verdict (...)", "not comparable" or "input".
    held_out : bool
        Whether the number was held out (nothing fitted to it: every row but the model inputs).
    how : str
        How the case represents the published machine and how the interval was formed.
    confidence : str
        The record's confidence in the number.
    """

    id: str
    quantity: str
    case: str
    source: str
    source_key: str
    published: float
    unit: str
    model: float | None
    lo: float | None
    hi: float | None
    noise_lo: float | None
    noise_hi: float | None
    verdict: str
    held_out: bool
    how: str
    confidence: str


@dataclass(frozen=True)
class ValidationSummary(JsonRecord):
    """Counts of the validation's verdicts.

    Attributes
    ----------
    held_out : int
        Published numbers nothing was fitted to (every row but the model inputs).
    consistent : int
        Held-out numbers inside the model's interval.
    not_reproduced : int
        Held-out numbers outside it.
    no_verdict : int
        Held-out numbers whose interval is too wide to decide (more than a factor of ten).
    not_comparable : int
        Held-out numbers of a machine or operating point the description does not represent.
    inputs : int
        Published numbers used as model inputs.
    """

    held_out: int
    consistent: int
    not_reproduced: int
    no_verdict: int
    not_comparable: int
    inputs: int


@dataclass(frozen=True)
class Validation(JsonRecord):
    """Data of the study step ``validation``: the harvest model against the published record.

    Attributes
    ----------
    rows : list of ValidationRow
        One per published number.
    replicates : int
        Perturbed starts per case.
    summary : ValidationSummary
        Counts of the verdicts.
    """

    rows: list[ValidationRow]
    replicates: int
    summary: ValidationSummary


__all__ = ["HarvestSpeedRow", "CalibrationParameter", "HeldOutComparison", "Calibration", "HarvestResponse",
           "ValidationRow", "ValidationSummary", "Validation"]
