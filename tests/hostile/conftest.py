"""Fixtures of the hostile suite: the tiny workspace and a fresh copy of it per case (``harness.py``)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from hostile.harness import Workspace
from project_factory import make_project


@pytest.fixture(scope="session")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("hostile-template")
    make_project(root / "proj")
    (root / "user.txt").write_text("a user's file\n")
    (root / "userdir").mkdir()
    (root / "userdir" / "notes.txt").write_text("a user's notes\n")
    (root / "report.ttl").write_text("@prefix ex: <https://example.org/> .\nex:a ex:b ex:c .\n")
    return root


@pytest.fixture
def workspace(template: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
              monkeypatch: pytest.MonkeyPatch) -> Workspace:
    root = tmp_path / "ws"
    shutil.copytree(template, root, symlinks=True)
    monkeypatch.setenv("KBPLANNER_CACHE_DIR", str(tmp_path / "cache"))
    return Workspace(root, capsys)
