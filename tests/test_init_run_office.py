"""Issue 10's check end to end on an office the project never saw: import-ifc, init, then run.

The office (tests/ifc_office.py) is written as ArchiCAD writes IFC2X3 (millimetres, unnamed property and
quantity sets); nothing is written by hand between the commands. Every frame is installed, or each one
that is not has its reason, and the exit codes say which (0 all installed, 1 a reported negative result).
Slow: it simulates.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ifc_office import write_office
from kbplanner.cli import main


@pytest.mark.slow
def test_office_ifc2x3_import_init_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    office = write_office(tmp_path / "office.ifc", schema="IFC2X3", rooms_per_side=2, storeys=1)
    assert (office.walls, office.doors, office.windows) == (8, 5, 4)

    assert main(["import-ifc", str(office.path), "--out", str(tmp_path / "imported")]) == 0
    skipped = json.loads((tmp_path / "imported" / "skipped.json").read_text(encoding="utf-8"))
    assert skipped["skipped"] == []  # no door, window or wall dropped for its unnamed sets

    project = tmp_path / "project"
    code = main(["init", str(office.path), "--task", "frame-interior-walls", "--max-walls", "1",
                 "--out", str(project)])
    out = capsys.readouterr().out
    assert "walls chosen: 1 of 8" in out and "storage-inside" in out
    assert code == (1 if "Negative result" in out else 0)  # frames the plan cannot install: reported

    code = main(["run", str(project), "--out", str(tmp_path / "run"), "--scenario", "storage-inside"])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err + captured.out
    metrics = json.loads((tmp_path / "run" / "scenarios" / "storage-inside" / "simulation" / "metrics.json")
                         .read_text(encoding="utf-8"))
    elements = metrics["per_element"]
    assert len(elements) == metrics["totals"]["elements"] >= 5
    not_installed = [e for e in elements if e["outcome"] != "installed"]
    assert all(e["reason"] for e in not_installed)  # each one it cannot install, with its reason
    assert code == (1 if not_installed else 0)
    assert metrics["totals"]["installed"] == len(elements) - len(not_installed)
