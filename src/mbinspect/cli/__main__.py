"""``python -m mbinspect.cli``: the command line."""

from ..command import run

run()
