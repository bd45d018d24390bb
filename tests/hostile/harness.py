"""Harness of the hostile suite: every case runs one command in a fresh copy of a tiny workspace.

The workspace (built once per session, ``conftest.py``) holds a small project (``project_factory``), a
file and a folder of the user's. Each case gets its own copy, so the cases are independent and cheap (no
case study, no simulation), and :meth:`Workspace.run` checks the rules that every case shares: one error
message and no traceback, no ``.partial`` left behind, and not one byte of the workspace changed outside
the fresh output folder ``new_out``.
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path

import pytest

from kbplanner.cli import main

FRESH = "new_out"  # the only path a case may write to


def tree_digest(root: Path) -> dict[str, str]:
    """SHA-256 of every file (and the target of every link) under ``root``, except caches and FRESH."""
    out: dict[str, str] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        rel = Path(dirpath).relative_to(root)
        dirnames[:] = [d for d in dirnames if d != ".kbplanner-cache" and (rel / d).as_posix() != FRESH]
        out[(rel / ".").as_posix() + "/"] = "dir"
        for f in filenames:
            p = Path(dirpath) / f
            key = (rel / f).as_posix()
            out[key] = (("link:" + os.readlink(p)) if p.is_symlink()
                        else hashlib.sha256(p.read_bytes()).hexdigest())
    return out


class Workspace:
    """A fresh copy of the template; ``run`` runs the command line in it and checks the shared rules."""

    def __init__(self, root: Path, capsys: pytest.CaptureFixture[str]) -> None:
        self.root = root
        self.capsys = capsys

    def run(self, argv: list[str], *, cwd: str = ".") -> tuple[int, str]:
        before = tree_digest(self.root)
        self.capsys.readouterr()
        old = Path.cwd()
        os.chdir(self.root / cwd)
        try:
            code = main(argv)
        finally:
            os.chdir(old)
        err = self.capsys.readouterr().err
        assert "Traceback" not in err
        assert tree_digest(self.root) == before, "a file outside the fresh output folder changed"
        assert not list(self.root.rglob("*.partial")), "a .partial folder was left behind"
        return code, err


PROGRESS_LINE = re.compile(r"^\[\s*[0-9.]+ s\] ")  # plain progress where stderr is no terminal


def one_message(err: str) -> str:
    """The error line of ``err`` (exactly one ``error:`` line, optionally followed by its fix)."""
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith(("WARNING ", "INFO "))
             and not PROGRESS_LINE.match(ln)]
    errors = [ln for ln in lines if ": error: " in ln]
    assert len(errors) == 1, err
    extra = [ln for ln in lines if ln not in errors and not ln.startswith("  fix:")]
    assert not extra, err
    return errors[0]
