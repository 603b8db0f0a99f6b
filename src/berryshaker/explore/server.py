"""The ``berryshaker explore`` page's server: one page per browser session on a loopback address, answering only
requests addressed to that address.

A server on 127.0.0.1 is still reachable from a web page elsewhere through DNS rebinding (a name of the other
site's that resolves to 127.0.0.1): the browser then sends that name in the ``Host`` header.  Bokeh checks the
``Origin`` of the page's websocket (``websocket_origin``), not the ``Host`` of its HTTP requests, so the server
adds a rule before Bokeh's routes (tornado's ``Application.add_handlers``): a request whose ``Host`` names
anything but the address served (127.0.0.1 and localhost name the same loopback address) is refused with 403
and nothing else: no page, no session, no run.
"""

from __future__ import annotations

import asyncio
import re
import threading

import panel as pn
import tornado.web

from berryshaker.errors import ConfigError
from berryshaker.explore.app import ExplorePage
from berryshaker.explore.model import RunCache

#: the host names of the loopback address served (a page reached under another name is refused)
LOOPBACK_ALIASES = ("127.0.0.1", "localhost")


def allowed_hosts(host: str) -> tuple[str, ...]:
    """The ``Host`` names the server answers: the address it binds, and its other loopback name.

    Parameters
    ----------
    host : str
        The loopback address served (:func:`berryshaker.explore.check_loopback`).

    Returns
    -------
    tuple of str
        Lower-case host names without port.
    """
    host = host.lower()
    return (host, *[h for h in LOOPBACK_ALIASES if h != host]) if host in LOOPBACK_ALIASES else (host,)


class WrongHostHandler(tornado.web.RequestHandler):
    """403 for a request whose ``Host`` header names another server (DNS rebinding); says which address to use.

    Parameters
    ----------
    application : tornado.web.Application
        The server's application (tornado makes one handler per request).
    request : tornado.httputil.HTTPServerRequest
        The request refused.
    **kwargs
        ``served``, given to :meth:`initialize`.
    """

    def initialize(self, served: str) -> None:
        """Remember the address served.

        Parameters
        ----------
        served : str
            ``http://HOST:PORT``, for the message.
        """
        self.served = served

    def prepare(self) -> None:
        """Answer every method with 403 before any handler work."""
        self.set_status(403)
        self.set_header("Content-Type", "text/plain; charset=utf-8")
        self.finish(f"berryshaker explore answers only requests addressed to {self.served}\n")


def guard_hosts(server, host: str, port: int) -> None:
    """Refuse requests to ``server`` whose ``Host`` is not :func:`allowed_hosts` of ``host``.

    Parameters
    ----------
    server : bokeh.server.server.Server
        The Bokeh server, before it starts serving.
    host : str
        The loopback address it binds.
    port : int
        Its port (for the message).
    """
    names = "|".join(re.escape(h) for h in allowed_hosts(host))
    # the Bokeh server's tornado Application (Panel reads the same attribute): a host rule goes before its routes
    server._tornado.add_handlers(rf"(?!(?:{names})$).*",
                                 [(r".*", WrongHostHandler, {"served": f"http://{host}:{port}"})])


def make_app(base, cache_dir=None, workers: int | None = None, source: str = "built-in reference machine"):
    """The page factory Panel calls once per browser session.

    Parameters
    ----------
    base : MachineBase
        The machine description.
    cache_dir : path, optional
        Cache folder of the long runs.
    workers : int, optional
        Local processes of the harvest runs.
    source : str
        Where the description came from (the page's header).

    Returns
    -------
    callable
        ``() -> panel layout``; the sessions share one :class:`~berryshaker.explore.model.RunCache`.
    """
    runs = RunCache()

    def page():
        p = ExplorePage(base, runs, cache_dir=cache_dir, workers=workers, source=source)
        pn.state.on_session_destroyed(lambda _ctx: p.close())  # noqa: B023
        return p.layout

    return page


def _server(apps: dict, host: str, port: int, loop=None):
    """The Panel/Bokeh server of ``apps`` on ``host:port``, its hosts guarded, not started yet."""
    try:
        server = pn.serve(apps, port=port, address=host, loop=loop, show=False, start=False, verbose=False,
                          websocket_origin=[f"{h}:{port}" for h in allowed_hosts(host)], title="berryshaker explore")
    except OSError as exc:  # the port taken between the check and the start
        raise ConfigError(f"the page's server could not start on {host}:{port} ({exc.strerror or exc}): choose "
                          "another port with --port") from None
    guard_hosts(server, host, port)
    return server


class ServerThread(threading.Thread):
    """The page's server on an event loop of its own thread (tests); :meth:`stop` ends it.

    Parameters
    ----------
    apps : dict
        Panel's applications by path.
    host : str
        Loopback address.
    port : int
        TCP port.
    """

    def __init__(self, apps: dict, host: str, port: int):
        super().__init__(daemon=True, name="berryshaker-explore-server")
        self._serve_args = (apps, host, port)
        self._ready = threading.Event()
        self._error: Exception | None = None
        self.loop = self.server = None

    def run(self) -> None:
        """Start the server and serve until :meth:`stop`."""
        from tornado.ioloop import IOLoop

        asyncio.set_event_loop(asyncio.new_event_loop())
        self.loop = IOLoop.current()
        try:
            self.server = _server(*self._serve_args, loop=self.loop)
            self.server.start()
        except Exception as exc:  # noqa: BLE001 - handed to the thread that waits in begin()
            self._error = exc
            self._ready.set()
            return
        self._ready.set()
        try:
            self.loop.start()
        finally:
            self.server.stop()
            self.loop.close(all_fds=False)

    def begin(self) -> ServerThread:
        """Start the thread and wait until the server listens.

        Returns
        -------
        ServerThread
            Itself.

        Raises
        ------
        ConfigError
            The server could not start.
        """
        self.start()
        self._ready.wait(60)
        if self._error is not None:
            raise self._error
        return self

    def stop(self) -> None:
        """Stop serving and wait for the thread."""
        if self.loop is not None and self.is_alive():
            self.loop.add_callback(self.loop.stop)
            self.join(10)


def serve(base, port: int, host: str = "127.0.0.1", cache_dir=None, workers: int | None = None,
          source: str = "built-in reference machine", threaded: bool = False):
    """Serve the page on ``host:port`` (loopback only, answering only that address).

    Parameters
    ----------
    base : MachineBase
        The machine description.
    port : int
        TCP port (free: :func:`berryshaker.explore.check_port`).
    host : str
        Loopback address.
    cache_dir, workers, source
        As :func:`make_app`.
    threaded : bool
        False: serve until stopped (Ctrl-C); True: serve in a thread and return it once it listens (tests;
        ``.stop()`` ends it).

    Returns
    -------
    ServerThread or None
        The serving thread (``threaded=True``).

    Raises
    ------
    ConfigError
        A host that is not a loopback address, or a port taken.
    """
    from berryshaker.explore import check_loopback

    check_loopback(host)
    pn.extension()
    apps = {"explore": make_app(base, cache_dir, workers, source)}
    if threaded:
        return ServerThread(apps, host, port).begin()
    server = _server(apps, host, port)
    server.start()
    server.io_loop.start()
    return None
