"""The exit statuses of ``mbinspect``, in one place."""

from __future__ import annotations

EXIT_USER = 2


EXIT_FLAGGED = 3  # results written, but a pile is flagged or a spacing fails the design


EXIT_IO = 1  # the output could not be written (a full disk)


EXIT_UNDECIDED = 4  # results written, nothing fails, but a verdict is undecided at 95 %


EXIT_DATA = 5  # the data cannot support an answer: the reason written (no_answer.json)


EXIT_PIPE = 141  # the reader of our output went away (128 + SIGPIPE)
