"""The command line shows each warning once per command (cli/__init__.py): init builds the task storey's
map once per storage proposal, and each build logged the same map warnings again (issue 10's checker saw
each split-level and footing warning three or four times)."""

from __future__ import annotations

import io
import logging
import subprocess
import sys

from kbplanner.cli import _WarnOnce


def test_a_repeated_warning_is_shown_once_and_other_levels_always() -> None:
    stream = io.StringIO()
    handler = logging.StreamHandler(stream)
    handler.addFilter(_WarnOnce())
    log = logging.getLogger("kbplanner.test_warn_once")
    log.addHandler(handler)
    log.propagate = False
    try:
        for _ in range(3):
            log.warning("map of %s: raised floor", "Level 1")
            log.error("bad %d", 1)
        log.warning("map of %s: raised floor", "Level 2")
    finally:
        log.removeHandler(handler)
    lines = stream.getvalue().splitlines()
    assert lines.count("map of Level 1: raised floor") == 1
    assert lines.count("map of Level 2: raised floor") == 1
    assert lines.count("bad 1") == 3


def test_the_console_of_a_command_gets_the_filter() -> None:
    code = ("import logging, sys\n"
            "from kbplanner.cli import main\n"
            "sys.argv = ['kbplanner', 'validate', '/nonexistent-project']\n"
            "main()\n"
            "for _ in range(2):\n"
            "    logging.getLogger('kbplanner.x').warning('same')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert out.stderr.count("WARNING kbplanner.x: same") == 1, out.stderr
