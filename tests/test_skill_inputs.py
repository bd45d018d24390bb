"""B2 skill inputs: one constant SPARQL text per binding, values bound, converted by value class."""

from __future__ import annotations

from pathlib import Path

import pytest
from rdflib import RDF, RDFS, Graph, Literal, URIRef
from rdflib.plugins.sparql import prepareQuery

from kb_fixtures import BASE, add_box, add_pose, add_task, frame_gid, make_model
from kbplanner.core.iris import element_iri, mint, task_iri
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.requirements import derive_requirements
from kbplanner.knowledge.task_specs import Binding, specification_ids, task_specification
from kbplanner.planning.skill_inputs import prepared_query, resolve_input, resolve_inputs, value_query

EXTENSION = Path(__file__).parent / "kb_extension" / "fixing_point.ttl"
EXT = "https://example.org/kb-extension#"
TEST = "https://example.org/test-kb#"


@pytest.fixture(scope="module")
def kb() -> Graph:
    return load_kb()


def _binding(kb: Graph, spec_id: str, order: int, name: str) -> Binding:
    action = next(a for a in task_specification(kb, spec_id).actions if a.order == order)
    b = action.binding(name)
    assert b is not None
    return b


def test_every_binding_of_the_knowledge_base_is_one_constant_query_of_knowledge_base_iris(kb: Graph) -> None:
    seen = 0
    for spec_id in specification_ids(kb):
        for action in task_specification(kb, spec_id).actions:
            for b in action.bindings:
                text = value_query(b)
                assert text.startswith("SELECT ?focus ?value WHERE { ?focus ")
                assert "data/" not in text  # no instance data, only ontology/KB IRIs
                prepareQuery(text)
                assert prepared_query(b) is prepared_query(b)  # prepared once, then cached
                seen += 1
    assert seen >= 9
    dest = _binding(kb, "I-W-F-#1", 1, "destination")
    assert value_query(dest) == ("SELECT ?focus ?value WHERE { ?focus (" + KBP.storedIn.n3() + "/"
                                 + KBP.pickupLocation.n3() + ") ?value . }")


def test_the_same_bindings_that_produced_requirements_give_the_values(kb: Graph) -> None:
    bare = make_model(3)
    unmet = {(r.action_order, r.input_name, e.iri) for r in derive_requirements(bare, kb).requirements
             for e in r.elements}
    assert {(o, n) for o, n, _ in unmet} == {(1, "destination"), (2, "grasp point")}
    spec = task_specification(kb, "I-W-F-#1")
    task = task_iri(BASE, "T1")
    frames = [element_iri(BASE, frame_gid(i)) for i in (1, 2, 3)]
    missing = {(a.order, v.name, el) for el in frames for a in spec.actions
               for v in resolve_inputs(bare, a.bindings, element=el, task=task) if not v.found}
    assert missing == unmet

    full = make_model(3, storage=True, grasp_points=True)
    assert derive_requirements(full, kb).requirements == []
    for el in frames:
        values = {(a.order, v.name): v for a in spec.actions
                  for v in resolve_inputs(full, a.bindings, element=el, task=task)}
        assert all(v.found for v in values.values())
        assert values[(1, "destination")].value == [-4.2, 3.0, 0.0, 0.0, 0.0, 3.1416]  # the storage pickup
        assert values[(2, "grasp point")].value == [0.0, 0.0, 1.2, 0.0, 0.0, 0.0]
        pose = full.value(el, KBP.installedPose)
        assert values[(3, "destination")].value[:2] == [float(full.value(pose, KBP.x)),  # type: ignore[arg-type]
                                                        float(full.value(pose, KBP.y))]  # type: ignore[arg-type]
        assert values[(4, "target pose")].value == values[(3, "destination")].value


def test_a_missing_value_names_the_input_the_path_and_where_it_stops(kb: Graph) -> None:
    model = make_model(1)
    storage = mint(BASE, "site", "bare-storage")
    el = element_iri(BASE, frame_gid(1))
    model.add((el, KBP.storedIn, storage))  # a storage without pickup location
    v = resolve_input(model, _binding(kb, "I-W-F-#1", 1, "destination"), el, describe="Frame 1")
    assert not v.found and v.value is None
    assert v.missing is not None
    assert "missing input 'destination'" in v.missing and "Frame 1" in v.missing
    assert "has no kbp:pickupLocation (step 2 of kbp:storedIn / kbp:pickupLocation)" in v.missing


def test_a_knowledge_base_extension_binding_is_fetched_with_no_code_change() -> None:
    kb = load_kb([EXTENSION])
    b = _binding(kb, "I-W-F-#1", 4, "fixing point")
    assert "kb-extension#fixingPoint" in value_query(b)
    model = make_model(2, storage=True, grasp_points=True)
    el1, el2 = (element_iri(BASE, frame_gid(i)) for i in (1, 2))
    model.add((el1, URIRef(EXT + "fixingPoint"), add_pose(model, mint(BASE, "pose", "fix-1"), 0.1, 0.0, 1.5)))
    found = resolve_input(model, b, el1)
    assert found.value == [0.1, 0.0, 1.5, 0.0, 0.0, 0.0]
    lacking = resolve_input(model, b, el2)
    assert lacking.missing is not None and "'fixing point'" in lacking.missing


def test_a_hostile_global_id_or_iri_in_the_model_does_not_change_the_query_text(kb: Graph) -> None:
    b = _binding(kb, "I-W-F-#1", 2, "grasp point")
    before = value_query(b)
    hostile = '2F"> } UNION { ?s ?p ?o } #{'
    model = make_model(1)
    el = element_iri(BASE, hostile)  # minted: percent-encoded
    raw = URIRef('https://example.org/el/a"> } UNION { ?focus ?p ?value } #')  # not even a valid IRI
    for node, gid in ((el, hostile), (raw, hostile)):
        model.add((node, KBP.globalId, Literal(gid)))
        model.add((node, RDFS.label, Literal(hostile)))
        grasp = add_pose(model, mint(BASE, "pose", f"g-{len(model)}"), 0.0, 0.0, 0.9)
        model.add((node, KBP.graspPoint, grasp))
    assert value_query(b) == before
    for node in (el, raw):
        v = resolve_input(model, b, node)
        assert v.value == [0.0, 0.0, 0.9, 0.0, 0.0, 0.0]
        assert v.notes == ()  # one value: the binding did not leak into other triples
    other = resolve_input(model, b, element_iri(BASE, frame_gid(1)))
    assert not other.found


def _path_extension(tmp_path: Path) -> Path:
    """A test KB: skill TS-1 with inputs bound by an inverse, an alternative and a zero-or-more path."""
    ttl = f"""@prefix kbp: <https://w3id.org/kbplanner/ontology#> .
@prefix bot: <https://w3id.org/bot#> .
@prefix owl: <http://www.w3.org/2002/07/owl#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix xsd: <http://www.w3.org/2001/XMLSchema#> .
@prefix sh: <http://www.w3.org/ns/shacl#> .
@prefix t: <{TEST}> .

t:partOf a owl:ObjectProperty ; rdfs:label "part of" .
t:markPoint a owl:ObjectProperty ; rdfs:range kbp:Pose ; rdfs:label "mark point" .
t:fallbackPoint a owl:ObjectProperty ; rdfs:range kbp:Pose ; rdfs:label "fallback point" .
t:thickness a owl:DatatypeProperty ; rdfs:range xsd:double ; rdfs:label "thickness" .

t:TS-1 a kbp:Skill ; kbp:skillId "TS-1" ; rdfs:label "test skill" ; kbp:skillKind kbp:LineMarking ;
    kbp:hasInput t:TS-1-storey , t:TS-1-point , t:TS-1-root , t:TS-1-thickness .
t:TS-1-storey a kbp:SkillInput ; kbp:inputName "storey" ; kbp:valueClass bot:Storey ;
    kbp:inputSource kbp:FromModel .
t:TS-1-point a kbp:SkillInput ; kbp:inputName "point" ; kbp:valueClass kbp:Pose ;
    kbp:inputSource kbp:FromModel .
t:TS-1-root a kbp:SkillInput ; kbp:inputName "root" ; kbp:valueClass kbp:Element ;
    kbp:inputSource kbp:FromModel .
t:TS-1-thickness a kbp:SkillInput ; kbp:inputName "thickness" ; kbp:valueClass xsd:double ;
    kbp:inputSource kbp:FromModel .

t:SPEC a kbp:TaskSpecification ; kbp:specificationId "PATHS-#1" ; rdfs:label "path forms" ;
    kbp:hasAction t:SPEC-a1 .
t:SPEC-a1 a kbp:Action ; kbp:order 1 ; rdfs:label "mark" ; kbp:usesSkill t:TS-1 ;
    kbp:hasBinding t:b-storey , t:b-point , t:b-root , t:b-thickness .
t:b-storey a kbp:InputBinding ; kbp:bindsInput t:TS-1-storey ; kbp:pathStart kbp:StartAtElement ;
    kbp:bindingPath [ sh:inversePath bot:containsElement ] .
t:b-point a kbp:InputBinding ; kbp:bindsInput t:TS-1-point ; kbp:pathStart kbp:StartAtElement ;
    kbp:bindingPath [ sh:alternativePath ( t:markPoint t:fallbackPoint ) ] .
t:b-root a kbp:InputBinding ; kbp:bindsInput t:TS-1-root ; kbp:pathStart kbp:StartAtElement ;
    kbp:bindingPath ( [ sh:zeroOrMorePath t:partOf ] ) .
t:b-thickness a kbp:InputBinding ; kbp:bindsInput t:TS-1-thickness ; kbp:pathStart kbp:StartAtElement ;
    kbp:bindingPath t:thickness .
"""
    path = tmp_path / "paths.ttl"
    path.write_text(ttl)
    return path


def test_inverse_alternative_and_repeated_paths_render_as_sparql_paths_and_fetch_values(
        tmp_path: Path) -> None:
    kb = load_kb([_path_extension(tmp_path)])
    action = task_specification(kb, "PATHS-#1").actions[0]
    texts = {b.input.name: value_query(b) for b in action.bindings}
    assert "^<https://w3id.org/bot#containsElement>" in texts["storey"]
    assert f"(<{TEST}markPoint>|<{TEST}fallbackPoint>)" in texts["point"]
    assert f"(<{TEST}partOf>)*" in texts["root"]
    model = make_model(1)
    el = element_iri(BASE, frame_gid(1))
    model.add((el, URIRef(TEST + "fallbackPoint"), add_pose(model, mint(BASE, "pose", "fb"), 1.0, 2.0, 0.5)))
    model.add((el, URIRef(TEST + "thickness"), Literal(0.089)))
    task = task_iri(BASE, "T1")
    values = {v.name: v for v in resolve_inputs(model, action.bindings, element=el, task=task)}
    assert values["storey"].value == str(mint(BASE, "storey", "L1"))
    assert values["point"].value == [1.0, 2.0, 0.5, 0.0, 0.0, 0.0]
    assert values["root"].value == str(el)  # zero steps: the element itself
    assert values["thickness"].value == 0.089


def test_a_box_becomes_six_numbers_and_a_task_path_starts_at_the_task(kb: Graph) -> None:
    g = make_model(1, spec_id="L-M-#1")
    el = element_iri(BASE, frame_gid(1))
    task = task_iri(BASE, "T1")
    g.add((task, KBP.surveyReference, add_pose(g, mint(BASE, "pose", "survey"), 1.0, -1.0, 0.0)))
    action = task_specification(kb, "L-M-#1").actions[1]
    values = {v.name: v for v in resolve_inputs(g, action.bindings, element=el, task=task, task_name="T1")}
    assert values["footprint"].value == [5.2, 4.45, 0.0, 5.8, 4.55, 2.4]
    assert values["survey reference"].value == [1.0, -1.0, 0.0, 0.0, 0.0, 0.0]
    assert not values["marking start"].found


def test_an_incomplete_pose_or_box_is_missing_with_a_reason_and_several_values_give_a_note(kb: Graph) -> None:
    g = make_model(2, grasp_points=True)
    el1, el2 = (element_iri(BASE, frame_gid(i)) for i in (1, 2))
    half = mint(BASE, "pose", "half")
    g.add((half, RDF.type, KBP.Pose))
    g.add((half, KBP.x, Literal(1.0)))
    g.remove((el1, KBP.graspPoint, None))
    g.add((el1, KBP.graspPoint, half))
    b = _binding(kb, "I-W-F-#1", 2, "grasp point")
    v = resolve_input(g, b, el1)
    assert v.missing is not None and "not a complete pose" in v.missing
    g.add((el2, KBP.graspPoint, add_pose(g, mint(BASE, "pose", "a-second"), 0.0, 0.0, 0.3)))
    two = resolve_input(g, b, el2)
    assert two.found and len(two.notes) == 1 and "2 values" in two.notes[0]
    box = mint(BASE, "box", "half")
    add_box(g, box, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    g.remove((box, KBP.maxZ, None))
    g.remove((el1, KBP.bounds, None))
    g.add((el1, KBP.bounds, box))
    fb = task_specification(kb, "L-M-#1").actions[1].binding("footprint")
    assert fb is not None
    assert "not a complete box" in (resolve_input(g, fb, el1).missing or "")


def test_a_task_that_builds_no_such_element_has_no_values(kb: Graph) -> None:
    g = Graph()
    add_task(g, "T9", "nothing", [], robotized=True, spec_id="I-W-F-#1")
    b = _binding(kb, "I-W-F-#1", 3, "destination")
    assert not resolve_input(g, b, element_iri(BASE, "nope")).found
