"""One exception hierarchy for mbinspect.

Every error a user can cause derives from :class:`MBInspectError` and also from the
built-in it resembles (``ValueError`` for bad values, ``OSError`` for files), so callers
can catch either. The message is one line that names the file, line, column or
parameter, the bad value and what was expected; the CLI prints it as it is.
"""

from __future__ import annotations

__all__ = [
    "MBInspectError",
    "InputError",
    "ParameterError",
    "NotEnoughPointsError",
    "FileAccessError",
    "DataError",
    "InputWarning",
]


class MBInspectError(Exception):
    """Base class of every error mbinspect raises on purpose.

    ``option`` is the library name of the option to blame, when there is one (the message
    then starts with ``"<option>: "``); the command line prints it under the flag's name.
    """

    def __init__(self, message: str = "", *, option: str | None = None) -> None:
        super().__init__(message)
        self.option = option


class FileAccessError(MBInspectError, OSError):
    """A file or folder cannot be read or written (missing, a directory, exists)."""


class InputError(MBInspectError, ValueError):
    """The content of an input file is malformed (bad cell, column count, format)."""


class ParameterError(MBInspectError, ValueError):
    """An option has a value that makes no sense (negative radius, unknown name)."""


class NotEnoughPointsError(MBInspectError, ValueError):
    """Too few points for a stage to give an answer."""


class DataError(MBInspectError, ValueError):
    """The data are well formed but cannot support the answer asked for."""


class NoAnswer(MBInspectError):
    """A command's data could not support its answer; the reason was written to ``written``
    (the command line's exit status 5, distinct from a user's mistake)."""

    def __init__(self, cause: MBInspectError, written: str) -> None:
        super().__init__(str(cause), option=cause.option)
        self.cause = cause
        self.written = written


class InputWarning(UserWarning):
    """A doubt about an input file that does not stop the read (the CLI prints one line)."""
