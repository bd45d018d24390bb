"""Validation of the augmented model (A4, A5): well-formedness shapes plus the generated requirement
shapes, a standard SHACL report, readable rows naming the term, and the caller's graph left untouched."""

from __future__ import annotations

from pathlib import Path

import pytest
import rdflib
from rdflib import RDF, Graph, Literal
from rdflib.compare import isomorphic

from kb_fixtures import BASE, add_jobsite, add_pose, frame_gid, make_model
from kbplanner.core.iris import mint, task_iri
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import SH, load_kb
from kbplanner.knowledge.validation import ValidationResult, validate_model


@pytest.fixture(scope="module")
def kb() -> Graph:
    return load_kb()


def _augmented() -> Graph:
    return make_model(n_frames=4, storage=True, grasp_points=True, jobsite=True)


def _messages(result: ValidationResult) -> list[str]:
    return [r.line() for r in result.violations]


def test_an_augmented_model_conforms_and_the_report_is_standard_shacl(kb: Graph) -> None:
    result = validate_model(_augmented(), kb)
    assert result.conforms, result.text()
    assert result.rows == []
    assert (None, RDF.type, SH.ValidationReport) in result.report_graph
    assert result.report_graph.value(next(result.report_graph.subjects(RDF.type, SH.ValidationReport)),
                                     SH.conforms) == Literal(True)
    assert result.text().startswith("The model conforms.")


def test_a_bare_model_does_not_conform_because_its_requirements_are_unmet(kb: Graph) -> None:
    result = validate_model(make_model(n_frames=3), kb)
    assert not result.conforms
    assert {r.kind for r in result.violations} == {"requirement"}
    assert len(result.violations) == 6  # NV-1 destination and MM-G-1 grasp point for three frames
    assert validate_model(make_model(n_frames=3), kb, include_requirements=False).conforms


def test_validation_never_modifies_the_callers_graph(kb: Graph) -> None:
    model = make_model(n_frames=3, spec_id="I-W-F-#9")
    before = Graph()
    for t in model:
        before.add(t)
    validate_model(model, kb)
    validate_model(_augmented(), kb)
    assert len(model) == len(before) and isomorphic(model, before)


def test_a_task_that_starts_after_it_finishes_is_a_violation_naming_the_task(kb: Graph) -> None:
    model = _augmented()
    t0 = task_iri(BASE, "T0")
    model.set((t0, KBP.finish, Literal("2022-05-01T07:00:00", datatype=rdflib.XSD.dateTime)))
    result = validate_model(model, kb)
    assert not result.conforms
    [row] = result.violations
    assert row.focus == "task T0" and row.path == "kbp:start" and "before it finishes" in row.message


def test_an_unknown_task_specification_id_is_a_validation_result(kb: Graph) -> None:
    result = validate_model(make_model(n_frames=2, spec_id="I-W-F-#9", storage=True, grasp_points=True), kb)
    [row] = result.violations
    assert row.focus == "task T1" and row.value == "I-W-F-#9"
    assert "task specification id I-W-F-#9 is not in the knowledge base" in row.message


def test_a_robotized_task_without_specification_id_is_a_validation_result(kb: Graph) -> None:
    result = validate_model(make_model(n_frames=2, spec_id=None, storage=True, grasp_points=True), kb)
    [row] = result.violations
    assert row.focus == "task T1" and "has no kbp:taskSpecificationId" in row.message


def test_an_element_of_a_robotized_task_without_geometry_is_named(kb: Graph) -> None:
    model = _augmented()
    el = next(model.subjects(KBP.globalId, Literal(frame_gid(2))))
    model.remove((el, KBP.meshFile, None))
    box = model.value(el, KBP.bounds)
    model.remove((el, KBP.bounds, None))
    model.remove((box, None, None))
    [row] = validate_model(model, kb).violations
    assert row.value == f"{frame_gid(2)} 'Frame 2'" and "has no geometry" in row.message


def test_a_pose_with_five_numbers_or_a_decimal_is_a_violation(kb: Graph) -> None:
    model = _augmented()
    pickup = mint(BASE, "pose", "frame-pickup")
    model.remove((pickup, KBP.yaw, None))
    grasp = mint(BASE, "pose", "grasp-1")
    model.set((grasp, KBP.z, Literal("1.2", datatype=rdflib.XSD.decimal)))
    rows = validate_model(model, kb).violations
    named = {(r.path, r.focus, r.focus_label) for r in rows}
    storage = mint(BASE, "site", "frame-storage")
    assert named == {("kbp:yaw", f"kbp:pickupLocation of <{storage}>", "Frame storage"),
                     ("kbp:z", f"kbp:graspPoint of {frame_gid(1)}", "Frame 1")}
    assert all("xsd:double" in r.message for r in rows)


def test_a_pickup_location_outside_the_site_extent_is_a_violation(kb: Graph) -> None:
    model = _augmented()
    model.set((mint(BASE, "pose", "frame-pickup"), KBP.x, Literal(-25.0)))
    [row] = validate_model(model, kb).violations
    assert "pickup location" in row.message and "outside the site extent" in row.message
    assert row.focus_label == "Frame storage"


def test_jobsite_parameters_out_of_range_are_violations_naming_the_term(kb: Graph) -> None:
    model = make_model(n_frames=2, storage=True, grasp_points=True)
    add_jobsite(model, max_width=-0.5, min_speed=0.5, max_speed=0.2, zone_at=(39.0, 0.0))
    rows = validate_model(model, kb).violations
    lines = "\n".join(r.line() for r in rows)
    assert "kbp:maxRobotWidth (allowable robot width (m)) is one positive number" in lines
    assert "kbp:minSpeed (m/s) of an action limit is one number >= 0 and not above its kbp:maxSpeed" in lines
    assert "no-go zone reaches outside the site extent" in lines
    assert len(rows) == 3


def test_an_action_limit_for_an_unknown_skill_is_a_violation(kb: Graph) -> None:
    model = make_model(n_frames=2, storage=True, grasp_points=True)
    add_jobsite(model)
    limit = mint(BASE, "site", "jobsite-nv2-limit")
    model.set((limit, KBP.appliesTo, mint("https://w3id.org/kbplanner/kb#", "x", "NV-9")))
    [row] = validate_model(model, kb).violations
    assert "neither a skill nor an action of the knowledge base" in row.message


def test_extra_shapes_are_applied(kb: Graph) -> None:
    extra = Graph().parse(data="""
@prefix sh: <http://www.w3.org/ns/shacl#> . @prefix kbp: <https://w3id.org/kbplanner/ontology#> .
<https://example.org/shapes#MassNeeded> a sh:NodeShape ; sh:targetClass kbp:Member ;
    sh:property <https://example.org/shapes#MassNeeded-mass> .
<https://example.org/shapes#MassNeeded-mass> sh:path kbp:mass ; sh:minCount 1 ;
    sh:message "a member needs a mass" .
""", format="turtle")
    model = _augmented()
    el = next(model.subjects(KBP.globalId, Literal(frame_gid(1))))
    model.remove((el, KBP.mass, None))
    [row] = validate_model(model, kb, extra_shapes=extra).violations
    assert row.message == "a member needs a mass" and row.focus == frame_gid(1)


def test_the_written_report_parses_and_is_byte_identical_across_runs(kb: Graph, tmp_path: Path) -> None:
    model = make_model(n_frames=3)
    a, b = tmp_path / "a.ttl", tmp_path / "b.ttl"
    validate_model(model, kb).write(a)
    validate_model(make_model(n_frames=3), kb).write(b)
    assert a.read_bytes() == b.read_bytes()
    report = Graph().parse(a, format="turtle")
    assert len(list(report.subjects(RDF.type, SH.ValidationResult))) == 6
    txt = tmp_path / "r.txt"
    validate_model(model, kb).write(txt)
    assert txt.read_text().splitlines()[1].startswith("The model does not conform: 6 violation(s).")


def test_a_second_pose_given_to_an_element_is_a_violation(kb: Graph) -> None:
    model = _augmented()
    el = next(model.subjects(KBP.globalId, Literal(frame_gid(3))))
    model.add((el, KBP.installedPose, add_pose(model, mint(BASE, "pose", "extra"), 1.0, 1.0)))
    rows = validate_model(model, kb).violations
    assert [r.path for r in rows] == ["kbp:installedPose"] and rows[0].focus == frame_gid(3)
