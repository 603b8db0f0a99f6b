"""What the ``berryshaker explore`` page draws and prints from a run: the drive's frames as flat columns for the
browser's animation (:func:`frame_data`, :data:`ANIMATION_JS`), the tables of peak forces, harvest indexes and
wear (Markdown, units and provenance tags on every value), and the jobs of the removal-against-frequency runs.
No Panel here: plain data, so the page and its tests read the same values.
"""

from __future__ import annotations

import html
import math
import re

import numpy as np

from berryshaker.explore import model as em
from berryshaker.report.style import PAIR_COLOURS, SERIES_COLOURS

#: colour of a joint in contact (and of the impact stars)
IMPACT_COLOUR = "#D62728"

#: the browser's frame update (a Bokeh CustomJS on the frame slider): links, joints, impacts and the cam's pitch
#: curve of frame ``frame.value`` from the columns of :func:`frame_data`, and the time marker on the force plot
ANIMATION_JS = """
const d = frames.data;
if (!d.t || d.t.length == 0) { return; }
const k = Math.min(frame.value, d.t.length - 1);
const lx = d.lx[k], ly = d.ly[k];
const xs = [], ys = [];
for (let i = 0; i < lx.length; i += 2) { xs.push([lx[i], lx[i + 1]]); ys.push([ly[i], ly[i + 1]]); }
links.data = {xs: xs, ys: ys, colour: Array.from(d.link_colour[0])};
const names = Array.from(d.joint_name[0]);
const base = Array.from(d.joint_colour[0]);
const c = d.jc[k];
const colour = names.map((_, i) => c[i] > 0.5 ? '""" + IMPACT_COLOUR + """' : base[i]);
joints.data = {x: Array.from(d.jx[k]), y: Array.from(d.jy[k]), r: Array.from(d.jr[k]), px: Array.from(d.jpx[k]),
               py: Array.from(d.jpy[k]), colour: colour, name: names};
const ix = [], iy = [], iname = [];
for (let i = 0; i < names.length; i++) {
    if (c[i] > 0.5) { ix.push(d.jx[k][i]); iy.push(d.jy[k][i]); iname.push(names[i]); }
}
impacts.data = {x: ix, y: iy, name: iname};
groove.data = {x: Array.from(d.gx[k]), y: Array.from(d.gy[k])};
span.location = d.t[k];
"""


#: ASCII punctuation Markdown may read as markup (CommonMark lets a backslash escape each); ``&<>"'`` are
#: escaped as HTML instead
_MARKDOWN_PUNCTUATION = re.compile(r"([!#$%()*+,\-./:;=?@\[\\\]^_`{|}~])")


def md_text(value) -> str:
    """User text (a machine name, a path, an error quoting a value) for a Markdown pane: shown as written,
    never read as Markdown or HTML, with control characters made visible.

    Control characters become their ``\\xNN`` escape, Markdown's punctuation is backslash-escaped and
    ``& < > " '`` become HTML entities, so a ``<script>`` in a machine name is text on the page.

    Parameters
    ----------
    value : object
        The text (``str(value)``).

    Returns
    -------
    str
        Markdown source that renders as exactly that text (also inside a table cell).
    """
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(value))
    return html.escape(_MARKDOWN_PUNCTUATION.sub(r"\\\1", text), quote=True)


def frame_data(frames: dict, magnify: float) -> dict:
    """A drive's drawing (:func:`berryshaker.explore.drawing.groove_cam_frames`,
    :func:`~berryshaker.explore.drawing.multibody_frames`) as the browser's columns, one row per frame, clearances
    magnified ``magnify`` times (m).

    Each joint is drawn as its housing (a circle of radius free play x ``magnify``: the groove or slot's play
    about the roller's foot, the bore about its pin) and the element in it (a dot at the housing's centre plus
    the clearance vector x ``magnify``); the links end at the drawn joints, so the connecting rod and push rod
    wobble with the magnified play.

    Parameters
    ----------
    frames : dict
        The drawing.
    magnify : float
        Magnification of the clearances (1: true scale).

    Returns
    -------
    dict
        Columns ``t`` (s), ``phi_deg`` (deg), ``lx``/``ly`` (link end points, 2 per link, m), ``jx``/``jy``/``jr``
        (housing centre and radius per joint, m), ``jpx``/``jpy`` (the element in it, m), ``jc`` (1 in contact),
        ``gx``/``gy`` (the cam's pitch curve, m; empty without a cam), and the constant ``link_colour``,
        ``joint_name``, ``joint_colour`` (repeated per row).
    """
    if not (isinstance(magnify, (int, float)) and math.isfinite(magnify) and magnify > 0):
        magnify = 1.0
    mag = float(magnify)
    drawn = {k: base + mag * vec for k, (base, vec) in frames["points"].items()}
    n = len(frames["t"])
    links = frames["links"]
    lx = np.stack([np.column_stack([drawn[a][:, 0], drawn[b][:, 0]]) for a, b, _ in links], axis=1).reshape(n, -1)
    ly = np.stack([np.column_stack([drawn[a][:, 1], drawn[b][:, 1]]) for a, b, _ in links], axis=1).reshape(n, -1)
    joints = frames["joints"]
    names = [j[0] for j in joints]
    col = lambda f: np.column_stack([f(j) for j in joints]) if joints else np.zeros((n, 0))
    jx, jy = col(lambda j: drawn[j[1]][:, 0]), col(lambda j: drawn[j[1]][:, 1])
    jpx, jpy = col(lambda j: drawn[j[2]][:, 0]), col(lambda j: drawn[j[2]][:, 1])
    jr = np.tile([j[3] * mag for j in joints], (n, 1))
    jc = col(lambda j: np.asarray(j[4], float))
    if frames.get("groove") is not None:
        g = frames["groove"]
        ca, sa = np.cos(frames["cam_angle"]), np.sin(frames["cam_angle"])
        gx = ca[:, None] * g[0][None, :] - sa[:, None] * g[1][None, :]
        gy = sa[:, None] * g[0][None, :] + ca[:, None] * g[1][None, :]
    else:
        gx = gy = np.zeros((n, 0))
    rows = lambda a: [np.ascontiguousarray(r) for r in a]  # one array per frame (a ragged column)
    return {"t": np.asarray(frames["t"], float), "phi_deg": np.asarray(frames["phi_deg"], float),
            "lx": rows(lx), "ly": rows(ly), "jx": rows(jx), "jy": rows(jy), "jr": rows(jr), "jpx": rows(jpx),
            "jpy": rows(jpy), "jc": rows(jc), "gx": rows(gx), "gy": rows(gy),
            "link_colour": [[c for _, _, c in links]] * n, "joint_name": [names] * n,
            "joint_colour": [[PAIR_COLOURS.get(j, SERIES_COLOURS[k % len(SERIES_COLOURS)])
                              for k, j in enumerate(names)]] * n}


def frame_at(data: dict, k: int) -> tuple[dict, dict, dict, dict]:
    """The data of the drawn sources at frame ``k`` (what :data:`ANIMATION_JS` sets in the browser).

    Parameters
    ----------
    data : dict
        :func:`frame_data`.
    k : int
        Frame index.

    Returns
    -------
    (links, joints, impacts, groove) : dicts of columns
        The link lines, joint housings and elements, the joints in contact and the cam's pitch curve (m).
    """
    lx, ly = data["lx"][k], data["ly"][k]
    links = dict(xs=[lx[i:i + 2].tolist() for i in range(0, len(lx), 2)],
                 ys=[ly[i:i + 2].tolist() for i in range(0, len(ly), 2)], colour=list(data["link_colour"][0]))
    names = list(data["joint_name"][0])
    c = data["jc"][k] > 0.5
    colour = [IMPACT_COLOUR if c[i] else data["joint_colour"][0][i] for i in range(len(names))]
    joints = dict(x=data["jx"][k].tolist(), y=data["jy"][k].tolist(), r=data["jr"][k].tolist(),
                  px=data["jpx"][k].tolist(), py=data["jpy"][k].tolist(), colour=colour, name=names)
    impacts = dict(x=data["jx"][k][c].tolist(), y=data["jy"][k][c].tolist(), name=[n for n, ci in zip(names, c) if ci])
    return links, joints, impacts, dict(x=data["gx"][k].tolist(), y=data["gy"][k].tolist())


def clearance_table(base, run: em.MechanismRun, changed: set) -> str:
    """Markdown table of each joint's clearance and collision force statistics of a mechanism run.

    Parameters
    ----------
    base : MachineBase
        The described machine (provenance tags).
    run : MechanismRun
        The mechanism run (:func:`~berryshaker.explore.model.run_mechanism`).
    changed : set of str
        Keys the page changed (:func:`~berryshaker.explore.model.changed_keys`).

    Returns
    -------
    str
        One row per pair: clearance (mm, tagged), static-equivalent load (multibody runs), peak (the extreme),
        mean and rms |force| (N), impacts over revolutions 2..N;
        the drive moment below.
    """
    s = run.summary
    tag = f"[computed: {run.model} model, revolutions 2..{em.REVOLUTIONS}]"
    lines = ["| joint | clearance | static-equivalent force | peak force (extreme) | mean force | rms force | impacts |",
             "|---|---|---|---|---|---|---|"]
    onsets = s.get("contact_onsets", {})
    for p in run.machine.pair_names:
        st = s["collision_force_N"][p]
        size = run.machine.clearance_sizes()[p] * 1e3
        design = f"{st['static_equivalent']:.1f} N" if "static_equivalent" in st else "-"
        lines.append(f"| {p} | {size:.3f} mm [{em.provenance_tag(base, f'clearance.{p}.size', changed)}] | {design} | "
                     f"<span class='peak' id='peak-{p}'>{st['peak']:.1f}</span> N | {st['mean']:.1f} N | "
                     f"{st['rms']:.1f} N | {onsets.get(p, '')} |")
    out = "\n".join(lines)
    dm = s.get("drive_moment_Nm", {})
    if dm:
        design = f"design torque (p95 of the revolutions' peaks) {dm['design']:.1f} N m, " if "design" in dm else ""
        out += f"\n\nDrive moment: {design}rms {dm['rms']:.1f} N m, extreme {dm['peak']:.1f} N m.  "
    out += (f"\nForces and impacts {tag}; forces are magnitudes; static-equivalent: the p95 of the impact peaks (the "
            "multibody model; a load to size from), peak: the run's single largest force over every integrator step "
            "(an extreme).")
    return out


def harvest_jobs(machine, speed_range_rpm, points: int) -> tuple[list[list[dict]], list[float]]:
    """The runs of removal against frequency: at each drive-shaft speed, the virtual harvest's replicate starts (one
    coupled drive-past per start carrying every branch class, :func:`berryshaker.study.runs.replicate_run`, the
    study's own runs: shared through the cache).

    Parameters
    ----------
    machine : MachineBase
        The page's machine (its clearances, stroke, travel speed and ``harvest.replicates``).
    speed_range_rpm : (float, float)
        Lowest and highest drive-shaft speed (r/min).
    points : int
        Speeds, equally spaced (>= 2).

    Returns
    -------
    (jobs, speeds)
        ``jobs``: per speed, the keyword arguments of :func:`~berryshaker.study.runs.replicate_run` of its starts;
        ``speeds`` in r/min.

    Raises
    ------
    ConfigError
        A speed range that is empty or not positive.
    """
    from berryshaker.config import machine_from_dict
    from berryshaker.errors import ConfigError
    from berryshaker.harvest.virtual import replicate_starts, with_drive_speed
    from berryshaker.study.replicate_responses import replicate_jobs

    lo, hi = (float(v) for v in speed_range_rpm)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ConfigError(f"drive-shaft speeds {lo:g}..{hi:g} r/min: give 0 < lowest < highest")
    if int(points) < 2:
        raise ConfigError(f"speeds: give at least 2, got {points}")
    data = machine.model_dump(mode="json")
    speeds = [float(v) for v in np.linspace(lo, hi, int(points))]
    seeds = replicate_starts(machine)
    jobs = []
    for v in speeds:
        d = with_drive_speed(data, v * em.RPM)
        jobs.append(replicate_jobs(machine_from_dict(d), machine.clearance_sizes(), seeds, data=d))
    return jobs, speeds


def harvest_row(jobs: list[dict], outs: list) -> tuple[dict | None, list[str]]:
    """The harvest responses at one speed from its starts' runs (:func:`harvest_jobs`): every response's mean and
    spreads over the starts that ran (:func:`berryshaker.harvest.virtual.replicate_response`).

    Parameters
    ----------
    jobs : list of dict
        The speed's jobs.
    outs : list of RunResult
        Their results, in order.

    Returns
    -------
    (dict or None, list of str)
        The responses (None with fewer than 2 starts that ran) and the failed starts' errors.
    """
    from berryshaker.config import machine_from_dict
    from berryshaker.harvest.virtual import replicate_response
    from berryshaker.study.replicate_responses import replicate_envelopes

    errors = [f"start {j['seed'][0]}: {o.error}" for j, o in zip(jobs, outs) if o.error]
    m = machine_from_dict(jobs[0]["machine_data"])
    reps = replicate_envelopes(m, [None if o.error else o.value for o in outs], [j["seed"][0] for j in jobs])
    return (replicate_response(m, reps) if len(reps) >= 2 else None), errors


def harvest_table(rows: list, settings: em.Settings) -> str:
    """Markdown table of the harvest indexes against speed (replicate mean ± SD).

    Parameters
    ----------
    rows : list of (speed_rpm, result dict, cached)
        :func:`harvest_row` per speed.
    settings : Settings
        The page's settings the runs used.

    Returns
    -------
    str
        One row per speed: speed (r/min), frequency (Hz), ripe removal, unripe shed and damage (%), efficiency
        (kg/min), tagged computed.
    """
    if not rows:
        return ""
    lines = ["| speed | frequency | ripe removal | unripe shed | damage | efficiency |", "|---|---|---|---|---|---|"]
    for rpm, v, _cached in rows:
        cell = lambda k, u: f"{v[k]:.3g} ± {v.get(k + '_sd', float('nan')):.2g} {u}"
        lines.append(f"| {rpm:.0f} r/min | {v['shaking_frequency_hz']:.2f} Hz | {cell('ripe_removal_pct', '%')} | "
                     f"{cell('unripe_shed_pct', '%')} | {cell('damage_rate_pct', '%')} | "
                     f"{cell('efficiency_kg_min', 'kg/min')} |")
    r = rows[0][1].get("replicates", "")
    return ("\n".join(lines) + f"\n\n[computed: virtual harvest, mean ± SD over {r} replicate starts; "
            f"travel speed {settings.walking_speed_m_min:g} m/min, clearances "
            + ", ".join(f"{p} {c:g} mm" for p, c in settings.clearance_mm) + "]")


def wear_limit_lines(res: dict, colours: list[str]) -> dict:
    """The service limit of every joint as a line across the hours simulated, for the wear plot.

    Parameters
    ----------
    res : dict
        The wear result (:func:`berryshaker.life.service.machine_wear`): its ``limits_si`` keyed
        ``clearance:<joint>`` (m) and ``horizon_h``.
    colours : list of str
        The colour of each joint of ``res["joints"]``, in order.

    Returns
    -------
    dict
        Columns ``xs`` (h), ``ys`` (mm), ``colour`` and ``name`` ("<joint> service limit"), one row per joint with
        a clearance limit.
    """
    colour = dict(zip(res["joints"], colours))
    out: dict[str, list] = dict(xs=[], ys=[], colour=[], name=[])
    for key, limit in res.get("limits_si", {}).items():
        kind, _, joint = key.partition(":")
        if kind != "clearance" or joint not in colour:
            continue
        out["xs"].append([0.0, float(res["horizon_h"])])
        out["ys"].append([limit * 1e3] * 2)
        out["colour"].append(colour[joint])
        out["name"].append(f"{joint} service limit")
    return out


def wear_table(res: dict) -> str:
    """Markdown table of the wear result (:func:`berryshaker.life.service.machine_wear`).

    Parameters
    ----------
    res : dict
        The wear result.

    Returns
    -------
    str
        Per joint: material pair, clearance at the start and the end (mm), maintenance interval (h); the
        machine's interval and its governing limit below.
    """
    lines = ["| joint | material | start | end | maintenance interval |", "|---|---|---|---|---|"]
    for j, d in res["joints"].items():
        mi = d.get("maintenance_interval_h")
        lines.append(f"| {md_text(j)} | {md_text(d.get('material_pair', ''))} | {d['clearance_mm'][0]:.4g} mm | "
                     f"{d['clearance_mm'][-1]:.4g} mm | "
                     f"{'does not wear' if not d.get('wears', True) else 'not reached' if mi is None else f'{mi:.0f} h'} |")
    mi = res.get("maintenance_interval_h")
    head = "not reached within the horizon" if mi is None else f"{mi:.0f} h"
    gov = f" ({md_text(res['governing_limit'])})" if res.get("governing_limit") else ""
    return ("\n".join(lines) + f"\n\n**Service interval: {head}**{gov} [computed: Archard wear on the multibody "
            f"model over {res.get('horizon_h', '')} h]")
