"""``berryshaker explore``: a local web page to explore a machine description interactively (docs/explore.md).

:mod:`.model` holds what the page computes (the settings applied to the machine, the library runs behind each
view), :mod:`.drawing` the drive drawn from a run, :mod:`.views` what the page draws and prints from a run,
:mod:`.app` the Panel page, :mod:`.server` its server (answering only its own host).  This module holds the checks the command makes before serving (loopback host, free port); it does not
import Panel, so ``berryshaker --help`` stays fast.
"""

from __future__ import annotations

import ipaddress
import socket

from berryshaker.errors import ConfigError

#: host names accepted as loopback besides loopback IP addresses
LOOPBACK_NAMES = ("localhost",)


def check_loopback(host: str) -> str:
    """Refuse a host that is not a loopback address: the page runs simulations for whoever reaches it.

    Parameters
    ----------
    host : str
        Address to serve on ("127.0.0.1", "localhost").

    Returns
    -------
    str
        ``host`` unchanged.

    Raises
    ------
    ConfigError
        ``host`` is not an IPv4 loopback address or "localhost".
    """
    if host in LOOPBACK_NAMES:
        return host
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        address = None
    if address is None or not address.is_loopback:
        raise ConfigError(f"--host {host!r}: explore serves only on this computer (a loopback address such as "
                          "127.0.0.1 or localhost); it runs simulations for anyone who can reach it")
    if address.version != 4:
        raise ConfigError(f"--host {host!r}: the page's server (Bokeh) takes no IPv6 address; use 127.0.0.1 or "
                          "localhost")
    return host


def check_port(host: str, port: int) -> int:
    """Check that ``port`` on ``host`` is free by binding it once.

    Parameters
    ----------
    host : str
        Loopback address.
    port : int
        TCP port, 1..65535.

    Returns
    -------
    int
        ``port``.

    Raises
    ------
    ConfigError
        The port is out of range or in use, naming it and the fix.
    """
    if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
        raise ConfigError(f"--port {port!r}: give a TCP port in 1..65535")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind((host, port))
        except OSError as exc:
            raise ConfigError(f"port {port} on {host} is not free ({exc.strerror or exc}); another program "
                              "(or another explore) uses it: choose another with --port") from None
    return port
