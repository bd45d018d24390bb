"""Prepared SPARQL queries kept across processes (issue 14): a query read back from the cache is the
query rdflib prepares (same algebra, prologue and arguments) and gives the same rows; a damaged file is
parsed again and replaced; ``KBPLANNER_NO_CACHE`` keeps nothing."""

from __future__ import annotations

import pickle
from collections import OrderedDict
from pathlib import Path
from typing import Any

import pytest
from rdflib import Graph
from rdflib.plugins.sparql import prepareQuery
from rdflib.plugins.sparql.parserutils import CompValue
from rdflib.plugins.sparql.sparql import Query

from kbplanner.core import sparql_cache
from kbplanner.core.cache_seal import sealed
from kbplanner.core.named_queries import catalogue, result_rows
from kbplanner.knowledge.knowledge_base import load_kb

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv(sparql_cache.CACHE_DIR_ENV, str(tmp_path))
    monkeypatch.delenv(sparql_cache.NO_CACHE_ENV, raising=False)
    return tmp_path / sparql_cache.SUBDIR


def _canonical(node: Any) -> Any:
    """A comparable form of an algebra tree (sets as frozensets: their order is the process's)."""
    if isinstance(node, CompValue):
        attrs = {k: v for k, v in node.__dict__.items() if k != "_evalfn"}
        fn = node.__dict__.get("_evalfn")
        return (type(node).__name__, node.name, getattr(fn, "__func__", fn),
                tuple((k, _canonical(v)) for k, v in sorted(attrs.items())),
                tuple((k, _canonical(OrderedDict.__getitem__(node, k))) for k in OrderedDict.keys(node)))
    if isinstance(node, set | frozenset):
        return frozenset(_canonical(v) for v in node)
    if isinstance(node, list | tuple):
        return tuple(_canonical(v) for v in node)
    if isinstance(node, dict):
        return tuple((k, _canonical(v)) for k, v in node.items())
    return node


def _read_back(text: str) -> Query:
    """The query as a later process gets it: written by one call, read from the file by the next."""
    sparql_cache.prepare_text(text)
    path = sparql_cache.cache_dir() / f"{sparql_cache.query_key(text)}.pickle"
    assert path.is_file()
    mark, _, data = path.read_bytes().partition(b"\n")
    assert sealed(data, mark.decode())
    got = pickle.loads(data)
    assert isinstance(got, Query)
    return got


def test_every_named_query_read_back_is_the_query_rdflib_prepares(cache: Path) -> None:
    for name, q in catalogue().items():
        fresh, kept = prepareQuery(q.text), _read_back(q.text)
        assert _canonical(kept.algebra) == _canonical(fresh.algebra), name
        assert kept._original_args == fresh._original_args, name
        assert sorted(kept.prologue.namespace_manager.namespaces()) == \
            sorted(fresh.prologue.namespace_manager.namespaces()), name
        assert sparql_cache.prepare_text(q.text) is not None
    assert len(list(cache.glob("*.pickle"))) == len({q.text for q in catalogue().values()})


def test_a_query_read_back_gives_the_rows_of_the_query_rdflib_prepares(cache: Path) -> None:
    from kbplanner.model.project_data import ProjectData

    graph: Graph = ProjectData.load(CASE, scenario="storage-outside").graph
    nonempty = 0
    for name, q in catalogue().items():
        fresh = result_rows(graph.query(prepareQuery(q.text)))
        kept = result_rows(graph.query(_read_back(q.text)))
        assert kept.columns == fresh.columns, name
        assert sorted(map(repr, kept.rows)) == sorted(map(repr, fresh.rows)), name
        nonempty += bool(fresh.rows)
    assert nonempty > len(catalogue()) // 2  # the comparison saw rows


def test_the_knowledge_base_queries_with_filters_and_optionals_give_the_same_rows(cache: Path) -> None:
    kb = load_kb()
    for name in ("action_bindings", "skills", "task_specifications", "robots", "skill_parameters"):
        text = catalogue()[name].text
        fresh = result_rows(kb.query(prepareQuery(text)))
        kept = result_rows(kb.query(_read_back(text)))
        assert fresh.rows and sorted(map(repr, kept.rows)) == sorted(map(repr, fresh.rows)), name


def test_a_damaged_file_is_parsed_again_and_replaced(cache: Path) -> None:
    text = catalogue()["storeys"].text
    _read_back(text)
    path = cache / f"{sparql_cache.query_key(text)}.pickle"
    path.write_bytes(b"not a pickle")
    got = sparql_cache.prepare_text(text)
    assert _canonical(got.algebra) == _canonical(prepareQuery(text).algebra)
    mark, _, data = path.read_bytes().partition(b"\n")
    assert sealed(data, mark.decode()) and isinstance(pickle.loads(data), Query)


class _Touch:
    """A pickle that, unpickled, creates a file (what a foreign pickle could do)."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self) -> tuple[Any, ...]:
        return (Path.touch, (self.path,))


def test_a_pickle_without_this_users_seal_is_never_unpickled(cache: Path, tmp_path: Path) -> None:
    text = catalogue()["storeys"].text
    _read_back(text)
    path = cache / f"{sparql_cache.query_key(text)}.pickle"
    witness = tmp_path / "unpickled"
    foreign = pickle.dumps(_Touch(witness))
    for mark in (b"0" * 64, b"", sealed.__name__.encode()):  # a wrong seal, none, a word
        path.write_bytes(mark + b"\n" + foreign)
        got = sparql_cache.prepare_text(text)
        assert not witness.exists() and isinstance(got, Query)
    mark, _, data = path.read_bytes().partition(b"\n")
    assert sealed(data, mark.decode())  # replaced by a sealed one


def test_the_key_follows_the_text_and_namespaces() -> None:
    text = catalogue()["storeys"].text
    assert sparql_cache.query_key(text) != sparql_cache.query_key(text + " ")
    assert sparql_cache.query_key(text) != sparql_cache.query_key(text, {"ex": "urn:x:"})
    assert sparql_cache.query_key(text) == sparql_cache.query_key(text, {})


def test_no_cache_keeps_nothing(cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(sparql_cache.NO_CACHE_ENV, "1")
    sparql_cache.prepare_text(catalogue()["storeys"].text)
    assert not cache.exists()
