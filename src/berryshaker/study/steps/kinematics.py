"""Study step ``kinematics``: the drive's ideal kinematics over one drive-shaft revolution (study eq. 1-3), its
figures (:func:`run`) and its report section (:func:`kinematics_section`).  Its data is the drives'
:class:`~berryshaker.drives.kinematics_record.KinematicsSummary`.
"""

from __future__ import annotations

from berryshaker.drives.kinematics_record import KinematicsSummary
from berryshaker.report.sections import SectionInput, details, maybe_img, table
from berryshaker.study.step_context import StudyContext
from berryshaker.study.step_result import Step, StepResult


def run(ctx: StudyContext) -> StepResult:
    """Ideal kinematics over one drive-shaft revolution (study eq. 1-3) and its figures.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``kinematics``: the drive's kinematics summary (:class:`KinematicsSummary`; units in the field names) and
        its figures.
    """
    from berryshaker.report import plots as P

    ctx.say("kinematics")
    kin = ctx.drive.check(ctx.machine)
    data = KinematicsSummary.from_json(ctx.drive.kinematics_summary(ctx.machine, kin))
    figs = P.write_kinematics_figures(ctx.machine, kin, ctx.figs, ctx.draw) or []
    return StepResult("kinematics", data, list(figs))


def kinematics_section(inp: SectionInput) -> tuple[str, list[str]]:
    """The drive's kinematics (study step ``kinematics``): the summary table and its figures.

    Parameters
    ----------
    inp : SectionInput
        Results (``kinematics``: a ``berryshaker.drives.kinematics_record.KinematicsSummary``, read by attribute;
        lengths in mm, angles in deg, speeds m/s, frequency Hz), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    k, figs = inp.res.kinematics, inp.figs
    parts = []
    krows = []
    if k.cam is not None:
        c = k.cam
        krows += [
            ["stroke", f"{c.stroke_mm:.2f} mm"], ["max push-rod velocity", f"{c.max_velocity_m_s:.4f} m/s"],
            ["max acceleration", f"{c.max_acceleration_m_s2:.3f} m/s²"], ["max jerk", f"{c.max_jerk_m_s3:.1f} m/s³"],
            ["pressure angle", f"{c.pressure_angle_deg.min:.2f} .. {c.pressure_angle_deg.max:.2f} deg"],
            ["min pitch radius of curvature",
             f"{c.min_radius_of_curvature_mm:.2f} mm (roller {c.roller_radius_mm:.1f} mm)"]]
    for key, val in (k.drive_specific or {}).items():
        krows.append([key.replace("_", " "), str(val)])
    left, right, ta = k.combs["left"].swing_deg, k.combs["right"].swing_deg, k.linkage.transmission_angle_deg
    parts.append(table(["quantity", "value"], krows + [
        ["left comb swing", f"{left.min:.2f} .. {left.max:.2f} deg"],
        ["right comb swing", f"{right.min:.2f} .. {right.max:.2f} deg"],
        ["transmission angle", f"{ta.min:.2f} .. {ta.max:.2f} deg"],
        ["comb frequency", f"{k.drive.comb_frequency_hz:.3f} Hz"]]))
    more: list[str] = []
    for name, cap in (("svaj.png", "Push-rod displacement, velocity, acceleration, jerk (3-4-5 law, corrected return)"),
                      ("groove_profile.png", "Groove cam: pitch curve and walls offset along its normal (corrected eq. 2)"),
                      ("comb_angles.png", "Comb swings, tip speeds and transmission angle (eq. 3)")):
        maybe_img(more, figs / name, cap)
    parts.append(details("Figures: the push rod's motion, the groove, the comb swings", more))
    return "Kinematics of the drive (eq. 1-3)", parts


#: the step in the study's step table (:data:`berryshaker.study.steps.STEPS`)
STEP = Step(key="kinematics", run=run, result="kinematics", sections=(kinematics_section,))
