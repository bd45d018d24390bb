"""The program's end (issue 14: a whole building's run): ``python -m kbplanner`` ends the process
without the interpreter's teardown, after flushing what it printed, with the command's exit code;
:func:`kbplanner.cli.main` itself returns (tests, notebooks)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from kbplanner.cli import main

SRC = Path(__file__).resolve().parents[1] / "src"


def _kbplanner(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    return subprocess.run([sys.executable, "-m", "kbplanner", *args], capture_output=True, text=True,
                          env=env, timeout=300)


def test_the_program_flushes_its_output_and_ends_with_the_command_s_exit_code(tmp_path: Path) -> None:
    ok = _kbplanner("--version")
    assert ok.returncode == 0 and ok.stdout.startswith("kbplanner ")
    bad = _kbplanner("run", str(tmp_path / "no-project"), "--out", str(tmp_path / "run"))
    assert bad.returncode == 2
    assert "kbplanner: error:" in bad.stderr and "fix:" in bad.stderr.splitlines()[-1]  # flushed, to the end
    assert "Traceback" not in bad.stderr
    assert not (tmp_path / "run").exists()


def test_main_returns_the_exit_code_in_the_calling_process(tmp_path: Path) -> None:
    assert main(["run", str(tmp_path / "no-project"), "--out", str(tmp_path / "run")]) == 2
