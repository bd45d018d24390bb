"""A scenario's validation in a task process (scale/task_jobs.validate_job, the pipeline's A4-A5 with
several workers): the same report files as the command's own validation, and the same verdict."""

from __future__ import annotations

from pathlib import Path

import pytest

from kbplanner.core.outputs import atomic_write_text
from kbplanner.project import Project
from kbplanner.scale.building_generator import generate_building
from kbplanner.scale.task_jobs import validate_job


@pytest.mark.parametrize("conforming", [True, False])
def test_a_task_process_s_validation_writes_what_the_command_writes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, conforming: bool) -> None:
    monkeypatch.setenv("KBPLANNER_CACHE_DIR", str(tmp_path / "cache"))
    project_dir = tmp_path / "b1x1"
    generate_building(project_dir, storeys=1, units_per_storey=1)
    scenario = "storage-in-units"
    if not conforming:  # no grasp points: does not conform
        scenario = "no-grasp-points"
        with (project_dir / "project.toml").open("a", encoding="utf-8") as fh:
            fh.write(f'\n[scenarios.{scenario}]\ndescription = "the storages, without grasp points"\n'
                     'overlays = ["scenarios/storage_in_units.ttl"]\n')
    val = Project.load(project_dir, scenario=scenario).validate()
    here, there = tmp_path / "command", tmp_path / "task-process"
    val.write(here / "validation.ttl")
    atomic_write_text(here / "validation.txt", val.text())
    verdict = validate_job(project_dir, scenario, there)
    assert (verdict.conforms, verdict.violations) == (val.conforms, len(val.violations))
    assert verdict.conforms is conforming
    for name in ("validation.ttl", "validation.txt"):
        assert (there / name).read_bytes() == (here / name).read_bytes()
