"""What one study step produces (:class:`StepResult`): the one type every step of :mod:`berryshaker.study.pipeline`
returns, kept apart from the pipeline so that step modules (e.g. :mod:`berryshaker.study.life_step`) import it
without importing the pipeline that calls them."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class StepResult:
    """What one study step produced: JSON-able data, figure files (relative names) and a note for the report
    (e.g. why a step was skipped)."""

    name: str
    data: dict | None
    figures: list[str] = field(default_factory=list)
    note: str = ""
    seconds: float = 0.0
