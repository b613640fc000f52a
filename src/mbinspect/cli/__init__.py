"""The ``mbinspect`` command line: a thin layer over the library, one module per command.

Each command checks its options and its output folder before any work, reads its input,
calls one library function and writes that function's result. A user's mistake is one
line on stderr (``mbinspect: error: ...``) naming the flag, file, line or column, with exit
status 2, never a traceback; warnings are one ``mbinspect: warning: ...`` line each. Flags
of the pipelines are generated from their options classes (:mod:`.flags`), so no default is
written twice. Ctrl-C and SIGTERM end a run within a second with status 130 and 143,
leaving nothing partial behind (:mod:`mbinspect.interrupt`).
"""

from .main import build_parser, main

__all__ = ["main", "build_parser"]

# the console entry point is mbinspect.command.run: it blocks the signals before this
# package imports numpy
