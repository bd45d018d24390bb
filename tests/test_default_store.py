"""Oxigraph, the default store of ``info`` and ``query`` (issue 14), gives what rdflib gives on the case
study: every named query (unbound, and bound to values of the model) prints the same table, CSV and
JSON on both stores, and ``info`` prints the same summary."""

from __future__ import annotations

from pathlib import Path

import pytest
from rdflib.term import Identifier

from kbplanner.cli import main
from kbplanner.core.named_queries import catalogue, run_named, run_text, to_term
from kbplanner.core.stores import describe
from kbplanner.core.tables import FORMATS, iri_shortener, render
from kbplanner.model.project_data import ProjectData

CASE = Path(__file__).resolve().parents[1] / "data" / "case_study"
SCENARIO = "storage-outside"


@pytest.fixture(scope="module")
def stores() -> dict[str, ProjectData]:
    return {store: ProjectData.load(CASE, scenario=SCENARIO, store=store) for store in ("memory", "oxigraph")}


def _cases(project: ProjectData, name: str) -> list[dict[str, Identifier]]:
    """No binding, then up to two values per parameter, taken from the columns of that name."""
    q = catalogue()[name]
    cases: list[dict[str, Identifier]] = [{}]
    for p in q.params:
        if p.type.lower() == "xsd:datetime":
            cases.append({p.name: to_term(project.manifest.simulation["date"], p.type)})
            continue
        values: set[Identifier] = set()
        for other in catalogue().values():
            if p.name in other.columns:
                result = run_text(project.graph, other.text, {})
                col = [str(v) for v in (result.vars or [])].index(p.name)
                values.update(row[col] for row in result if row[col] is not None)  # type: ignore[index]
        cases += [{p.name: to_term(v, p.type)} for v in sorted(values, key=str)[:2]]
    return cases


@pytest.mark.parametrize("name", sorted(catalogue()))
def test_every_named_query_prints_the_same_rows_on_oxigraph_and_rdflib(stores: dict[str, ProjectData],
                                                                       name: str) -> None:
    assert describe(stores["oxigraph"].graph) == "oxigraph" and describe(stores["memory"].graph) == "memory"
    shorten = iri_shortener(stores["memory"].base)
    for bindings in _cases(stores["memory"], name):
        printed = {}
        for store, project in stores.items():
            result = run_named(project.graph, name, **bindings)
            printed[store] = [render(result.columns, result.rows, fmt, shorten=shorten) for fmt in FORMATS]
        assert printed["oxigraph"] == printed["memory"], (name, bindings)


def test_info_prints_the_same_summary_on_both_stores(capsys: pytest.CaptureFixture[str]) -> None:
    outputs = []
    for store in ("memory", None):  # None: the default, Oxigraph
        args = ["info", str(CASE), "--scenario", SCENARIO] + (["--store", store] if store else [])
        assert main(args) == 0
        outputs.append(capsys.readouterr().out)
    assert outputs[0] == outputs[1] and "Wall" in outputs[0]
