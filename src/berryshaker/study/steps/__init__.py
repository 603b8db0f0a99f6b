"""The study's steps, one module per step, and the step table (:data:`STEPS`).

Each module holds one step whole: its plan (``plan(ctx) -> list[PlannedRuns]``, where its runs are known before it
starts), its run (``run(ctx) -> StepResult``), the calls that draw its figures and the renderers of its report
sections (``<name>_section(inp) -> (title, parts)``), and declares it once as ``STEP``
(:class:`berryshaker.study.step_result.Step`).  What a step gets is :mod:`berryshaker.study.step_context`; the
machinery that runs the steps, starts their planned runs ahead and writes the outputs is
:mod:`berryshaker.study.pipeline`; the report numbers the sections in this table's order
(:mod:`berryshaker.report.sections`).
"""

from __future__ import annotations

from berryshaker.study.steps import (
    clearance_life,
    clearance_rows,
    fruit_force,
    harvest_response,
    kinematics,
    model_agreement,
    powered_drive,
    validation,
    virtual_l9,
)

#: the study's steps, in the order they run and their sections stand in the report (the machine's own steps,
#: then the harvest against frequency and the published record); only ``harvest_response`` reads an earlier
#: step's results (``fruit_force``)
STEPS = (kinematics.STEP, model_agreement.STEP, clearance_rows.STEP, fruit_force.STEP, virtual_l9.STEP,
         clearance_life.STEP, powered_drive.STEP, harvest_response.STEP, validation.STEP)
