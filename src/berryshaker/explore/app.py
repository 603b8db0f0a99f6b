"""The ``berryshaker explore`` web page (Panel with Bokeh): fields and sliders for a machine's clearances, drive
speed, stroke and travel speed; the drive animated with its clearances magnified and impacts marked; collision
forces per joint; removal against frequency; wear and the service interval.

The mechanism and force views rerun the drive's reduced model (about a second) on every change, in a
background thread (the newest settings win; runs kept in memory by :class:`~berryshaker.explore.model.RunCache`);
the harvest and wear views start their long runs from a button, in a background thread through the cached
:class:`~berryshaker.runs.runner.SweepRunner`, with a progress bar in the page.  Every page update from a thread
goes through the session's document (``add_next_tick_callback``), never straight to its models.  What each view
computes: docs/explore.md.
"""

from __future__ import annotations

import html
import math
import threading

import numpy as np
import panel as pn
from bokeh.layouts import column as bk_column
from bokeh.layouts import row as bk_row
from bokeh.models import Button, ColumnDataSource, CustomJS, Slider, Span
from bokeh.plotting import figure

from berryshaker.errors import BerryshakerError
from berryshaker.explore import model as em
from berryshaker.explore.drawing import magnification_range
from berryshaker.explore.views import (
    ANIMATION_JS,
    clearance_table,
    frame_at,
    frame_data,
    harvest_jobs,
    harvest_row,
    harvest_table,
    md_text,
    wear_limit_lines,
    wear_table,
)
from berryshaker.report.style import PAIR_COLOURS, SERIES_COLOURS, decimate_minmax_shared

#: width of the settings column (px); the views share the rest of the window and wrap below this width each
CONTROLS_WIDTH = 320
VIEW_MIN_WIDTH = 400
#: height of the drive's and the forces' figures, and of the harvest and wear figures (px)
FIGURE_HEIGHT = 380
CARD_FIGURE_HEIGHT = 300


def _colour(pair: str, k: int) -> str:
    return PAIR_COLOURS.get(pair, SERIES_COLOURS[k % len(SERIES_COLOURS)])


def _legend_outside(fig, ncols: int | None = None) -> None:
    """The figure's legend below its plot area, off the data (the report's figure rule), in rows of ``ncols``
    entries (default one row): the plot keeps the container's width."""
    legend = fig.legend[0]
    legend.orientation = "horizontal"
    legend.location = "center"
    if ncols is not None:
        legend.ncols = ncols
    fig.add_layout(legend, "below")


def _figure(title: str, height: int, **kw):
    """A Bokeh figure that takes its container's width (at least :data:`VIEW_MIN_WIDTH`)."""
    return figure(title=title, height=height, sizing_mode="stretch_width", min_width=VIEW_MIN_WIDTH, **kw)


def _views(*children) -> pn.FlexBox:
    """Views side by side where the window is wide enough, else one below the other."""
    for c in children:
        c.sizing_mode = "stretch_width"
        c.min_width = VIEW_MIN_WIDTH
        c.styles = {**(c.styles or {}), "flex": f"1 1 {VIEW_MIN_WIDTH}px"}
    return pn.FlexBox(*children, flex_wrap="wrap", sizing_mode="stretch_width")


class ExplorePage:
    """One browser session's page on a machine description.

    Parameters
    ----------
    base : MachineBase
        The machine as described (the page's settings start from it).
    runs : RunCache
        Mechanism runs shared by the sessions.
    cache_dir : path, optional
        Cache folder of the harvest and wear runs (default the runner's, ``$BERRYSHAKER_CACHE`` or
        ~/.cache/berryshaker/runs).
    workers : int, optional
        Local processes of the harvest runs (default 1: the page stays responsive on a small machine).
    source : str
        Where the description came from, for the page's header.
    """

    def __init__(self, base, runs: em.RunCache, cache_dir=None, workers: int | None = None,
                 source: str = "built-in reference machine"):
        self.base = base
        self.runs = runs
        self.cache_dir = cache_dir
        self.workers = workers or 1
        self.doc = pn.state.curdoc
        self._want = None
        self._busy = False
        self._closed = False
        self._lock = threading.Lock()
        self._last_run = None
        ref = em.settings_of(base)
        self._build_controls(ref)
        self._build_mechanism()
        self._build_harvest(ref)
        self._build_wear()
        # the machine's name and the file's path are the user's text: escaped, never markup
        self.header = pn.pane.HTML(
            f"<h2 id='explore-title'>berryshaker explore: {html.escape(str(base.machine.name))}</h2>"
            f"<p>{html.escape(str(source))}; drive <b>{html.escape(base.DRIVE)}</b>.  Provenance tags in brackets: "
            "<i>study</i>, <i>published</i>, <i>assumed</i> from the description, <i>set here</i> where this page "
            "changed the value, <i>computed</i> for model outputs.</p>", sizing_mode="stretch_width")
        main = pn.Column(self.header, self.error, self.status, self.mech_pane, self.peaks,
                         _views(self.harvest_card, self.wear_card), sizing_mode="stretch_width",
                         styles={"flex": f"1 1 {VIEW_MIN_WIDTH}px", "min-width": "0"})
        self.layout = pn.FlexBox(pn.Column(self.header_controls, width=CONTROLS_WIDTH), main, flex_wrap="wrap",
                                 sizing_mode="stretch_width", name="explore_page")
        # the first run starts once the session is live: an update sent while Panel still builds the session is lost
        if self.doc is not None and self.doc.session_context is not None:
            pn.state.onload(self.on_change)
        else:  # no server session (the page built on its own): at once
            self.on_change()

    # ---- threads ---------------------------------------------------------------------------------------
    @staticmethod
    def _thread(fn, *args) -> None:
        """Run ``fn(*args)`` in a daemon thread: Ctrl-C stops the server without waiting for a long run."""
        threading.Thread(target=fn, args=args, daemon=True, name="berryshaker-explore").start()

    def _later(self, fn) -> None:
        """Run ``fn`` on the session's event loop (the document locked), from any thread."""
        if self._closed:
            return
        doc = self.doc
        if doc is not None and doc.session_context is not None:
            doc.add_next_tick_callback(fn)
        else:
            fn()

    # ---- controls --------------------------------------------------------------------------------------
    def _tag(self, key: str, changed: set) -> str:
        return f"[{em.provenance_tag(self.base, key, changed)}]"

    def _build_controls(self, ref: em.Settings) -> None:
        base = self.base
        width = CONTROLS_WIDTH - 20
        self.clearance = {}
        for info in base.PAIRS:
            # the slider spans the pair's test levels and service limit in fine steps; its field takes any size
            # (one beyond the geometric limit is refused with a message naming the field)
            end, step = em.clearance_slider(base, info.name)
            v = dict(ref.clearance_mm)[info.name]
            self.clearance[info.name] = pn.widgets.EditableFloatSlider(
                label=f"clearance {info.name} [mm]", start=0.0, end=end, step=step, value=v, format="0.000",
                fixed_start=None, fixed_end=None, width=width)
        self.speed = pn.widgets.EditableFloatSlider(label="drive-shaft speed [r/min]", start=20.0,
                                                    end=max(240.0, round(ref.speed_rpm * 2)), step=1.0,
                                                    value=ref.speed_rpm, format="0.0", fixed_start=None,
                                                    fixed_end=None, width=width)
        sf = em.stroke_field(base)
        self.stroke = None
        if sf is not None:
            self.stroke = pn.widgets.EditableFloatSlider(
                label=f"{sf[1]} [mm]", start=round(ref.stroke_mm * 0.5, 1), end=round(ref.stroke_mm * 1.5, 1),
                step=0.5, value=ref.stroke_mm, format="0.0", fixed_start=None, fixed_end=None, width=width)
        self.walking = pn.widgets.EditableFloatSlider(label="travel speed [m/min]", start=5.0,
                                                      end=max(60.0, round(ref.walking_speed_m_min * 2)), step=1.0,
                                                      value=ref.walking_speed_m_min, format="0.0", fixed_start=None,
                                                      fixed_end=None, width=width)
        # chosen from the clearances with every run (drawing.magnification_range), the user's choice kept while it
        # still draws a joined linkage
        self.magnify = pn.widgets.FloatSlider(label="clearance magnification in the drawing [x]", start=1.0,
                                              end=1000.0, step=1.0, value=100.0, width=width)
        self._magnify_auto = True
        self.reset = pn.widgets.Button(label="Reset to the description", color="default", width=width)
        self.tags = pn.pane.Markdown("", width=width)
        widgets = [*self.clearance.values(), self.speed, *([self.stroke] if self.stroke else []), self.walking]
        for w in widgets:
            w.param.watch(lambda _e: self.on_change(), "value")
        self.magnify.param.watch(lambda _e: self._magnify_changed(), "value_throttled")
        self.reset.on_click(lambda _e: self._reset())
        self.header_controls = pn.Column(pn.pane.Markdown("### Machine settings"), *widgets, self.tags,
                                         self.magnify, self.reset)
        self.error = pn.pane.Alert("", alert_type="danger", visible=False, sizing_mode="stretch_width")
        self.status = pn.pane.Markdown("", sizing_mode="stretch_width")

    def settings(self) -> em.Settings:
        """The settings the page's fields hold now.

        Returns
        -------
        Settings
            Clearances (mm), drive speed (r/min), stroke (mm) and travel speed (m/min).
        """
        return em.Settings(clearance_mm=tuple((p, w.value) for p, w in self.clearance.items()),
                           speed_rpm=self.speed.value, stroke_mm=self.stroke.value if self.stroke else None,
                           walking_speed_m_min=self.walking.value)

    def _reset(self) -> None:
        ref = em.settings_of(self.base)
        for p, v in ref.clearance_mm:
            self.clearance[p].value = v
        self.speed.value = ref.speed_rpm
        if self.stroke is not None:
            self.stroke.value = ref.stroke_mm
        self.walking.value = ref.walking_speed_m_min

    def _show_tags(self, settings: em.Settings) -> None:
        try:
            changed = em.changed_keys(self.base, settings)
        except (TypeError, ValueError):  # a field emptied: no value to compare
            changed = set()
        keys = [(f"clearance {i.name} ({i.kind}, {i.joins})", f"clearance.{i.name}.size") for i in self.base.PAIRS]
        keys.append(("drive-shaft speed", em.speed_key(self.base)))
        if self.stroke is not None:
            keys.append((em.stroke_field(self.base)[1], em.stroke_field(self.base)[0]))
        keys.append(("travel speed", "operation.walking_speed"))
        self.tags.object = "**Provenance**  \n" + "  \n".join(f"{md_text(lab)}: {md_text(self._tag(k, changed))}"
                                                            for lab, k in keys)

    # ---- mechanism and forces -----------------------------------------------------------------------------
    def _build_mechanism(self) -> None:
        self.frames = ColumnDataSource(data={}, name="explore_frames")
        self.links = ColumnDataSource(data=dict(xs=[], ys=[], colour=[]), name="explore_links")
        self.joints = ColumnDataSource(data=dict(x=[], y=[], r=[], px=[], py=[], colour=[], name=[]),
                                       name="explore_joints")
        self.impacts = ColumnDataSource(data=dict(x=[], y=[], name=[]), name="explore_impacts")
        self.groove = ColumnDataSource(data=dict(x=[], y=[]), name="explore_groove")
        fig = _figure("Comb drive (clearances magnified)", FIGURE_HEIGHT, match_aspect=True, x_axis_label="x [m]",
                      y_axis_label="y [m]", tools="pan,wheel_zoom,reset,save")
        if self.base.DRIVE == "groove_cam":
            fig.line("x", "y", source=self.groove, color="#999999", legend_label="cam pitch curve")
        fig.multi_line("xs", "ys", source=self.links, color="colour", line_width=4)
        fig.circle("x", "y", radius="r", source=self.joints, fill_alpha=0.0, line_color="colour", line_width=3)
        fig.scatter("px", "py", source=self.joints, size=5, color="black")
        fig.scatter("x", "y", source=self.impacts, marker="asterisk", size=16, line_width=2,
                    color="#D62728", legend_label="joint in contact")
        _legend_outside(fig)
        self.frame = Slider(start=0, end=1, value=0, step=1, title="frame (drive-shaft angle over the last revolution)",
                            sizing_mode="stretch_width", min_width=200, name="explore_frame")
        self.play = Button(label="► play / pause", width=140, name="explore_play")
        self.span = Span(location=0.0, dimension="height", line_color="#444444", line_dash="dashed")
        self.forces = ColumnDataSource(data={"t": [], **{p: [] for p in self.base.pair_names}}, name="explore_forces")
        ffig = _figure("Collision force per joint (revolutions 2..3)", FIGURE_HEIGHT, x_axis_label="time [s]",
                       y_axis_label="|collision force| [N]", tools="pan,box_zoom,wheel_zoom,reset,save")
        for k, p in enumerate(self.base.pair_names):
            ffig.line("t", p, source=self.forces, color=_colour(p, k), legend_label=f"{p}", line_width=1.5)
        ffig.legend.click_policy = "hide"
        _legend_outside(ffig)
        ffig.add_layout(self.span)
        args = dict(frames=self.frames, links=self.links, joints=self.joints, impacts=self.impacts,
                    groove=self.groove, span=self.span, frame=self.frame)
        self.frame.js_on_change("value", CustomJS(args=args, code=ANIMATION_JS))
        self.play.js_on_click(CustomJS(args=dict(frame=self.frame), code="""
            if (window._bs_timer) { clearInterval(window._bs_timer); window._bs_timer = null; return; }
            window._bs_timer = setInterval(() => {
                frame.value = frame.value >= frame.end ? 0 : frame.value + 1; }, 80);"""))
        # two panes of one document (the frame slider's callback moves the force plot's marker), side by side or
        # one below the other; shown once the first run has drawn into them (a figure without data has no ranges)
        self._mech_views = [pn.pane.Bokeh(bk_column(fig, bk_row(self.play, self.frame, sizing_mode="stretch_width"),
                                                    sizing_mode="stretch_width")), pn.pane.Bokeh(ffig)]
        self.mech_pane = pn.Column(sizing_mode="stretch_width")
        self.peaks = pn.pane.Markdown("", sizing_mode="stretch_width", name="explore_peaks")

    def on_change(self) -> None:
        """A field changed: show the tags and start a mechanism run of the new settings (the newest wins)."""
        try:
            settings = self.settings()
        except (TypeError, ValueError):
            return
        self._show_tags(settings)
        with self._lock:
            self._want = settings
            if self._busy:
                return
            self._busy = True
        self.status.object = "computing the drive ..."
        self._thread(self._run_loop)

    def _run_loop(self) -> None:
        while True:
            with self._lock:
                settings = self._want
                self._want = None
                if settings is None:
                    self._busy = False
                    return
            try:
                run, cached = self.runs.get(self.base, settings)
                self._later(lambda run=run, cached=cached: self._show_run(run, cached))
            except BerryshakerError as exc:
                self._later(lambda msg=str(exc): self._show_error(msg))
            except Exception as exc:  # noqa: BLE001 - the page shows what went wrong instead of dying
                self._later(lambda msg=f"{type(exc).__name__}: {exc}": self._show_error(msg))

    def _show_error(self, msg: str) -> None:
        self.error.object = f"**These settings are refused**: {md_text(msg)}"
        self.error.visible = True
        self.status.object = "the plots show the last settings that ran"

    def _show_run(self, run: em.MechanismRun, cached: bool) -> None:
        self.error.visible = False
        self._last_run = run
        t, series = decimate_minmax_shared(run.t, run.forces, n_bins=1500)
        self.forces.data = {"t": t, **{p: series[p] for p in run.forces}}
        if run.frames is not None:
            self._choose_magnification(run.frames)
        self._redraw()
        if not self.mech_pane.objects:
            self.mech_pane.objects = [_views(*self._mech_views) if run.frames is not None else self._mech_views[1]]
        self.peaks.object = clearance_table(self.base, run, em.changed_keys(self.base, self.settings()))
        how = "from memory" if cached else f"in {run.wall_time_s:.2f} s"
        self.status.object = (f"{run.model} model of the {run.machine.DRIVE} drive, {em.REVOLUTIONS} revolutions, "
                              f"statistics over revolutions 2..{em.REVOLUTIONS}: ran {how}")

    def _choose_magnification(self, frames: dict) -> None:
        """The magnification slider's range for these clearances, and its value: the default unless the user chose
        one that still draws a joined linkage (:func:`berryshaker.explore.drawing.magnification_range`)."""
        default, largest = magnification_range(frames)
        keep = not self._magnify_auto and self.magnify.value <= largest
        self._magnify_auto = not keep
        self.magnify.param.update(end=largest, value=self.magnify.value if keep else default)

    def _magnify_changed(self) -> None:
        """The user moved the magnification slider (``value_throttled`` follows a drag, never the code)."""
        self._magnify_auto = False
        self._redraw()

    def _redraw(self) -> None:
        run = self._last_run
        if run is None or run.frames is None:
            return
        data = frame_data(run.frames, self.magnify.value)
        self.frames.data = data
        n = len(data["t"])
        self.frame.end = max(n - 1, 1)
        k = min(self.frame.value, n - 1)
        self.frame.value = k
        links, joints, impacts, groove = frame_at(data, k)
        self.links.data, self.joints.data, self.impacts.data, self.groove.data = links, joints, impacts, groove
        self.span.location = float(data["t"][k])

    # ---- harvest: removal against frequency ------------------------------------------------------------------
    def _build_harvest(self, ref: em.Settings) -> None:
        lo, hi = round(ref.speed_rpm * 0.6), round(ref.speed_rpm * 1.4)
        width = CONTROLS_WIDTH - 20
        self.h_range = pn.widgets.RangeSlider(label="drive-shaft speeds [r/min]", start=20, end=max(240, hi * 2),
                                              value=(lo, hi), step=1, width=width)
        self.h_points = pn.widgets.IntSlider(label="speeds [1]", start=2, end=9, value=5, width=width)
        self.h_run = pn.widgets.Button(label="Run the virtual harvest", color="primary", width=width)
        self.h_progress = pn.indicators.Progress(value=0, max=100, width=width, visible=False)
        self.h_status = pn.pane.Markdown("Coupled machine-plant runs, one per replicate start and speed, on every "
                                         "worker (about 20 s for 5 speeds of 8 starts on 2 cores); a repeated "
                                         "speed is read from the cache.",
                                         sizing_mode="stretch_width")
        self.h_src = ColumnDataSource(data=dict(f=[], ripe=[], unripe=[], damage=[]), name="explore_harvest")
        fig = _figure("Removal against shaking frequency", CARD_FIGURE_HEIGHT, x_axis_label="shaking frequency [Hz]",
                      y_axis_label="share of the fruit [%]", tools="pan,wheel_zoom,reset,save")
        for k, (col, lab) in enumerate((("ripe", "ripe removal"), ("unripe", "unripe shed"), ("damage", "damage"))):
            fig.line("f", col, source=self.h_src, color=SERIES_COLOURS[k], legend_label=lab, line_width=2)
            fig.scatter("f", col, source=self.h_src, color=SERIES_COLOURS[k], size=7)
        _legend_outside(fig)
        self.h_table = pn.pane.Markdown("", sizing_mode="stretch_width")
        self.h_run.on_click(lambda _e: self._start_harvest())
        self._h_figure = pn.pane.Bokeh(fig, sizing_mode="stretch_width")
        self.h_plot = pn.Column(sizing_mode="stretch_width")  # the figure, once there is a result to draw
        self.harvest_card = pn.Card(self.h_range, self.h_points, self.h_run, self.h_progress, self.h_status,
                                    self.h_plot, self.h_table, title="Removal against frequency (virtual harvest)")

    def _start_harvest(self) -> None:
        try:
            machine = em.build_machine(self.base, self.settings())
            jobs, speeds = harvest_jobs(machine, self.h_range.value, self.h_points.value)
        except BerryshakerError as exc:
            self.h_status.object = f"**refused**: {md_text(exc)}"
            return
        self.h_run.disabled = True
        self.h_progress.visible = True
        self.h_progress.value = 0
        self.h_status.object = f"running {len(jobs)} speeds ..."
        self._thread(self._harvest_thread, jobs, speeds, self.settings())

    def _harvest_thread(self, jobs, speeds, settings) -> None:
        from berryshaker.runs.runner import SweepRunner
        from berryshaker.study.runs import replicate_run

        rows, errors = [], []
        try:
            with SweepRunner(workers=self.workers, cache_dir=self.cache_dir, progress=False) as runner:
                runner.prefetch(replicate_run, [j for per in jobs for j in per])  # every worker busy to the end
                for k, (per, rpm) in enumerate(zip(jobs, speeds)):
                    outs = runner.map(replicate_run, per, "virtual harvest")
                    value, failed = harvest_row(per, outs)
                    errors.extend(f"{rpm:.0f} r/min, {e}" for e in failed)
                    if value is not None:
                        rows.append((rpm, value, all(o.cached for o in outs)))
                    done = k + 1
                    self._later(lambda done=done: self._harvest_progress(done, len(jobs)))
        except Exception as exc:  # noqa: BLE001 - shown in the page
            errors.append(f"{type(exc).__name__}: {exc}")
        self._later(lambda: self._harvest_done(rows, errors, settings))

    def _harvest_progress(self, done: int, total: int) -> None:
        self.h_progress.value = int(100 * done / total)
        self.h_status.object = f"{done} of {total} speeds done ..."

    def _harvest_done(self, rows, errors, settings) -> None:
        self.h_run.disabled = False
        self.h_progress.visible = False
        self.h_src.data = dict(f=[r[1]["shaking_frequency_hz"] for r in rows],
                               ripe=[r[1]["ripe_removal_pct"] for r in rows],
                               unripe=[r[1]["unripe_shed_pct"] for r in rows],
                               damage=[r[1]["damage_rate_pct"] for r in rows])
        if rows and not self.h_plot.objects:
            self.h_plot.objects = [self._h_figure]
        self.h_table.object = harvest_table(rows, settings)
        self.h_status.object = (f"{len(rows)} speeds ran ({sum(1 for r in rows if r[2])} from the cache)"
                                + ("; failed: " + "; ".join(md_text(e) for e in errors) if errors else ""))

    # ---- wear and service interval -------------------------------------------------------------------------
    def _build_wear(self) -> None:
        width = CONTROLS_WIDTH - 20
        self.w_hours = pn.widgets.FloatInput(label="operating hours to simulate [h]", value=2000.0, start=1.0,
                                             end=1e6, step=100.0, width=width)
        self.w_run = pn.widgets.Button(label="Run the wear simulation", color="primary", width=width)
        self.w_progress = pn.indicators.Progress(value=-1, active=True, width=width, visible=False)
        self.w_status = pn.pane.Markdown("Archard wear of every joint on the multibody model, re-simulated as the "
                                         "clearances grow (berryshaker wear); each simulation cached.",
                                         sizing_mode="stretch_width")
        self.w_src = ColumnDataSource(data=dict(xs=[], ys=[], colour=[], name=[]), name="explore_wear")
        # each joint's service limit (docs/life.md), dashed in the joint's colour across the hours simulated
        self.w_limits = ColumnDataSource(data=dict(xs=[], ys=[], colour=[], name=[]), name="explore_wear_limits")
        fig = _figure("Clearance growth by wear", CARD_FIGURE_HEIGHT, x_axis_label="operating time [h]",
                      y_axis_label="clearance [mm]", tools="pan,wheel_zoom,reset,save")
        fig.multi_line("xs", "ys", source=self.w_src, color="colour", line_width=2, legend_field="name")
        fig.multi_line("xs", "ys", source=self.w_limits, color="colour", line_width=1.5, line_dash="dashed",
                       legend_label="service limit (dashed)")
        _legend_outside(fig, ncols=2)
        self.w_table = pn.pane.Markdown("", sizing_mode="stretch_width")
        self.w_run.on_click(lambda _e: self._start_wear())
        self._w_figure = pn.pane.Bokeh(fig, sizing_mode="stretch_width")
        self.w_plot = pn.Column(sizing_mode="stretch_width")  # the figure, once there is a result to draw
        self.wear_card = pn.Card(self.w_hours, self.w_run, self.w_progress, self.w_status, self.w_plot,
                                 self.w_table, title="Wear and service interval")

    def _start_wear(self) -> None:
        hours = self.w_hours.value
        try:
            if hours is None or not (math.isfinite(hours) and 0 < hours <= 1e7):
                raise BerryshakerError(f"operating hours {hours!r}: give hours in (0, 1e7] h")
            machine = em.build_machine(self.base, self.settings())
        except BerryshakerError as exc:
            self.w_status.object = f"**refused**: {md_text(exc)}"
            return
        self.w_run.disabled = True
        self.w_progress.visible = True
        self.w_status.object = "wear: starting ..."
        self._thread(self._wear_thread, machine, float(hours), self.settings())

    def _wear_thread(self, machine, hours: float, settings) -> None:
        from berryshaker.life.service import machine_wear
        from berryshaker.runs.runner import SweepRunner

        res, error = None, None
        try:
            with SweepRunner(workers=1, cache_dir=self.cache_dir, progress=False) as runner:
                res = machine_wear(machine, hours, runner=runner,
                                   say=lambda m: self._later(lambda m=m: self._wear_say(m)))
        except Exception as exc:  # noqa: BLE001 - shown in the page
            error = f"{type(exc).__name__}: {exc}" if not isinstance(exc, BerryshakerError) else str(exc)
        self._later(lambda: self._wear_done(res, error, settings))

    def _wear_say(self, msg: str) -> None:
        self.w_status.object = f"wear: {md_text(msg)}"

    def _wear_done(self, res, error, settings) -> None:
        self.w_run.disabled = False
        self.w_progress.visible = False
        if error is not None:
            self.w_status.object = f"**wear failed**: {md_text(error)}"
            return
        joints = res["joints"]
        self.w_src.data = dict(xs=[np.asarray(d["hours"], float) for d in joints.values()],
                               ys=[np.asarray(d["clearance_mm"], float) for d in joints.values()],
                               colour=[_colour(j, k) for k, j in enumerate(joints)],
                               name=[f"{j} ({d['size_convention']})" for j, d in joints.items()])
        self.w_limits.data = wear_limit_lines(res, [_colour(j, k) for k, j in enumerate(joints)])
        if not self.w_plot.objects:
            self.w_plot.objects = [self._w_figure]
        self.w_table.object = wear_table(res)
        self.w_status.object = (f"{res['simulations']} simulations ({res['simulations_from_cache']} from the cache) "
                                f"in {res['wall_time_s']:.1f} s")

    def close(self) -> None:
        """The session ended: no page updates any more (runs under way finish into the caches)."""
        self._closed = True
