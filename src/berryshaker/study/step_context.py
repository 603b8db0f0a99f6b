"""What every step of the study (:data:`berryshaker.study.steps.STEPS`) gets and gives: the study context
(:class:`StudyContext`: the machine, its drive, the runner, the figure folder, the failure log, and figures drawn in
idle pool workers, :func:`draw_figure`), the runs a step will ask for, known before it starts (:class:`PlannedRuns`),
and how a run's clearances read in the failure log (:func:`describe_clearance`).

Kept apart from the pipeline that runs the steps, so that the step modules (:mod:`berryshaker.study.steps`)
import it without importing the pipeline that imports them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from berryshaker.drives import drive_of
from berryshaker.study.step_result import FailedRun


def _silent(msg: str) -> None:
    """A progress message nobody reads (the default ``StudyContext.say``).

    Parameters
    ----------
    msg : str
        The message (ignored).
    """


def _nothing() -> None:
    """No action (the default ``StudyContext.engine_compiled``)."""


@dataclass
class StudyContext:
    """What every step gets: the machine, its drive, the runner, the figure folder and the failure log.

    Attributes
    ----------
    machine : MachineBase
        The study's machine description.
    runner : SweepRunner
        Runs the steps' runs (cached).
    figs : Path
        Folder the figures are written to.
    failures : list of FailedRun
        Failed runs (step, run, inputs, error), for the report.
    say : callable
        ``say(msg)``: progress messages (default silent).
    results : dict
        The records of the steps run so far, by their result name (the fields of
        :class:`~berryshaker.study.step_result.StudyResults`: ``rows``, ``fruit_force`` ...).
    drawing : list
        Figures being drawn in pool workers: (future, pickled call).
    draw_in_workers : bool
        Whether :meth:`draw` may use a pool worker (False: every figure is drawn in this process).
    engine_compiled : callable
        Called by the step that compiles the multibody engine once it has (then the planned runs that need it
        start).
    """

    machine: object
    runner: object
    figs: Path
    failures: list = field(default_factory=list)
    say: Callable[[str], None] = field(default=None)
    results: dict = field(default_factory=dict)  # records of the steps run so far, by result name
    drawing: list = field(default_factory=list)  # figures drawn in pool workers: (future, pickled call)
    draw_in_workers: bool = True  # False: every figure is drawn in this process (a study with nothing to compute)
    # called by the step that compiles the multibody engine once it has (run_steps then starts the planned runs
    # that need it, while that step still plots)
    engine_compiled: Callable[[], None] = field(default=None)

    def __post_init__(self):
        """Silent defaults for the callbacks (``say``, ``engine_compiled``) not given."""
        if self.say is None:
            self.say = _silent
        if self.engine_compiled is None:
            self.engine_compiled = _nothing

    @property
    def drive(self):
        """The machine's drive plug-in."""
        return drive_of(self.machine)

    @property
    def data(self) -> dict:
        """The machine as a JSON-compatible dict (what the run functions take)."""
        return self.machine.model_dump(mode="json")

    @property
    def figure_cache(self) -> Path | None:
        """The folder of the figures kept between studies (:mod:`berryshaker.report.plots.figure_cache`):
        ``figures`` in the runner's run cache, under its ownership rule; None when the runner has no cache."""
        folder = getattr(self.runner, "cache_dir", None)
        if folder is None or not getattr(self.runner, "use_cache", False):
            return None
        return Path(folder) / "figures"

    def draw(self, fn, *args, **kwargs) -> None:
        """Draw a figure (``fn(*args, **kwargs)``, a function of berryshaker.report.plots: data in, its PNG and
        SVG out).  The same call drawn before (same function, code, arguments and library versions) is copied from
        the :attr:`figure_cache`, the same bytes (:func:`berryshaker.report.plots.figure_cache.draw_cached`).  Else
        it is drawn in a pool worker when the runner has a local pool and :attr:`draw_in_workers`, or here;
        :meth:`finish_drawing` waits for it.  The figure functions set their
        whole style themselves (berryshaker.report.style), so a worker draws what this process would; a matplotlib
        style set globally by a program that calls :func:`~berryshaker.study.pipeline.run_study` does not reach the
        workers.

        Parameters
        ----------
        fn : callable
            The figure function.
        *args
            Its positional arguments (pickled now).
        **kwargs
            Its keyword arguments (pickled now).
        """
        import pickle

        from berryshaker.report.plots.figure_cache import draw_cached, figure_key, restore_figure

        cache = self.figure_cache
        key = None if cache is None else figure_key(fn, args, kwargs, self.figs)
        if restore_figure(cache, key, self.figs):
            return
        if key is None:
            cache = None  # a call that is not kept (its arguments do not pickle, a function of another package)
        # pickled now: the pool pickles a call's arguments later, in its own thread, and the step's data may
        # change meanwhile (the next steps and the claims add to the results)
        if not self.draw_in_workers:
            draw_cached(cache, fn, args, kwargs, self.figs, key)
            return
        job = dict(payload=pickle.dumps((fn, args, kwargs)), cache=None if cache is None else str(cache),
                   figs=str(self.figs), key=key)
        fut = self.runner.warm_up(draw_figure, job)
        if fut is None:
            draw_cached(cache, fn, args, kwargs, self.figs, key)
        else:
            self.drawing.append((fut, job))

    def finish_drawing(self) -> None:
        """Wait for the figures drawn in workers (:meth:`draw`).  A figure whose worker died (the pool broke) or was
        cancelled is drawn here; an error of the figure function itself is raised here, as without the pool."""
        from concurrent.futures import CancelledError
        from concurrent.futures.process import BrokenProcessPool

        pending, self.drawing = self.drawing, []
        for fut, job in pending:
            try:
                fut.result()
            except (BrokenProcessPool, CancelledError):
                self.say("a worker drawing a figure stopped; drawing it here")
                draw_figure(**job)

    def collect(self, fn, jobs, label, describe):
        """Run jobs through the sweep runner; failed runs are logged and come back as None.

        Parameters
        ----------
        fn : callable
            A module-level run function.
        jobs : list of dict
            Its keyword arguments, one dict per run.
        label : str
            Progress label, and the failure log's step.
        describe : callable
            ``describe(job) -> str``: the inputs of a failed run, for the log.

        Returns
        -------
        list
            Each run's value in the jobs' order, None where it failed.
        """
        outs = self.runner.map(fn, jobs, label)
        for o in outs:
            if o.error:
                self.failures.append(FailedRun(step=label, run=o.index + 1, inputs=describe(jobs[o.index]),
                                               error=o.error))
        return [o.value for o in outs]


def draw_figure(payload: bytes, cache: str | None = None, figs: str | None = None, key: str | None = None) -> None:
    """Draw a figure of :meth:`StudyContext.draw` in a pool worker: ``payload`` is the pickled call
    ``(fn, args, kwargs)``, kept in the figure cache ``cache`` under ``key`` when given
    (:func:`berryshaker.report.plots.figure_cache.draw_cached`).

    Parameters
    ----------
    payload : bytes
        The pickled call.
    cache : str, optional
        The figure cache folder; None: keep nothing.
    figs : str, optional
        The figure folder the call writes into (needed with ``cache``).
    key : str, optional
        The call's key, as the study computed it before pickling the call.
    """
    import pickle

    from berryshaker.report.plots.figure_cache import draw_cached

    fn, args, kwargs = pickle.loads(payload)
    if cache is None or figs is None:
        fn(*args, **kwargs)
    else:
        draw_cached(cache, fn, args, kwargs, figs, key)


@dataclass
class PlannedRuns:
    """Runs a step will ask the runner for, known before it starts: the study starts them ahead in idle workers
    (``SweepRunner.prefetch``) and the step's own map takes their results.  ``engine``: they need the compiled
    multibody engine (started only once this process has compiled it, so workers do not compile it too).

    Attributes
    ----------
    fn : callable
        The module-level run function.
    jobs : list of dict
        Its keyword arguments, one dict per run.
    label : str
        The step's label of these runs.
    engine : bool
        Whether the runs need the compiled multibody engine.
    """

    fn: Callable
    jobs: list[dict]
    label: str
    engine: bool = True


def describe_clearance(clearance: dict) -> str:
    """A run's clearances as the failure log names them (e.g. "A 0.1 mm, C 0.2 mm").

    Parameters
    ----------
    clearance : dict of str to float
        Clearance size (m) per pair; empty for the configured clearances.

    Returns
    -------
    str
        Each pair with its clearance in mm, or "as configured".
    """
    return ", ".join(f"{p} {v * 1e3:g} mm" for p, v in clearance.items()) or "as configured"
