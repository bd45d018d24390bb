"""The notebooks run from top to bottom (on a short run), so they cannot rot."""

from __future__ import annotations

import os
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.slow  # about 40 s: `make test-slow` (.ci/run runs it after `make test`)
@pytest.mark.parametrize("name", ["case_study.ipynb"])
def test_notebook_runs_without_errors(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("KBPLANNER_NOTEBOOK_FRAMES", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(REPO / "notebooks" / name, as_version=4)
    client = NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(REPO / "notebooks")}}
    )
    client.execute(env=dict(os.environ))
    outputs = "".join(
        o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
    )
    assert "conforms: True" in outputs
    assert "min separation" in outputs
    assert "storage-inside" in outputs
