"""The load memo (issue 14, the 10 x 8 building's serial stages): a second load in the same process takes
the import graph and the schedule graph the first one made instead of parsing ``model.ttl`` and resolving
the schedule again, and gets exactly the graphs and facts it got before."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from kbplanner.core.rdf_io import parse_turtle, recording_reads
from kbplanner.model import load_memo, project_cache
from kbplanner.model.project_data import CACHE_ENV, ProjectData, import_cached

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"
SCENARIO = "storage-outside"


@pytest.fixture
def case(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path]:
    proj = tmp_path / "case"
    shutil.copytree(CASE, proj, ignore=shutil.ignore_patterns(".kbplanner-cache", "tools"))
    cache = tmp_path / "cache"
    cache.mkdir()
    monkeypatch.setenv(CACHE_ENV, str(cache))
    monkeypatch.delenv(project_cache.NO_CACHE_ENV, raising=False)
    load_memo.keep_import(tmp_path / "none.ttl", parse_turtle(CASE / "site" / "jobsite.ttl"))  # empty memo
    return proj, cache


def _forget(cache: Path) -> None:
    """No memo and no loaded-project entries: the next load reads ``model.ttl`` and the schedule."""
    load_memo.keep_import(cache / "none.ttl", parse_turtle(CASE / "site" / "jobsite.ttl"))
    shutil.rmtree(cache / project_cache.SUBDIR, ignore_errors=True)


def test_a_bare_load_after_a_scenario_load_gives_what_a_load_from_the_files_gives(
        case: tuple[Path, Path]) -> None:
    proj, cache = case
    ProjectData.load(proj, scenario=SCENARIO)  # imports the IFC (or reads model.ttl) and keeps the graphs
    said: list[str] = []
    memo = ProjectData.load(proj, progress=said.append)
    assert "reading schedule" in said  # a load of its own, not a cache entry
    _forget(cache)
    files = ProjectData.load(proj)
    assert set(memo.model) == set(files.model)
    assert memo.info() == files.info()
    assert sorted(memo.model.namespaces()) == sorted(files.model.namespaces())


def test_the_kept_import_is_the_parsed_model_ttl_and_is_noted_as_read(case: tuple[Path, Path]) -> None:
    proj, _cache = case
    ProjectData.load(proj, scenario=SCENARIO)
    manifest = ProjectData.load(proj).manifest
    with recording_reads() as reads:
        graph, out = import_cached(manifest)
    ttl = out / "model.ttl"
    assert load_memo.kept_import(ttl) is graph
    assert reads == [ttl]  # as parsing it records, so the project cache keys its entries the same
    assert set(graph) == set(parse_turtle(ttl))


def test_a_rewritten_model_ttl_or_schedule_is_read_again(case: tuple[Path, Path]) -> None:
    proj, _cache = case
    loaded = ProjectData.load(proj, scenario=SCENARIO)
    graph, out = import_cached(loaded.manifest)
    schedule = loaded.manifest.schedule
    assert schedule is not None
    assert load_memo.kept_schedule(graph, schedule, loaded.manifest.base) is not None
    assert load_memo.kept_schedule(graph, schedule, loaded.manifest.base + "x") is None
    schedule.write_bytes(schedule.read_bytes() + b"\n")
    assert load_memo.kept_schedule(graph, schedule, loaded.manifest.base) is None
    ttl = out / "model.ttl"
    st = ttl.stat()
    os.utime(ttl, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
    assert load_memo.kept_import(ttl) is None
    again, _ = import_cached(loaded.manifest)
    assert again is not graph and set(again) == set(graph)
