"""Named queries: every .rq file is documented and parses; values are bound, never pasted."""

from __future__ import annotations

import pytest
from rdflib import RDF, RDFS, Graph, Literal, URIRef
from rdflib.plugins.sparql import prepareQuery

from kbplanner.core.errors import QueryError
from kbplanner.core.named_queries import catalogue, get_query, run_named
from kbplanner.core.vocab import BOT, KBP


def test_every_named_query_has_a_description_columns_and_parses() -> None:
    cat = catalogue()
    assert {"storeys", "elements_by_class_and_storey", "tasks_and_elements", "doors_and_widths",
            "element_state_at"} <= set(cat)
    for name, q in cat.items():
        assert q.description, name
        assert q.columns, name
        prepareQuery(q.text)


def test_every_declared_parameter_appears_as_a_variable_of_its_query() -> None:
    for name, q in catalogue().items():
        for p in q.params:
            assert f"?{p.name}" in q.text, f"{name}: ?{p.name}"


def _graph() -> Graph:
    g = Graph()
    storey = URIRef("urn:x:storey")
    g.add((storey, RDF.type, BOT.Storey))
    g.add((storey, RDFS.label, Literal("Level 1")))
    for i, label in enumerate(['Door "A"', "Door } UNION { ?s ?p ?o"]):
        d = URIRef(f"urn:x:door{i}")
        g.add((d, RDF.type, KBP.Door))
        g.add((d, KBP.globalId, Literal(f"gid{i}")))
        g.add((d, KBP.ifcClass, Literal("IfcDoor")))
        g.add((d, RDFS.label, Literal(label)))
        g.add((d, KBP.overallWidth, Literal(0.8 + i / 10)))
        g.add((storey, BOT.containsElement, d))
    return g


def test_a_value_that_looks_like_sparql_is_bound_as_a_literal_and_matches_only_itself() -> None:
    g = _graph()
    rows = run_named(g, "elements_by_class_and_storey", ifcClass="IfcDoor", storeyLabel="Level 1").rows
    assert len(rows) == 2
    hostile = run_named(g, "elements_by_class_and_storey", ifcClass="IfcDoor\" } UNION { ?s ?p ?o")
    assert hostile.rows == []
    assert "UNION" not in get_query("elements_by_class_and_storey").text


def test_unknown_query_and_unknown_parameter_are_clear_errors() -> None:
    with pytest.raises(QueryError, match="no named query"):
        run_named(Graph(), "nope")
    with pytest.raises(QueryError, match="has no parameter 'colour'"):
        run_named(Graph(), "storeys", colour="red")
    with pytest.raises(QueryError, match="not a valid xsd:dateTime"):
        run_named(Graph(), "element_state_at", at="yesterday")


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_a_double_binding_must_be_finite(value: str) -> None:
    from kbplanner.core.errors import QueryError
    from kbplanner.core.named_queries import to_term

    with pytest.raises(QueryError, match="not a valid xsd:double"):
        to_term(value, "xsd:double", param="x", query="q")


@pytest.mark.parametrize("value", ["https://a/b>c", "https://a/b c", "no-scheme", "https://a/{x}", ""])
def test_an_iri_binding_must_be_an_absolute_iri_that_sparql_allows(value: str) -> None:
    from kbplanner.core.errors import QueryError
    from kbplanner.core.named_queries import iri_term, to_term

    with pytest.raises(QueryError, match="not an absolute IRI"):
        to_term(value, "iri", param="box", query="plan_box")
    assert str(iri_term("urn:kbp:a#b")) == "urn:kbp:a#b"


def test_every_named_query_is_prepared_once_and_gives_the_rows_of_its_text() -> None:
    from kbplanner.core.named_queries import prepare_all, prepared, result_rows, run_text

    assert prepare_all() == len(catalogue())  # every .rq file declares its prefixes
    assert prepared("doors_and_widths") is prepared("doors_and_widths")  # parsed once per process
    g = _graph()
    doors = {"ifcClass": "IfcDoor", "storeyLabel": "Level 1"}
    cases: tuple[tuple[str, dict[str, str]], ...] = (
        ("doors_and_widths", {}), ("storeys", {}), ("elements_by_class_and_storey", doors))
    for name, bindings in cases:
        from_text = result_rows(run_text(g, get_query(name).text,
                                         {k: Literal(v) for k, v in bindings.items()}))
        assert run_named(g, name, **bindings) == from_text, name
    assert run_named(g, "doors_and_widths").rows  # the comparison above compared rows, not two empty tables
