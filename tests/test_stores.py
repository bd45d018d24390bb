"""Graph backends: memory, Oxigraph (embedded, in memory and on disk) and a real SPARQL endpoint (an
Oxigraph server started on 127.0.0.1) give the same named-query rows, requirements and plans."""

from __future__ import annotations

import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
from rdflib import Literal, URIRef
from rdflib.term import Identifier

from kbplanner.cli import main
from kbplanner.core.errors import KbplannerError
from kbplanner.core.named_queries import catalogue, run_text, to_term
from kbplanner.core.stores import (
    EndpointStore,
    StoreError,
    bind_values,
    describe,
    parse_store,
    result_json,
)
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project
from kbplanner.scale.building_generator import generate_building
from kbplanner.scale.building_plan import SCENARIO

SERVER_START_TIMEOUT_S = 15.0


def _oxigraph_binary() -> str | None:
    local = Path(sys.executable).parent / "oxigraph"
    return str(local) if local.is_file() else shutil.which("oxigraph")


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def endpoint(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A real Oxigraph SPARQL server on a free local port; stopped (bounded waits) after the module."""
    binary = _oxigraph_binary()
    if binary is None:
        pytest.skip("the oxigraph server binary is not installed (pip install -e '.[dev]')")
    port = _free_port()
    location = tmp_path_factory.mktemp("oxigraph-server")
    log = (location.parent / f"oxigraph-{port}.log").open("wb")
    proc = subprocess.Popen([binary, "serve", "--location", str(location), "--bind", f"127.0.0.1:{port}"],
                            stdout=log, stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}/query"
    deadline = time.monotonic() + SERVER_START_TIMEOUT_S
    try:
        while True:
            try:
                req = urllib.request.Request(url, data=b"ASK {}",
                                             headers={"Content-Type": "application/sparql-query"})
                with urllib.request.urlopen(req, timeout=1.0):
                    break
            except OSError:
                if proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"oxigraph server did not start on port {port}") from None
                time.sleep(0.05)
        yield f"sparql+{url}"
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)
        log.close()


@pytest.fixture(scope="module")
def building(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("stores") / "b1x2"
    generate_building(out, storeys=1, units_per_storey=2)
    return out


@pytest.fixture(scope="module")
def projects(building: Path, endpoint: str) -> dict[str, Project]:
    """The scenario model on each backend."""
    return {name: Project.load(building, scenario=SCENARIO, store=spec)
            for name, spec in (("memory", None), ("oxigraph", "oxigraph"), ("endpoint", endpoint))}


def _cases(project: Project, name: str) -> list[dict[str, Identifier]]:
    """No binding, then up to two values per parameter taken from the columns of the same name."""
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
        for v in sorted(values, key=str)[:2]:
            cases.append({p.name: to_term(v, p.type)})
    return cases


@pytest.mark.parametrize("name", sorted(catalogue()))
def test_every_named_query_gives_identical_rows_on_memory_oxigraph_and_the_endpoint(
        projects: dict[str, Project], name: str) -> None:
    q = catalogue()[name]
    cases = _cases(projects["memory"], name)
    assert {p.name for p in q.params} == {k for c in cases for k in c}  # each parameter bound at least once
    for bindings in cases:
        rows = {backend: result_json(run_text(p.graph, q.text, bindings)) for backend, p in projects.items()}
        assert rows["oxigraph"] == rows["memory"], (name, bindings)
        assert rows["endpoint"] == rows["memory"], (name, bindings)
    assert describe(projects["endpoint"].graph).startswith("sparql http://127.0.0.1:")
    assert describe(projects["oxigraph"].graph) == "oxigraph"


def test_a_bound_date_reaches_the_bind_of_element_state_at_on_the_endpoint(
        projects: dict[str, Project]) -> None:
    # rdflib's own SPARQLStore would append VALUES after the WHERE group, leaving every state unbound.
    at = projects["memory"].manifest.simulation["date"]
    for p in projects.values():
        rows = p.query("element_state_at", at=at).rows
        states = {str(r[3]).rsplit("#", 1)[-1] for r in rows}
        assert states == {"Built", "InProgress", "NotStarted"}, describe(p.graph)


def test_a_hostile_literal_is_bound_as_a_value_not_run_as_sparql(projects: dict[str, Project]) -> None:
    p = projects["endpoint"]
    before = len(p.model)
    hostile = 'Level 1" } } ; DROP ALL ; SELECT * WHERE { ?s ?p "x'
    assert p.query("spaces", storeyLabel=hostile).rows == []
    assert len(p.model) == before > 0
    with pytest.raises(KbplannerError, match="cannot be sent"):
        bind_values("SELECT ?s WHERE { ?s ?p ?o }", {"s": URIRef("http://ex.org/a> } ; DROP ALL ; #")})


def test_values_go_at_the_start_of_the_top_level_where_group_past_strings_iris_and_comments() -> None:
    text = ('# a comment with WHERE { in it\nPREFIX ex: <http://ex.org/ns#>\n'
            'SELECT ?s WHERE { ?s ex:p "WHERE {" . { SELECT ?s WHERE { ?s ?q ?o } } }')
    out = bind_values(text, {"s": Literal("a")})
    head = "SELECT ?s WHERE {"
    assert out.index('VALUES ( ?s ) { ( "a" ) }') == out.index(head) + len(head) + 1
    assert out.count("VALUES") == 1


def test_requirements_are_the_same_on_every_backend(building: Path, endpoint: str) -> None:
    found = {}
    for spec in (None, "oxigraph", endpoint):
        result = Project.load(building, store=spec).requirements()
        found[spec] = sorted((r.skill_id, r.input_name, tuple(sorted(e.global_id for e in r.elements)))
                             for r in result.requirements)
    assert found[None] and [len(r[2]) for r in found[None]] == [28, 28]
    assert found["oxigraph"] == found[None]
    assert found[endpoint] == found[None]


def test_the_scenario_conforms_and_plans_the_same_steps_on_every_backend(
        projects: dict[str, Project]) -> None:
    plans = {}
    for backend, p in projects.items():
        assert p.validate().conforms, backend
        plan = plan_task(p)
        plans[backend] = [(s.element, s.skill_id, sorted(s.inputs.items()), s.feasible) for s in plan.steps]
    assert len(plans["memory"]) == 4 * 28
    assert plans["oxigraph"] == plans["memory"]
    assert plans["endpoint"] == plans["memory"]


def test_oxigraph_on_disk_replaces_the_project_graphs_at_each_load(building: Path, tmp_path: Path) -> None:
    spec = f"oxigraph:{tmp_path / 'db'}"
    first = Project.load(building, store=spec)
    n = len(first.model)
    again = Project.load(building, store=spec)
    assert len(again.model) == n == len(Project.load(building).model)
    assert again.query("storeys").rows == Project.load(building).query("storeys").rows


def test_store_specs_parse_and_bad_ones_say_how_to_write_them() -> None:
    assert parse_store(None).is_memory and parse_store("memory").is_memory
    s = parse_store("sparql+http://host:3030/ds/query")
    assert (s.query_url, s.update_url) == ("http://host:3030/ds/query", "http://host:3030/ds/update")
    assert parse_store("sparql+http://host/sparql").update_url == "http://host/sparql"
    assert parse_store("oxigraph:/tmp/x").location == Path("/tmp/x")
    with pytest.raises(StoreError, match="unknown store") as err:
        parse_store("postgres://x")
    assert "sparql+http://HOST:PORT/query" in str(err.value)


def test_an_endpoint_that_is_down_is_an_error_with_a_fix_not_a_hang(building: Path) -> None:
    port = _free_port()
    # No port listens: the connection is refused at once (a hang would stall this test, not pass it).
    with pytest.raises(StoreError, match="cannot reach the SPARQL endpoint") as err:
        Project.load(building, store=f"sparql+http://127.0.0.1:{port}/query")
    assert "oxigraph serve" in str(err.value)
    with pytest.raises(StoreError):
        EndpointStore(f"http://127.0.0.1:{port}/query", f"http://127.0.0.1:{port}/update").has_graph("urn:x")


def test_cli_commands_take_store_and_print_the_same_table(building: Path, endpoint: str,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    outputs = []
    for extra in ([], ["--store", "oxigraph"], ["--store", endpoint]):
        argv = ["query", str(building), "doors_and_widths", "--bind", "storeyLabel=Level 1", *extra]
        assert main(argv) == 0
        outputs.append(capsys.readouterr().out)
    assert outputs[0] == outputs[1] == outputs[2] and "Unit door" in outputs[0]
    assert main(["validate", str(building), "--scenario", SCENARIO, "--store", endpoint]) == 0
    assert main(["info", str(building), "--store", "nonsense"]) == 2
    assert "unknown store" in capsys.readouterr().err


def test_upload_texts_are_constant_and_values_are_bound_rows() -> None:
    from kbplanner.core.stores import CLEAR_GRAPH, INSERT_TRIPLES, bind_rows, bind_values

    g, s, p = URIRef("urn:g"), URIRef("http://ex.org/a"), URIRef("http://ex.org/p")
    text = bind_rows(INSERT_TRIPLES, ("g", "s", "p", "o"), [(g, s, p, Literal('say "hi"'))])
    assert text.startswith("INSERT { GRAPH ?g { ?s ?p ?o } } WHERE {") and text.endswith("}")
    assert '( <urn:g> <http://ex.org/a> <http://ex.org/p> "say \\"hi\\"" )' in text
    assert bind_values(CLEAR_GRAPH, {"g": g}).startswith("DELETE { GRAPH ?g { ?s ?p ?o } } WHERE {")
