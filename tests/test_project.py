"""Loading a project directory: the manifest, the import cache, overlays, and the summary."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import pytest

from kbplanner.core.errors import ProjectError
from kbplanner.project import Project, read_manifest
from project_factory import make_project


@pytest.fixture(scope="module")
def project_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("proj")
    make_project(d)
    return d


def test_a_project_loads_its_ifc_schedule_and_site_layout(project_dir: Path) -> None:
    p = Project.load(project_dir)
    info = p.info()
    assert info.counts["Wall"] == 10
    assert (info.walls_interior, info.walls_exterior) == (2, 8)
    assert info.counts["Door"] == 3
    assert [(s[0], s[1]) for s in info.storeys] == [("Level 1", 0.0), ("Level 2", 3.0)]
    assert info.tasks == 4
    assert info.date_range[0].startswith("2022-03-01")
    assert info.date_range[1].startswith("2022-05-25")
    assert info.site_objects == {"SiteOffice": 1}


def test_a_second_load_reuses_the_cached_import(project_dir: Path) -> None:
    first = Project.load(project_dir)
    stamp = (first.import_dir / "model.ttl").stat().st_mtime_ns
    second = Project.load(project_dir)
    assert second.import_dir == first.import_dir
    assert (second.import_dir / "model.ttl").stat().st_mtime_ns == stamp
    assert len(second.model) == len(first.model)


def test_element_states_follow_the_schedule(project_dir: Path) -> None:
    p = Project.load(project_dir)
    states = p.element_states(datetime(2022, 5, 12))
    by_state: dict[str, int] = {}
    for s in states.values():
        by_state[s] = by_state.get(s, 0) + 1
    assert by_state["in progress"] == 2  # the two partitions
    assert by_state["not started"] == 3  # the doors


def test_named_query_bindings_filter_rows(project_dir: Path) -> None:
    p = Project.load(project_dir)
    all_doors = p.query("doors_and_widths")
    storeys = {r[3] for r in all_doors.rows}
    one = sorted(storeys)[0]
    filtered = p.query("doors_and_widths", storeyLabel=one)
    assert 0 < len(filtered) < len(all_doors)
    assert {r[3] for r in filtered.rows} == {one}


def test_unknown_scenario_names_the_known_ones(project_dir: Path) -> None:
    with pytest.raises(ProjectError) as err:
        Project.load(project_dir, scenario="nope")
    assert "project.toml" in str(err.value) and "nope" in str(err.value)


@pytest.mark.parametrize(
    ("toml", "needle"),
    [
        ("[project]\nname = 'x'\n[model]\n", "has no 'ifc'"),
        ("[project\nname = 'x'\n", "not valid TOML"),
        ("[model]\nifc = 'missing.ifc'\n", "does not exist: missing.ifc"),
        ("[model]\nifc = 'model.ifc'\nsite = 3\n", "must be a path or a list"),
    ],
)
def test_a_bad_manifest_is_one_clear_error_naming_project_toml(tmp_path: Path, toml: str,
                                                               needle: str) -> None:
    (tmp_path / "model.ifc").write_text("ISO-10303-21;")
    (tmp_path / "project.toml").write_text(toml)
    with pytest.raises(ProjectError) as err:
        read_manifest(tmp_path)
    assert needle in str(err.value)
    assert "project.toml" in str(err.value)
    assert "fix:" in str(err.value)


def test_a_directory_without_manifest_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(ProjectError, match=r"no project\.toml"):
        read_manifest(tmp_path)
