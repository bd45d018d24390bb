"""Additional modeling requirements (A3): derived from the knowledge base's bindings through generated
SHACL shapes, grouped per cause, with a Turtle template that meets them once added to the model."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest
from rdflib import RDF, Graph, Literal, URIRef
from rdflib.compare import isomorphic

from kb_fixtures import BASE, add_pose, frame_gid, make_model
from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.core.iris import mint
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.requirement_rows import MISSING, WRONG_TYPE
from kbplanner.knowledge.requirements import derive_requirements

EXTENSION = Path(__file__).parent / "kb_extension" / "fixing_point.ttl"
EXT_FIXING_POINT = URIRef("https://example.org/kb-extension#fixingPoint")


@pytest.fixture(scope="module")
def kb() -> Graph:
    return load_kb()


def test_a_bare_model_needs_the_papers_two_requirements_for_all_eleven_frames(kb: Graph) -> None:
    result = derive_requirements(make_model(), kb)
    rows = [(r.action_order, r.skill_id, r.input_name, r.problem, len(r.elements))
            for r in result.requirements]
    assert rows == [(1, "NV-1", "destination", MISSING, 11), (2, "MM-G-1", "grasp point", MISSING, 11)]
    nv1 = result.requirements[0]
    assert nv1.missing == "stored in -> material storage -> robot pickup location (pose)"
    assert "kbp:storedIn -> kbp:MaterialStorage" in nv1.how_to_add
    pose = "kbp:pickupLocation -> kbp:Pose with kbp:x, kbp:y, kbp:z, kbp:roll, kbp:pitch, kbp:yaw"
    assert pose in nv1.how_to_add
    assert "Model the frame material storage" in nv1.how_to_add  # the binding's modeling hint
    assert {e.global_id for e in nv1.elements} == {frame_gid(i) for i in range(1, 12)}
    assert {e.label for e in nv1.elements} == {f"Frame {i}" for i in range(1, 12)}


def test_inputs_the_model_already_holds_produce_no_requirement(kb: Graph) -> None:
    result = derive_requirements(make_model(), kb)
    assert not any(r.skill_id in ("NV-2", "MM-R-1") for r in result.requirements)
    met = [(c.action_order, c.skill_id, c.targets) for c in result.checks if c.unmet == 0]
    assert met == [(3, "NV-2", 11), (4, "MM-R-1", 11)]


def test_an_augmented_model_has_no_requirements(kb: Graph) -> None:
    result = derive_requirements(make_model(storage=True, grasp_points=True), kb)
    assert result.met and result.requirements == []
    assert all(c.unmet == 0 for c in result.checks) and len(result.checks) == 4


def test_a_storage_without_pickup_location_is_named_as_what_is_missing(kb: Graph) -> None:
    model = make_model(storage=True, grasp_points=True)
    storage = mint(BASE, "site", "frame-storage")
    model.remove((storage, KBP.pickupLocation, None))
    [req] = derive_requirements(model, kb).requirements
    assert req.skill_id == "NV-1" and len(req.elements) == 11
    assert req.missing.endswith("the material storage 'Frame storage' has no robot pickup location (pose)")
    assert req.how_to_add.startswith(
        "give the material storage 'Frame storage' kbp:pickupLocation -> kbp:Pose")


def test_a_value_of_the_wrong_type_is_a_requirement_of_its_own(kb: Graph) -> None:
    model = make_model(n_frames=3, storage=True, grasp_points=True)
    grasp = mint(BASE, "pose", "grasp-2")
    model.remove((grasp, RDF.type, KBP.Pose))
    [req] = derive_requirements(model, kb).requirements
    assert (req.skill_id, req.problem, [e.global_id for e in req.elements]) == ("MM-G-1", WRONG_TYPE,
                                                                                 [frame_gid(2)])
    assert "is not a kbp:Pose" in req.missing


def test_requirements_are_derived_without_modifying_the_model(kb: Graph) -> None:
    model = make_model()
    before = Graph()
    for t in model:
        before.add(t)
    derive_requirements(model, kb)
    assert isomorphic(model, before) and len(model) == len(before)


def test_a_knowledge_base_extension_adds_a_requirement_without_code_change() -> None:
    model = make_model(storage=True, grasp_points=True)
    assert derive_requirements(model, load_kb()).requirements == []
    [req] = derive_requirements(model, load_kb([EXTENSION])).requirements
    summary = (req.action_order, req.skill_id, req.input_name, len(req.elements))
    assert summary == (4, "MM-R-1", "fixing point", 11)
    assert req.missing == "fixing point (pose)"
    assert "give each element ext:fixingPoint -> kbp:Pose" in req.how_to_add


def test_the_template_as_written_meets_the_requirements_it_lists(kb: Graph) -> None:
    model = make_model()
    result = derive_requirements(model, kb)
    text = result.template()
    assert "TODO requirement 1" in text and '"0.0"^^xsd:double' in text
    skeleton = Graph().parse(data=text, format="turtle")
    storages = list(skeleton.subjects(RDF.type, KBP.MaterialStorage))
    assert len(storages) == 1  # one shared storage for the eleven frames
    assert len(list(skeleton.subjects(KBP.graspPoint, None))) == 11  # one grasp point per frame
    augmented = make_model()
    augmented += skeleton
    assert derive_requirements(augmented, kb).requirements == []


def test_the_template_completes_a_partial_storage_without_a_second_storage(kb: Graph) -> None:
    model = make_model(grasp_points=True, storage=True)
    model.remove((mint(BASE, "site", "frame-storage"), KBP.pickupLocation, None))
    skeleton = Graph().parse(data=derive_requirements(model, kb).template(), format="turtle")
    assert list(skeleton.subjects(RDF.type, KBP.MaterialStorage)) == []
    assert list(skeleton.subjects(KBP.pickupLocation, None)) == [mint(BASE, "site", "frame-storage")]
    model += skeleton
    assert derive_requirements(model, kb).requirements == []


def test_a_template_for_an_extension_input_is_met_once_applied() -> None:
    kb = load_kb([EXTENSION])
    model = make_model(n_frames=4, storage=True, grasp_points=True)
    skeleton = Graph().parse(data=derive_requirements(model, kb).template(), format="turtle")
    model += skeleton
    assert derive_requirements(model, kb).requirements == []


def test_template_iris_are_unique_per_requirement() -> None:
    # issue 12: one pose IRI was reused for every requirement that adds a pose to the same element
    kb = load_kb([EXTENSION])
    model = make_model(n_frames=2, storage=True)  # no grasp point, no fixing point
    text = derive_requirements(model, kb).template()
    skeleton = Graph().parse(data=text, format="turtle")
    grasp = set(skeleton.objects(None, KBP.graspPoint))
    fixing = set(skeleton.objects(None, EXT_FIXING_POINT))
    assert len(grasp) == 2 and len(fixing) == 2 and not grasp & fixing
    assert all((p, RDF.type, KBP.Pose) in skeleton for p in grasp | fixing)
    model += skeleton
    assert derive_requirements(model, kb).requirements == []


def test_the_template_is_deterministic(kb: Graph) -> None:
    one = derive_requirements(make_model(), kb).template()
    two = derive_requirements(make_model(), kb).template()
    assert one == two and "_:" not in one


def test_a_binding_that_starts_at_the_task_targets_the_task(kb: Graph) -> None:
    model = make_model(n_frames=2, spec_id="L-M-#1")
    result = derive_requirements(model, kb)
    by_input = {r.input_name: r for r in result.requirements}
    assert set(by_input) == {"destination", "marking start", "survey reference"}
    [task] = by_input["survey reference"].elements
    assert task.global_id == "T1" and task.label == "Frame interior wood partition"
    assert {c.input_name for c in result.checks if c.unmet == 0} == {"footprint"}  # elements have bounds
    model += Graph().parse(data=result.template(), format="turtle")
    assert derive_requirements(model, kb).requirements == []


def test_a_robotized_task_with_an_unknown_specification_is_a_clear_error(kb: Graph) -> None:
    with pytest.raises(KnowledgeBaseError) as err:
        derive_requirements(make_model(spec_id="I-W-F-#9"), kb)
    assert "task T1 names task specification id 'I-W-F-#9'" in str(err.value)


def test_a_robotized_task_without_a_specification_is_a_clear_error(kb: Graph) -> None:
    with pytest.raises(KnowledgeBaseError, match="has no task specification id"):
        derive_requirements(make_model(spec_id=None), kb)


def test_requirements_render_as_csv_json_and_turtle(kb: Graph) -> None:
    result = derive_requirements(make_model(n_frames=3), kb)
    rows = list(csv.DictReader(io.StringIO(result.to_csv())))
    assert len(rows) == 6 and {r["skill"] for r in rows} == {"NV-1", "MM-G-1"}
    assert rows[0]["globalId"] == frame_gid(1)
    data = json.loads(result.to_json())
    assert [len(r["elements"]) for r in data["requirements"]] == [3, 3]
    assert len(data["checked"]) == 4
    g = Graph().parse(data=result.to_graph().serialize(format="turtle"), format="turtle")
    reqs = list(g.subjects(RDF.type, KBP.ModelingRequirement))
    assert len(reqs) == 2
    assert all(len(list(g.objects(r, KBP.missingFor))) == 3 for r in reqs)
    assert {str(g.value(r, KBP.requirementText)) for r in reqs} == {
        "stored in -> material storage -> robot pickup location (pose)", "grasp point (pose)"}


def test_only_the_requested_task_is_checked(kb: Graph) -> None:
    model = make_model(n_frames=2)
    assert derive_requirements(model, kb, task_id="T0").requirements == []
    assert len(derive_requirements(model, kb, task_id="T1").requirements) == 2


def test_a_non_robotized_task_gets_no_requirements(kb: Graph) -> None:
    model = make_model(n_frames=2)
    model.set((next(model.subjects(KBP.taskId, Literal("T1"))), KBP.robotized, Literal(False)))
    assert derive_requirements(model, kb).requirements == []


def test_a_pose_typed_in_the_model_but_stored_elsewhere_still_counts(kb: Graph) -> None:
    # grasp points given for only some frames: one requirement listing the others
    model = make_model(n_frames=4, storage=True)
    for i in (1, 3):
        el = next(model.subjects(KBP.globalId, Literal(frame_gid(i))))
        model.add((el, KBP.graspPoint, add_pose(model, mint(BASE, "pose", f"g{i}"), 0.0, 0.0, 1.2)))
    [req] = derive_requirements(model, kb).requirements
    assert [e.global_id for e in req.elements] == [frame_gid(2), frame_gid(4)]


def test_an_oxigraph_backed_model_gives_the_same_requirements_and_validation(kb: Graph) -> None:
    from kbplanner.core.rdf_io import new_graph
    from kbplanner.knowledge.validation import validate_model

    memory = make_model(n_frames=3)
    oxi = new_graph("oxigraph")
    oxi += memory
    one, two = derive_requirements(memory, kb), derive_requirements(oxi, kb)
    assert [(r.skill_id, r.elements) for r in one.requirements] == [(r.skill_id, r.elements)
                                                                    for r in two.requirements]
    assert one.template() == two.template()
    assert len(validate_model(oxi, kb).violations) == 6
