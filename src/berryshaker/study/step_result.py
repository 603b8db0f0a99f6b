"""What one study step produces (:class:`StepResult`): the one type every step of :mod:`berryshaker.study.pipeline`
returns, kept apart from the pipeline so that step modules (e.g. :mod:`berryshaker.study.life_step`) import it
without importing the pipeline that calls them."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class StepResult:
    """What one study step produced: JSON-able data, figure files (relative names) and a note for the report
    (e.g. why a step was skipped).

    Attributes
    ----------
    name : str
        The step's name.
    data : dict or None
        Its JSON-able results (None when it produced none).
    figures : list of str
        Figure files it wrote, relative to the output folder.
    note : str
        A note for the report (e.g. why the step was skipped).
    seconds : float
        Wall time of the step (s).
    """

    name: str
    data: dict | None
    figures: list[str] = field(default_factory=list)
    note: str = ""
    seconds: float = 0.0
