"""The drive drawn from a run, for the page's animation: the groove cam from its reduced (MLSD) model's
coordinates, any other drive from its multibody run and mechanism description.  A drawing is points (each a base
position and a clearance displacement to magnify), links between them and the clearance joints with their free
play and contact flags per frame (:func:`groove_cam_frames`); :func:`berryshaker.explore.views.frame_data` turns it
into the browser's columns.  SI throughout.
"""

from __future__ import annotations

import math

import numpy as np

#: drive-shaft revolutions of the runs drawn (the drawing covers the last); the page's runs use this many
REVOLUTIONS = 3

#: colour of the drive's links and combs in the drawing
LINK_COLOUR = "#555555"
COMB_COLOUR = "#8C564B"


#: the magnified free play of a joint drawn by default, and at most, as a share of the shortest link it joins (at
#: the largest the housing circle still leaves most of the link in view, so the linkage reads as joined)
DEFAULT_PLAY_SHARE = 0.15
MAX_PLAY_SHARE = 0.4
#: magnifications of the drawing: at least true scale, at most this
MAX_MAGNIFY = 1000.0


def magnification_range(frames: dict) -> tuple[float, float]:
    """The drawing's default and largest clearance magnification, from its clearances and links.

    A joint drawn magnified ``k`` times is a circle of radius ``k`` x its free play, and the links that end at it end
    up to that far from each other; the drawing stays a joined linkage while that radius is a small share of the
    shortest link ending at the joint.  The default makes the largest such share :data:`DEFAULT_PLAY_SHARE`, the
    largest magnification :data:`MAX_PLAY_SHARE` (both to two significant digits, within 1 .. :data:`MAX_MAGNIFY`).
    Link lengths are taken between the points' positions before magnification, in the first frame; a link ends at a
    joint when one of its ends lies within 1 % of the drawing's extent of the joint's housing, and links shorter than
    that (the arm of a joint on a bar's axis) are not links a joint could swallow.

    Parameters
    ----------
    frames : dict
        A drawing (:func:`groove_cam_frames`, :func:`multibody_frames`).

    Returns
    -------
    (float, float)
        Default and largest magnification (1 = true scale).
    """
    base = {k: np.asarray(b, float)[0] for k, (b, _v) in frames["points"].items()}
    xy = np.array(list(base.values()))
    extent = float(np.ptp(xy[:, 0]) + np.ptp(xy[:, 1])) if len(xy) else 0.0
    lengths = [(a, b, float(np.hypot(*(base[a] - base[b])))) for a, b, _c in frames["links"]]
    shares = []
    for _name, housing, _element, play, _contact in frames["joints"]:
        at = base[housing]
        near = [ln for a, b, ln in lengths if ln > 0.01 * extent
                and min(np.hypot(*(base[a] - at)), np.hypot(*(base[b] - at))) <= 0.01 * extent]
        if play > 0 and near:
            shares.append(min(near) / play)
    if not shares:
        return 1.0, MAX_MAGNIFY
    two = lambda k: float(f"{min(max(k, 1.0), MAX_MAGNIFY):.2g}")
    return two(DEFAULT_PLAY_SHARE * min(shares)), two(MAX_PLAY_SHARE * min(shares))


def _frame_index(t: np.ndarray, period: float, n_frames: int) -> np.ndarray:
    """Indexes of ``n_frames`` samples equally spaced over the last revolution of the series ``t`` (s)."""
    t_last = t[-1] - period
    idx = np.unique(np.searchsorted(t, np.linspace(t_last, t[-1], n_frames, endpoint=False)))
    return np.clip(idx, 0, len(t) - 1)


def groove_cam_frames(result, n_frames: int = 120) -> dict:
    """The groove-cam drive drawn from an MLSD result over its last revolution (the drawing of
    :func:`berryshaker.explore.views.frame_data`).

    The points follow docs/mlsd.md: roller A at x = s0 + x on the guide line y = e (its pitch point at
    s0 + s(phi)); roller B at s0 + x + l_AB; the left comb from D along its angle theta_D, arm DC at theta_D +
    gamma; pin F at E + l_FE (cos theta_E, sin theta_E), the right comb from E along theta_E; the clearance vectors
    r_A, r_B (roller minus its foot on the slot line), r_C, r_F (rod bore minus comb pin) are the model's
    (eq. 4).  A joint is in contact where its link length |d_i| exceeds its free play c_i (half the size for a
    roller, the radial clearance for a pin).

    Parameters
    ----------
    result : MLSDResult
        A groove-cam MLSD run (:func:`berryshaker.drives.groove_cam.mlsd.simulate_mlsd`).
    n_frames : int
        Frames, equally spaced over the last revolution.

    Returns
    -------
    dict
        ``t`` (s) and ``phi_deg`` (drive-shaft angle, deg) per frame; ``points``: name -> (base, vector), two
        (n_frames, 2) arrays in m, the point drawn at base + magnification x vector (the vector is a clearance
        displacement, zero for a point drawn true); ``links``: (point, point, colour); ``joints``: (name, housing
        point, element point, free play in m, contact flags per frame); ``groove``: the cam's pitch curve in the cam
        frame ((2, n), m) and ``cam_angle`` (rad per frame, the cam turning clockwise).
    """
    from berryshaker.drives.groove_cam.kinematics import cam_groove
    from berryshaker.drives.groove_cam.mlsd_kernel import R_DA, R_RBX, R_RBY, R_RCX, R_RCY, R_RFX, R_RFY
    from berryshaker.kinematics.cam import follower_svaj

    m = result.machine
    c = m.cam
    idx = _frame_index(result.t, 2 * math.pi / c.speed, n_frames)
    t = result.t[idx]
    phi = c.speed * t
    st, rs = result.state[idx], result.results[idx]
    x, thd, the = st[:, 0], st[:, 1], st[:, 3]
    s = follower_svaj(phi % (2 * math.pi), c.stroke, c.rise_angle, c.far_dwell_angle, c.return_angle, c.law)[0]
    e, s0, lab = c.offset, c.s0, m.push_rod.length
    xd, yd = m.shaft_D
    xe, ye = m.shaft_E
    lcd, gam, lfe, lc = m.rocker.arm_CD, m.rocker.arm_angle, m.four_bar.arm_FE, m.combs.length
    n = len(idx)
    one, zero = np.ones(n), np.zeros((n, 2))
    a0 = np.column_stack([s0 + s, e * one])  # pitch point of the groove
    b = np.column_stack([s0 + x + lab, e * one])
    c_pin = np.column_stack([xd + lcd * np.cos(thd + gam), yd + lcd * np.sin(thd + gam)])
    f_pin = np.column_stack([xe + lfe * np.cos(the), ye + lfe * np.sin(the)])
    v = {"A": np.column_stack([x - s, 0 * one]), "B": np.column_stack([rs[:, R_RBX], rs[:, R_RBY]]),
         "C": np.column_stack([rs[:, R_RCX], rs[:, R_RCY]]), "F": np.column_stack([rs[:, R_RFX], rs[:, R_RFY]])}
    pts = {
        "A0": (a0, zero), "A": (a0, v["A"]), "B0": (b - v["B"], zero), "B": (b - v["B"], v["B"]),
        "D": (np.column_stack([xd * one, yd * one]), zero), "E": (np.column_stack([xe * one, ye * one]), zero),
        "L": (np.column_stack([xd + lc * np.cos(thd), yd + lc * np.sin(thd)]), zero),
        "R": (np.column_stack([xe + lc * np.cos(the), ye + lc * np.sin(the)]), zero),
        "C_pin": (c_pin, zero), "C_bore": (c_pin, v["C"]), "F_pin": (f_pin, zero), "F_bore": (f_pin, v["F"]),
    }
    links = [("A", "B", LINK_COLOUR), ("D", "L", COMB_COLOUR), ("D", "C_pin", LINK_COLOUR),
             ("C_bore", "F_bore", LINK_COLOUR), ("E", "F_pin", LINK_COLOUR), ("E", "R", COMB_COLOUR)]
    play = {p: result.clearance[p] * (1.0 if m.clearance[p].kind == "pin-in-bore" else 0.5) for p in v}
    contact = {p: np.abs(rs[:, R_DA + k]) > play[p] for k, p in enumerate(("A", "B", "C", "F"))}
    joints = [("A", "A0", "A", play["A"], contact["A"]), ("B", "B0", "B", play["B"], contact["B"]),
              ("C", "C_bore", "C_pin", play["C"], contact["C"]), ("F", "F_bore", "F_pin", play["F"], contact["F"])]
    _, pitch, _, _ = cam_groove(m, n=181)
    return {"t": t, "phi_deg": np.degrees(phi % (2 * math.pi)), "points": pts, "links": links, "joints": joints,
            "groove": pitch, "cam_angle": -phi}


def multibody_frames(machine, result, n_frames: int = 120) -> dict | None:
    """Any drive drawn from its multibody result over the last revolution (the drawing of
    :func:`berryshaker.explore.views.frame_data`), from the mechanism description alone.

    Each body is drawn as a bar along its x axis through its mass centre, of the length a slender bar of its mass
    and moment of inertia has (sqrt(12 J / m), the bodies of the drives' mechanisms are such bars), at most reaching
    its farthest joint, with an arm from the bar to every joint point off it.  A clearance joint is drawn as its
    housing on ``body_i`` (a circle of radius the clearance) and the point of ``body_j`` displaced from it by the
    clearance vector (the difference of the two joint points), to be magnified; ``body_j``'s arms end there.  A
    joint is in contact where its contact force is not zero.

    Parameters
    ----------
    machine : MachineBase
        The machine run.
    result : MultibodyResult
        Its multibody run (:func:`berryshaker.drives.simulation.simulate_multibody`).
    n_frames : int
        Frames, equally spaced over the last revolution.

    Returns
    -------
    dict or None
        As :func:`groove_cam_frames` without the groove; None where the result's state does not match the drive's
        mechanism description.
    """
    from berryshaker.drives import drive_of

    spec = drive_of(machine).mechanism(machine, revolutions=REVOLUTIONS)
    nb = len(spec.bodies)
    if result.y.shape[1] < 6 * nb:
        return None
    idx = _frame_index(result.t, 2 * math.pi / machine.drive_speed, n_frames)
    y = result.y[idx]
    n = len(idx)
    zero = np.zeros((n, 2))
    index = {b.name: i for i, b in enumerate(spec.bodies)}

    def world(body: str, p) -> np.ndarray:
        if body not in index:  # ground: the point is in the frame
            return np.tile(np.asarray(p, float), (n, 1))
        k = 3 * index[body]
        ca, sa = np.cos(y[:, k + 2]), np.sin(y[:, k + 2])
        return np.column_stack([y[:, k] + ca * p[0] - sa * p[1], y[:, k + 1] + sa * p[0] + ca * p[1]])

    cm = result.compiled
    pts, links, joints = {}, [], []
    attach: dict[str, list[tuple[tuple[float, float], str]]] = {b.name: [] for b in spec.bodies}
    for j in spec.joints:
        pi, pj = getattr(j, "point_i", None), getattr(j, "point_j", None)
        if pi is None or pj is None:
            continue
        wi, wj = world(j.body_i, pi), world(j.body_j, pj)
        play = float(getattr(j, "clearance", 0.0) or 0.0)
        if str(j.type).endswith("_clearance") and play > 0:
            pts[f"{j.name}:i"], pts[f"{j.name}:j"] = (wi, zero), (wi, wj - wi)
            on_j = f"{j.name}:j"
        else:
            pts[f"{j.name}:i"] = (wi, zero)
            on_j = f"{j.name}:i"
        if j.body_i in attach:
            attach[j.body_i].append((tuple(pi), f"{j.name}:i"))
        if j.body_j in attach:
            attach[j.body_j].append((tuple(pj), on_j))
        contact = (np.abs(result.element_force(j.name)[idx]) > 0 if j.name in cm.frc_names
                   else np.zeros(n, bool))
        if play > 0:
            joints.append((j.name, f"{j.name}:i", on_j, play, contact))
    for b in spec.bodies:
        reach = max((math.hypot(*p) for p, _ in attach[b.name]), default=0.0)
        half = min(math.sqrt(3.0 * b.inertia / b.mass) if b.mass > 0 else 0.0, reach)
        colour = COMB_COLOUR if "comb" in b.name else LINK_COLOUR
        if half > 0:
            pts[f"{b.name}:-"], pts[f"{b.name}:+"] = (world(b.name, (-half, 0.0)), zero), (world(b.name, (half, 0.0)), zero)
            links.append((f"{b.name}:-", f"{b.name}:+", colour))
        for k, (p, name) in enumerate(attach[b.name]):
            foot = f"{b.name}:foot{k}"
            pts[foot] = (world(b.name, (min(max(p[0], -half), half), 0.0)), zero)
            links.append((foot, name, colour))
    t = result.t[idx]
    return {"t": t, "phi_deg": np.degrees((machine.drive_speed * t) % (2 * math.pi)), "points": pts, "links": links,
            "joints": joints, "groove": None, "cam_angle": None}
