"""The numeric rule: ranges from shapes/numbers.ttl, checked where files are read and by validate's SHACL."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from rdflib import XSD, Graph, Literal, URIRef

from kbplanner.core.errors import NumberRangeError
from kbplanner.core.number_rule import check_numbers, number_ranges
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.validation import validate_model
from kbplanner.project import Project
from project_factory import make_project

CASE_STUDY = Path(__file__).resolve().parents[1] / "data" / "case_study"


def test_ranges_come_from_the_shapes() -> None:
    ranges = number_ranges()
    assert not ranges[KBP.maxSpeed].allows(0.0) and ranges[KBP.maxSpeed].allows(0.3)
    assert ranges[KBP.dwellTime].allows(0.0) and not ranges[KBP.dwellTime].allows(-1.0)
    for bad in (math.nan, math.inf, -math.inf, 2e9):
        assert not ranges[KBP.x].allows(bad)


@pytest.mark.parametrize(("prop", "value"), [
    (KBP.maxSpeed, Literal("NaN", datatype=XSD.double)),
    (KBP.maxSpeed, Literal("INF", datatype=XSD.double)),
    (KBP.maxSpeed, Literal(-1.0)),
    (KBP.sizeZ, Literal(0.0)),
    (KBP.dwellTime, Literal(-2.0)),
    (KBP.mass, Literal(0)),
])
def test_a_bad_number_names_file_subject_property_and_value(prop: URIRef, value: Literal) -> None:
    g = Graph()
    g.add((URIRef("urn:x:node"), prop, value))
    with pytest.raises(NumberRangeError) as err:
        check_numbers(g, "site/jobsite.ttl")
    text = str(err.value)
    assert "site/jobsite.ttl" in text and "urn:x:node" in text and f"kbp:{prop.split('#')[1]}" in text
    assert "fix:" in text


def test_every_file_of_the_case_study_keeps_the_rule() -> None:
    for ttl in sorted(CASE_STUDY.rglob("*.ttl")):
        check_numbers(Graph().parse(ttl, format="turtle"), ttl)


def test_validate_reports_a_bad_number_in_its_shacl_report(tmp_path: Path) -> None:
    make_project(tmp_path / "p")
    project = Project.load(tmp_path / "p")
    node = URIRef("https://w3id.org/kbplanner/data/testproj/site/limit")
    project.model.add((node, KBP.maxSpeed, Literal("INF", datatype=XSD.double)))
    result = validate_model(project.model, project.kb)
    assert not result.conforms
    assert any(str(node) in str(r) and "maxSpeed" in str(r) for r in result.rows)


def test_a_turtle_syntax_error_gives_line_and_column(tmp_path: Path) -> None:
    from kbplanner.core.errors import RdfSyntaxError
    from kbplanner.core.rdf_io import parse_turtle

    bad = tmp_path / "site.ttl"
    bad.write_text('@prefix kbp: <https://w3id.org/kbplanner/ontology#> .\n<urn:a> kbp:x 1.0 .\n'
                   '<urn:b> kbp:y 2.0 ;\n   kbp:z zz:q .\n')
    with pytest.raises(RdfSyntaxError) as err:
        parse_turtle(bad)
    assert str(err.value).startswith(f"{bad}:4: Turtle syntax error at column 10: ")
    assert 'zz:' in str(err.value)


def test_owl_imports_of_a_local_file_is_read_and_a_missing_one_is_an_error(tmp_path: Path) -> None:
    from kbplanner.core.errors import InputFileError
    from kbplanner.core.rdf_io import parse_turtle

    main = tmp_path / "main.ttl"
    main.write_text("@prefix owl: <http://www.w3.org/2002/07/owl#> .\n"
                    "<urn:o> a owl:Ontology ; owl:imports <other.ttl> .\n")
    (tmp_path / "other.ttl").write_text('<urn:x> <urn:p> "from other" .\n'
                                        "<urn:o2> <http://www.w3.org/2002/07/owl#imports> <main.ttl> .\n")
    g = parse_turtle(main)
    assert (URIRef("urn:x"), URIRef("urn:p"), Literal("from other")) in g
    (tmp_path / "other.ttl").unlink()
    with pytest.raises(InputFileError, match="no such file"):
        parse_turtle(main)
