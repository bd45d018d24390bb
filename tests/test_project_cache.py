"""The project cache (issue 14): a second load reads it and gives the same graphs; any input change
(a Turtle file, a file reached through owl:imports) gives a new load; it can be switched off; two
commands at once leave one whole entry."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from rdflib import Graph, Literal, URIRef
from rdflib.compare import isomorphic

from kbplanner.cli import NO_CACHE_ENV as CLI_NO_CACHE_ENV
from kbplanner.cli import main
from kbplanner.core.cache_seal import sealed
from kbplanner.model import project_cache
from kbplanner.model.project_data import CACHE_ENV, ProjectData

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"
SCENARIO = "storage-outside"
WORKER = ("<https://w3id.org/kbplanner/data/duplex/worker/extra> "
          "a <https://w3id.org/kbplanner/ontology#Worker> .\n")


def _copy_case(tmp: Path) -> tuple[Path, Path]:
    """A copy of the case study and a cache folder holding the case study's IFC imports (if any)."""
    proj = tmp / "case"
    shutil.copytree(CASE, proj, ignore=shutil.ignore_patterns(".kbplanner-cache", "tools"))
    cache = tmp / "cache"
    cache.mkdir()
    src = CASE / ".kbplanner-cache"
    for d in (src.iterdir() if src.is_dir() else []):
        if (d / "model.ttl").is_file():
            shutil.copytree(d, cache / d.name)
    return proj, cache


def _load(proj: Path, scenario: str | None = SCENARIO,
          store: str | None = None) -> tuple[ProjectData, list[str]]:
    said: list[str] = []
    return ProjectData.load(proj, scenario=scenario, progress=said.append, store=store), said


def _entries(cache: Path) -> list[str]:
    folder = cache / project_cache.SUBDIR
    return sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []


@pytest.fixture
def case(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path]:
    proj, cache = _copy_case(tmp_path)
    monkeypatch.setenv(CACHE_ENV, str(cache))
    monkeypatch.delenv(project_cache.NO_CACHE_ENV, raising=False)
    return proj, cache


def test_a_second_load_reads_the_cache_and_gives_the_same_graphs_and_info(case: tuple[Path, Path]) -> None:
    proj, cache = case
    cold, said = _load(proj)
    assert "project from cache" not in said and len(_entries(cache)) == 1
    warm, said = _load(proj)
    assert "project from cache" in said
    assert set(warm.model) == set(cold.model)  # the model has no blank nodes
    assert isomorphic(warm.kb, cold.kb)       # the knowledge base has (SHACL lists)
    assert warm.info() == cold.info()
    assert sorted(warm.kb.namespaces()) == sorted(cold.kb.namespaces())
    assert warm.import_dir == cold.import_dir and warm.kb_files == cold.kb_files
    on_ox, said = _load(proj, store="oxigraph")  # read straight into Oxigraph
    assert "project from cache" in said and len(on_ox.graph) == len(cold.graph)
    assert on_ox.info() == cold.info()


def test_editing_a_turtle_file_changes_the_result(case: tuple[Path, Path]) -> None:
    proj, cache = case
    before, _ = _load(proj)
    with open(proj / "site" / "workers.ttl", "a", encoding="utf-8") as fh:
        fh.write(WORKER)
    after, said = _load(proj)
    assert "project from cache" not in said
    assert after.info().workers == before.info().workers + 1
    assert len(_entries(cache)) == 1  # the entry of the old inputs was removed
    _load(proj, scenario=None)
    assert len(_entries(cache)) == 2  # one entry per scenario


def test_a_change_of_a_file_read_through_owl_imports_is_seen(case: tuple[Path, Path]) -> None:
    proj, _ = case
    extra = proj / "site" / "extra.ttl"
    extra.write_text("", encoding="utf-8")
    with open(proj / "site" / "site_layout.ttl", "a", encoding="utf-8") as fh:
        fh.write(f"<urn:kbplanner-test:site> <http://www.w3.org/2002/07/owl#imports> <{extra.as_uri()}> .\n")
    before, _ = _load(proj, scenario=None)
    _, said = _load(proj, scenario=None)
    assert "project from cache" in said
    extra.write_text(WORKER, encoding="utf-8")
    after, said = _load(proj, scenario=None)
    assert "project from cache" not in said
    assert after.info().workers == before.info().workers + 1
    _, said = _load(proj, scenario=None)
    assert "project from cache" in said  # the stale entry was replaced


def test_no_cache_reads_and_writes_nothing(case: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    proj, cache = case
    assert CLI_NO_CACHE_ENV == project_cache.NO_CACHE_ENV
    monkeypatch.setenv(project_cache.NO_CACHE_ENV, "1")
    _, said = _load(proj)
    assert _entries(cache) == [] and "project from cache" not in said
    monkeypatch.delenv(project_cache.NO_CACHE_ENV)
    assert main(["--no-cache", "info", str(proj), "--format", "json"]) == 0
    assert _entries(cache) == [] and project_cache.NO_CACHE_ENV not in os.environ  # flag left no trace
    assert main(["info", str(proj), "--format", "json"]) == 0
    assert len(_entries(cache)) == 1
    out = capsys.readouterr().out
    first, second = out[: len(out) // 2], out[len(out) // 2:]
    assert first == second  # the same summary without and with the cache


def test_two_commands_at_once_leave_one_whole_entry_and_no_temporary_folder(case: tuple[Path, Path]) -> None:
    proj, cache = case
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    cmd = [sys.executable, "-m", "kbplanner", "info", str(proj), "--scenario", SCENARIO]
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
             for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    assert outs[0][0] == outs[1][0] and outs[0][1] == outs[1][1] == ""
    entries = _entries(cache)
    assert len(entries) == 1 and not entries[0].startswith(".")
    assert {p.name for p in (cache / project_cache.SUBDIR / entries[0]).iterdir()} == {
        project_cache.MODEL_NT, project_cache.KB_NT, project_cache.META}  # info runs on Oxigraph: no pickle
    third = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True, timeout=300)
    assert third.stdout == outs[0][0]


def test_a_damaged_entry_is_not_used_and_is_replaced(case: tuple[Path, Path]) -> None:
    proj, cache = case
    cold, _ = _load(proj)
    entry = cache / project_cache.SUBDIR / _entries(cache)[0]
    assert not (entry / project_cache.GRAPHS).exists()  # written by the first read with rdflib
    _, said = _load(proj)
    assert "project from cache" in said and (entry / project_cache.GRAPHS).is_file()
    cut = (entry / project_cache.GRAPHS).read_bytes()[:-100]  # a pickle cut short
    for store, name, damaged in ((None, project_cache.GRAPHS, b"\x80\x05garbage"),  # unpickled
                                 (None, project_cache.GRAPHS, cut),
                                 ("oxigraph", project_cache.MODEL_NT, b"<a> <b> .\n")):  # not N-Triples
        (entry / name).write_bytes(damaged)
        again, said = _load(proj, store=store)
        assert "project from cache" not in said and again.info() == cold.info()
        _, said = _load(proj)  # the entry written again, read again (by rdflib: its pickle kept)
        assert "project from cache" in said and (entry / name).stat().st_size > 1000
    (entry / project_cache.META).unlink()
    again, said = _load(proj)
    assert "project from cache" not in said and again.info() == cold.info()
    _, said = _load(proj)
    assert "project from cache" in said  # a whole entry again


def test_world_tables_read_from_the_cache_equal_those_read_from_the_graph_until_it_changes(
        case: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch) -> None:
    from dataclasses import replace

    from kbplanner.world.tables import TABLE_QUERIES, world_tables

    proj, _ = case
    _load(proj)  # writes the entry
    first, _ = _load(proj)
    assert first.cache_entry is not None
    tables = replace(world_tables(first), model_id=0)  # read by SPARQL, rows kept
    kept = sorted(p.name for p in (first.cache_entry / project_cache.ROWS).iterdir())
    assert kept == sorted(f"{name}.memory.json" for name, _ in TABLE_QUERIES)
    second, _ = _load(proj)
    assert replace(world_tables(second), model_id=0) == tables  # from the kept rows
    monkeypatch.setenv(project_cache.NO_CACHE_ENV, "1")
    assert replace(world_tables(second), model_id=0) == tables  # by SPARQL again
    monkeypatch.delenv(project_cache.NO_CACHE_ENV)
    tasks = second.pristine_rows([("world_tasks", False)])["world_tasks"].rows
    second.model.remove((URIRef(tasks[0][0]), None, None))  # an API user edits the loaded graph
    assert len(second.pristine_rows([("world_tasks", False)])["world_tasks"].rows) == len(tasks) - 1


def _literals(g: Graph) -> list[tuple[str, ...]]:
    return sorted((repr(o), repr(o.value), str(o.ill_typed), str(o.language), str(o.datatype))
                  for o in g.objects() if isinstance(o, Literal))


def test_the_pickled_graphs_are_those_the_n_triples_give_and_answer_the_same_rows(
        case: tuple[Path, Path]) -> None:
    from kbplanner.core.named_queries import catalogue, run_named

    proj, _ = case
    cold, _ = _load(proj)
    first, said = _load(proj)  # parses the N-Triples, keeps the pickle
    assert "project from cache" in said and first.cache_entry is not None
    assert (first.cache_entry / project_cache.GRAPHS).is_file()
    warm, said = _load(proj)  # unpickles
    assert "project from cache" in said and warm.cache_entry is not None
    assert set(warm.model) == set(first.model) and warm._kept_stamp == first._kept_stamp
    meta = json.loads((warm.cache_entry / project_cache.META).read_text(encoding="utf-8"))
    for kept, name, ns in ((warm.model, project_cache.MODEL_NT, "model_namespaces"),
                           (warm.kb, project_cache.KB_NT, "kb_namespaces")):
        parsed = project_cache._graph(warm.cache_entry / name, meta[ns])
        assert set(kept) == set(parsed) and len(kept) == len(parsed)
        for s in parsed.subjects(unique=True):  # the same order of a subject's triples
            assert list(kept.predicate_objects(s)) == list(parsed.predicate_objects(s))
        assert _literals(kept) == _literals(parsed)  # values, datatypes, languages as parsed
        assert sorted(kept.namespaces()) == sorted(parsed.namespaces())
    merged = project_cache.merged_graph(warm.model, warm.kb)
    assert set(warm.graph) == set(merged) and sorted(warm.graph.namespaces()) == sorted(merged.namespaces())
    assert isomorphic(warm.graph, cold.graph)
    for name in catalogue():  # every named query, no value bound: the same rows
        got, want = run_named(warm.graph, name), run_named(cold.graph, name)
        assert got.columns == want.columns, name
        assert sorted(map(repr, got.rows)) == sorted(map(repr, want.rows)), name


def test_the_kept_merged_graph_is_merged_again_after_an_edit(case: tuple[Path, Path]) -> None:
    proj, _ = case
    _load(proj)
    warm, _ = _load(proj)
    extra = (URIRef("urn:x:a"), URIRef("urn:x:b"), Literal("c"))
    warm.model.add(extra)
    assert extra in warm.graph and set(warm.graph) == set(warm.model) | set(warm.kb)


def test_the_kept_stamp_stands_for_the_unpickled_graphs_until_one_is_edited(case: tuple[Path, Path]) -> None:
    proj, _ = case
    _load(proj)
    _load(proj)
    warm, _ = _load(proj)
    assert warm.cache_entry is not None and (warm.cache_entry / project_cache.GRAPHS).is_file()
    assert warm._kept_stamp == project_cache.graphs_stamp(warm.model, warm.kb)  # the graphs as unpickled
    assert project_cache.unedited(warm.model, warm.kb)
    warm.kb.remove((None, None, Literal("no such value")))  # a removal that removes nothing is an edit too
    assert not project_cache.unedited(warm.model, warm.kb) and project_cache.unedited(warm.model)
    cold = ProjectData.load(proj, scenario=SCENARIO, store=None)
    assert project_cache.unedited(cold.model)  # read from the entry again


class _Touch:
    """A pickle that, unpickled, creates a file (what a foreign pickle could do)."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self) -> tuple[object, ...]:
        return (Path.touch, (self.path,))


def test_a_graphs_pickle_without_this_users_seal_is_never_unpickled(case: tuple[Path, Path],
                                                                      tmp_path: Path) -> None:
    import pickle

    proj, cache = case
    cold, _ = _load(proj)
    _load(proj)  # keeps the pickle
    entry = cache / project_cache.SUBDIR / _entries(cache)[0]
    witness = tmp_path / "unpickled"
    (entry / project_cache.GRAPHS).write_bytes(pickle.dumps(_Touch(witness)))  # a project from elsewhere
    again, said = _load(proj)
    assert not witness.exists() and "project from cache" not in said and again.info() == cold.info()
    for _ in range(2):  # read (the pickle kept again, sealed), then unpickled
        _, said = _load(proj)
        assert "project from cache" in said and not witness.exists()
    mark, _, data = (entry / project_cache.GRAPHS).read_bytes().partition(b"\n")
    assert sealed(data, mark.decode())


def test_a_cold_load_keeps_its_graphs_for_the_next_process_which_answers_the_same_rows(
        case: tuple[Path, Path]) -> None:
    """``kbplanner run --tasks all`` writes the cold load's graphs into the entry before its spawned
    processes load the scenario (ProjectData.keep_graphs): they unpickle them, with the same triples,
    literals and rows as the graphs parsed from the entry's N-Triples."""
    from kbplanner.core.graph_memo import memo
    from kbplanner.core.named_queries import catalogue, run_named

    proj, _ = case
    cold, said = _load(proj)
    assert "project from cache" not in said and cold.cache_entry is not None
    assert project_cache.unedited(cold.model, cold.kb) and memo(cold.model) is not None
    assert not (cold.cache_entry / project_cache.GRAPHS).is_file()
    cold.keep_graphs()
    assert (cold.cache_entry / project_cache.GRAPHS).is_file()
    assert cold._kept_stamp == project_cache.graphs_stamp(cold.model, cold.kb)
    warm, said = _load(proj)  # unpickles what the cold load kept
    assert "project from cache" in said and warm._kept_stamp == cold._kept_stamp
    assert set(warm.model) == set(cold.model) and _literals(warm.model) == _literals(cold.model)
    assert isomorphic(warm.kb, cold.kb) and isomorphic(warm.graph, cold.graph)
    for name in catalogue():  # every named query, no value bound: the same rows
        got, want = run_named(warm.graph, name), run_named(cold.graph, name)
        assert sorted(map(repr, got.rows)) == sorted(map(repr, want.rows)), name
    cold.keep_graphs()  # kept already: nothing written again
    cold.model.add((URIRef("urn:x:a"), URIRef("urn:x:b"), Literal("c")))
    assert memo(cold.model) is None  # edited: queried again
