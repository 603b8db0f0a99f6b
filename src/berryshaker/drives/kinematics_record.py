"""The drives' kinematics summary as a typed record (:class:`KinematicsSummary`): what a drive's
``kinematics_summary`` gives (the JSON of ``berryshaker kinematics``), read by the study's ``kinematics`` step and
its report section by attribute.  The drives build the dict (it is the CLI's JSON); :meth:`KinematicsSummary.from_json`
reads it, validated.  One record for every drive: a section only one drive has is an :func:`~berryshaker.records.optional`
field (the groove cam's ``cam``, the crank-rocker's ``drive_specific`` and ``crank``).
"""

from __future__ import annotations

from dataclasses import dataclass

from berryshaker.records import JsonRecord, optional


@dataclass(frozen=True)
class AngleRange(JsonRecord):
    """The least and greatest value of an angle over one revolution.

    Attributes
    ----------
    min : float
        Least value (deg).
    max : float
        Greatest value (deg).
    """

    min: float
    max: float


@dataclass(frozen=True)
class ClosedFormPeaks(JsonRecord):
    """Closed-form peaks of the cam's follower law (rise and return; the shorter move's).

    Attributes
    ----------
    max_velocity_m_s : float
        Peak push-rod velocity (m/s).
    max_acceleration_m_s2 : float
        Peak push-rod acceleration magnitude (m/s^2).
    max_jerk_m_s3 : float
        Peak push-rod jerk magnitude (m/s^3).
    """

    max_velocity_m_s: float
    max_acceleration_m_s2: float
    max_jerk_m_s3: float


@dataclass(frozen=True)
class CamKinematics(JsonRecord):
    """The groove cam and its push rod over one revolution.

    Attributes
    ----------
    law : str
        Follower law (e.g. "3-4-5").
    stroke_mm : float
        Push-rod stroke (mm).
    max_velocity_m_s : float
        Peak push-rod speed (m/s).
    max_acceleration_m_s2 : float
        Peak push-rod acceleration magnitude (m/s^2).
    max_jerk_m_s3 : float
        Peak push-rod jerk magnitude (m/s^3).
    pressure_angle_deg : AngleRange
        Pressure angle range (deg).
    min_radius_of_curvature_mm : float
        Least radius of curvature of the pitch curve (mm).
    roller_radius_mm : float
        Follower roller radius (mm).
    undercut : bool
        The groove undercuts (least radius of curvature <= roller radius).
    closed_form : ClosedFormPeaks or None
        Closed-form peaks of the law, where the law has them (absent otherwise).
    """

    law: str
    stroke_mm: float
    max_velocity_m_s: float
    max_acceleration_m_s2: float
    max_jerk_m_s3: float
    pressure_angle_deg: AngleRange
    min_radius_of_curvature_mm: float
    roller_radius_mm: float
    undercut: bool
    closed_form: ClosedFormPeaks | None = optional()


@dataclass(frozen=True)
class CrankKinematics(JsonRecord):
    """The crank-rocker's crank and connecting rod.

    Attributes
    ----------
    radius_mm : float
        Crank radius (mm).
    rod_length_mm : float
        Connecting-rod length (mm).
    rod_transmission_angle_deg : AngleRange
        Rod-rocker transmission angle range (deg).
    """

    radius_mm: float
    rod_length_mm: float
    rod_transmission_angle_deg: AngleRange


@dataclass(frozen=True)
class CombKinematics(JsonRecord):
    """One comb's swing over one revolution.

    Attributes
    ----------
    swing_deg : AngleRange
        Comb angle about its mid-stroke angle (deg).
    max_tip_speed_m_s : float
        Peak comb-tip speed (m/s).
    max_tip_acceleration_m_s2 : float
        Peak comb-tip acceleration magnitude, tangential and centripetal (m/s^2).
    mid_stroke_angle_deg : float
        The comb's mid-stroke angle (deg).
    """

    swing_deg: AngleRange
    max_tip_speed_m_s: float
    max_tip_acceleration_m_s2: float
    mid_stroke_angle_deg: float


@dataclass(frozen=True)
class LinkageKinematics(JsonRecord):
    """The four-bar linkage between the combs.

    Attributes
    ----------
    transmission_angle_deg : AngleRange
        Transmission angle range (deg).
    shaft_D_mm : list of float
        Left comb shaft position x, y (mm).
    shaft_E_mm : list of float
        Right comb shaft position x, y (mm).
    """

    transmission_angle_deg: AngleRange
    shaft_D_mm: list[float]
    shaft_E_mm: list[float]


@dataclass(frozen=True, kw_only=True)
class DriveSpeeds(JsonRecord):
    """Speeds of the drive.

    Attributes
    ----------
    shaft_speed_rpm : float or None
        Drive-shaft speed (r/min; the crank-rocker's, absent for the groove cam).
    cam_speed_rpm : float
        Drive-shaft (cam) speed (r/min).
    comb_frequency_hz : float
        Comb shaking frequency (Hz).
    """

    shaft_speed_rpm: float | None = optional()
    cam_speed_rpm: float
    comb_frequency_hz: float


@dataclass(frozen=True, kw_only=True)
class KinematicsSummary(JsonRecord):
    """A drive's ideal kinematics over one drive-shaft revolution (``kinematics_summary`` of its plug-in).

    Attributes
    ----------
    drive_specific : dict of str to str or None
        The drive's own quantities as formatted text with units (label -> text; the crank-rocker's, absent for
        the groove cam).
    crank : CrankKinematics or None
        Crank and rod (the crank-rocker's; absent otherwise).
    cam : CamKinematics or None
        Cam and push rod (the groove cam's; absent otherwise).
    combs : dict of str to CombKinematics
        Per comb ("left", "right"): its swing (deg) and tip speed (m/s) and acceleration (m/s^2).
    linkage : LinkageKinematics
        Transmission angle (deg) and comb shafts (mm).
    drive : DriveSpeeds
        Speeds (r/min) and comb frequency (Hz).
    """

    drive_specific: dict[str, str] | None = optional()
    crank: CrankKinematics | None = optional()
    cam: CamKinematics | None = optional()
    combs: dict[str, CombKinematics]
    linkage: LinkageKinematics
    drive: DriveSpeeds


__all__ = ["AngleRange", "ClosedFormPeaks", "CamKinematics", "CrankKinematics", "CombKinematics",
           "LinkageKinematics", "DriveSpeeds", "KinematicsSummary"]
