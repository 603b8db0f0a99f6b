"""Exceptions that carry a message meant for the user (the CLI prints them without a traceback)."""


class BerryshakerError(Exception):
    """Base class of every error whose message is written for an engineer, not a developer."""


class ConfigError(BerryshakerError):
    """A machine description is missing a value, has a wrong unit or an impossible number."""


class GeometryError(BerryshakerError):
    """The mechanism cannot be built as described (linkage does not assemble, cam undercuts...)."""


class SimulationError(BerryshakerError):
    """A simulation could not be completed (solver gave up, non-finite state...)."""


class OutputError(BerryshakerError):
    """An output destination is refused (would overwrite the user's files, wrong suffix, not writable...)."""


class WriteError(OutputError, OSError):
    """A file could not be written (a full disk, a read-only disk, no permission): the message names the file and
    what to do, and nothing was written (no file half-written, no pair of files with one missing).  Also an
    :class:`OSError`, so code that handles a failed write of its own (the run cache) still does."""
