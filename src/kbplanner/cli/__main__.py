"""``python -m kbplanner.cli``: the same as the ``kbplanner`` console script."""

from kbplanner.cli import command_line

command_line()
