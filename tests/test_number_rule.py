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
