"""Progress lines where stderr is no terminal (CI logs, nohup): issue 17."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

from rich.console import Console

from kbplanner.cli.progress import PlainLines, plain_counter, status
from project_factory import make_project


def test_plain_status_prints_each_new_message_once() -> None:
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=False)
    with status(console, "starting") as say:
        say("loading")
        say("loading")
        say("validating")
    lines = buf.getvalue().splitlines()
    assert [line.split("] ", 1)[1] for line in lines] == ["starting", "loading", "validating"]
    assert all(line.startswith("[") and " s] " in line for line in lines)


def test_counts_are_throttled_but_the_last_one_is_printed() -> None:
    buf = io.StringIO()
    lines = PlainLines(buf, every_s=3600.0)
    for done in range(1, 11):
        lines.count("B5", done, 10)
    printed = buf.getvalue().splitlines()
    assert [p.split("] ", 1)[1] for p in printed] == ["B5: 1/10", "B5: 10/10"]


def test_a_terminal_gets_no_plain_lines() -> None:
    assert plain_counter(Console(file=io.StringIO(), force_terminal=True)) is None


def test_a_command_with_stderr_in_a_pipe_shows_progress(tmp_path: Path) -> None:
    make_project(tmp_path / "p")
    proc = subprocess.run([sys.executable, "-m", "kbplanner", "run", str(tmp_path / "p"), "--no-simulation",
                           "--out", str(tmp_path / "out")], capture_output=True, text=True, check=False)
    assert "import and load" in proc.stderr, proc.stderr
    assert "s] " in proc.stderr
