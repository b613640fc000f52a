"""``python -m mbinspect.cli``: the command line."""

from .main import run

run()
