"""The construction robot knowledge base (A1-A2): skills, task specifications, bindings, and the
errors a broken knowledge base gives (naming the file and the term, never a traceback)."""

from __future__ import annotations

from pathlib import Path

import pytest
from rdflib import Graph, Literal, URIRef

from kb_fixtures import frame_gid, make_model
from kbplanner.core.errors import KnowledgeBaseError, RdfSyntaxError
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.binding_paths import (
    InversePath,
    PredicatePath,
    SequencePath,
    copy_path,
    read_path,
    sparql_path,
)
from kbplanner.knowledge.knowledge_base import KB, load_kb, source_of
from kbplanner.knowledge.requirement_shapes import requirement_shapes
from kbplanner.knowledge.task_specs import robotized_tasks, skill_ids, specification_ids, task_specification

PREFIXES = """@prefix kbp: <https://w3id.org/kbplanner/ontology#> .
@prefix kb: <https://w3id.org/kbplanner/kb#> .
@prefix ext: <https://example.org/ext#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix sh: <http://www.w3.org/ns/shacl#> .
"""


@pytest.fixture(scope="module")
def kb() -> Graph:
    return load_kb()


def _extension(tmp_path: Path, body: str, name: str = "ext.ttl") -> Path:
    p = tmp_path / name
    p.write_text(PREFIXES + body, encoding="utf-8")
    return p


def test_the_knowledge_base_traces_every_skill_and_specification_to_its_file(kb: Graph) -> None:
    assert source_of(kb, KB["NV-1"]) == "ontology/kb/skills.ttl"
    assert source_of(kb, KB["I-W-F-1"]) == "ontology/kb/task_specifications.ttl"
    assert source_of(kb, KB["husky-ur5"]) == "ontology/kb/robots.ttl"
    assert source_of(kb, URIRef("https://example.org/nothing")) is None


def test_the_knowledge_base_holds_the_papers_skills_and_its_specifications(kb: Graph) -> None:
    assert {"NV-1", "NV-2", "MM-G-1", "MM-R-1", "MK-1"} <= set(skill_ids(kb))
    assert {"I-W-F-#1", "I-W-F-#2", "L-M-#1", "B-I-#1"} <= set(specification_ids(kb))


def test_board_installation_is_a_turtle_only_task_of_the_existing_skills(kb: Graph) -> None:
    spec = task_specification(kb, "B-I-#1")
    assert source_of(kb, spec.iri) == "ontology/kb/board_installation.ttl"
    assert [a.skill.skill_id for a in spec.actions] == ["NV-1", "MM-G-1", "NV-2", "MM-R-1"]
    assert spec.task_kind == KB["BoardInstallation"]
    assert dict((p.kind, v) for p, v in spec.actions[2].settings) == {KBP.maxSpeed: 0.25}


def test_I_W_F_1_is_the_papers_four_actions_with_their_skills_and_bindings(kb: Graph) -> None:
    spec = task_specification(kb, "I-W-F-#1")
    assert spec.task_kind == KBP.InteriorWallFraming
    summary = [(a.order, a.label, a.skill.skill_id, [(b.input.name, b.words) for b in a.bindings])
               for a in spec.actions]
    assert summary == [
        (1, "navigate to frame pickup location", "NV-1",
         [("destination", "stored in -> material storage -> robot pickup location (pose)")]),
        (2, "pick frame", "MM-G-1", [("grasp point", "grasp point (pose)")]),
        (3, "navigate to install location", "NV-2", [("destination", "installed pose (pose)")]),
        (4, "install frame", "MM-R-1", [("target pose", "installed pose (pose)")]),
    ]
    nv1 = spec.actions[0].bindings[0]
    assert nv1.path == SequencePath((PredicatePath(KBP.storedIn), PredicatePath(KBP.pickupLocation)))
    assert not nv1.starts_at_task


def test_skills_carry_typed_inputs_parameters_with_units_and_required_capabilities(kb: Graph) -> None:
    spec = task_specification(kb, "I-W-F-#1")
    nv2 = spec.actions[2].skill
    assert nv2.kind == KBP.NavigationWithObject
    assert {i.name: i.source for i in nv2.inputs}["destination"] == KBP.FromModel
    assert {i.name for i in nv2.inputs if not i.from_model} == {"initial pose", "map", "laser scan",
                                                                   "carried object"}
    params = {p.kind: (p.default, p.unit) for p in nv2.parameters}
    assert params[KBP.maxSpeed] == (0.3, "m/s") and params[KBP.safetyStopDistance] == (1.0, "m")
    assert params[KBP.armPose] == (KB["pose-carry"], "rad")
    assert set(nv2.capabilities) == {KBP.Navigation2D, KBP.Lidar2D, KBP.Manipulation6DoF, KBP.Gripping}


def test_I_W_F_2_is_another_method_for_the_same_task_with_its_own_carry_parameters(kb: Graph) -> None:
    one, two = task_specification(kb, "I-W-F-#1"), task_specification(kb, "I-W-F-#2")
    assert one.task_kind == two.task_kind
    assert [a.skill.skill_id for a in two.actions] == [a.skill.skill_id for a in one.actions]
    settings = {p.kind: v for p, v in two.actions[2].settings}
    assert settings == {KBP.armPose: KB["pose-carry-on-side"], KBP.maxSpeed: 0.2, KBP.safetyStopDistance: 1.5}


def test_layout_marking_is_a_different_task_whose_reference_binding_starts_at_the_task(kb: Graph) -> None:
    spec = task_specification(kb, "L-M-#1")
    assert spec.task_kind == KBP.LayoutMarking
    mk = spec.actions[1]
    assert mk.skill.skill_id == "MK-1" and KBP.MarkingTool in mk.skill.capabilities
    starts = {b.input.name: b.starts_at_task for b in mk.bindings}
    assert starts == {"footprint": False, "marking start": False, "survey reference": True}
    assert mk.binding("footprint") is not None and mk.binding("footprint").input.value_class == KBP.Box  # type: ignore[union-attr]


def test_robotized_tasks_come_from_the_schedule_with_their_elements_sorted() -> None:
    tasks = robotized_tasks(make_model(n_frames=3))
    assert [(t.task_id, t.spec_id, len(t.elements)) for t in tasks] == [("T1", "I-W-F-#1", 3)]
    assert [e.global_id for e in tasks[0].elements] == [frame_gid(1), frame_gid(2), frame_gid(3)]
    assert robotized_tasks(make_model(), "T0") == []


def test_generated_shapes_copy_the_binding_path_as_shacl_structure(kb: Graph) -> None:
    shapes = requirement_shapes(make_model(n_frames=2), kb)
    nv1 = next(t for t in shapes.targets.values() if t.action.order == 1)
    from kbplanner.knowledge.knowledge_base import SH

    path_node = shapes.graph.value(nv1.shape, SH.path)
    assert path_node is not None
    assert read_path(kb + shapes.graph, path_node, owner=nv1.shape) == nv1.binding.path
    assert shapes.graph.value(nv1.shape, SH["class"]) == KBP.Pose
    assert set(shapes.graph.objects(nv1.shape, SH.targetNode)) == {e.iri for e in nv1.task.elements}
    assert shapes.graph.value(nv1.shape, KBP.forBinding) == KB["I-W-F-1-a1-destination"]


def test_other_shacl_path_forms_round_trip_and_render_as_sparql(kb: Graph) -> None:
    g = Graph()
    path = SequencePath((InversePath(PredicatePath(KBP.storedIn)), PredicatePath(KBP.installedPose)))
    node = copy_path(path, g)
    assert read_path(kb + g, node, owner=node) == path
    assert sparql_path(path) == f"(^<{KBP.storedIn}>/<{KBP.installedPose}>)"


def test_a_path_rendered_from_a_binding_fetches_the_value_with_the_element_bound(kb: Graph) -> None:
    model = make_model(n_frames=2, storage=True)
    binding = task_specification(kb, "I-W-F-#1").actions[0].bindings[0]
    query = f"SELECT ?element ?value WHERE {{ ?element {sparql_path(binding.path)} ?value }}"
    el = robotized_tasks(model)[0].elements[0].iri
    rows = list(model.query(query, initBindings={"element": el}))
    assert [str(r[1]).rsplit("/", 1)[-1] for r in rows] == ["frame-pickup"]  # type: ignore[index]


def test_an_unknown_specification_id_is_an_error_listing_the_known_ones(kb: Graph) -> None:
    with pytest.raises(KnowledgeBaseError) as err:
        task_specification(kb, "I-W-F-#7", task="T1")
    text = str(err.value)
    assert "task T1 names task specification id 'I-W-F-#7'" in text
    assert "I-W-F-#1, I-W-F-#2, L-M-#1" in text


def test_an_action_whose_skill_does_not_exist_names_the_file_and_the_action(tmp_path: Path) -> None:
    ext = _extension(tmp_path, """
kb:X-1 a kbp:TaskSpecification ; kbp:specificationId "X-#1" ; kbp:hasAction kb:X-1-a1 .
kb:X-1-a1 a kbp:Action ; kbp:order 1 ; rdfs:label "fly to the roof" ; kbp:usesSkill kb:FLY-1 .
""")
    with pytest.raises(KnowledgeBaseError) as err:
        task_specification(load_kb([ext]), "X-#1")
    text = str(err.value)
    assert str(ext) in text and "kb:X-1-a1" in text and "kb:FLY-1" in text and "not a skill" in text
    assert "fix:" in text and "NV-1" in text


def test_a_binding_path_with_an_undeclared_property_names_the_file_and_the_property(tmp_path: Path) -> None:
    ext = _extension(tmp_path, """
kb:X-2 a kbp:TaskSpecification ; kbp:specificationId "X-#2" ; kbp:hasAction kb:X-2-a1 .
kb:X-2-a1 a kbp:Action ; kbp:order 1 ; rdfs:label "go" ; kbp:usesSkill kb:NV-1 ; kbp:hasBinding kb:X-2-b .
kb:X-2-b a kbp:InputBinding ; kbp:bindsInput kb:NV-1-destination ; kbp:pathStart kbp:StartAtElement ;
    kbp:bindingPath ( kbp:storedIn ext:pickupSpot ) .
""")
    with pytest.raises(KnowledgeBaseError) as err:
        task_specification(load_kb([ext]), "X-#2")
    text = str(err.value)
    assert str(ext) in text and "undeclared property ext:pickupSpot" in text and "kb:X-2-b" in text


def test_an_action_that_leaves_a_model_input_of_its_skill_unbound_is_an_error(tmp_path: Path) -> None:
    ext = _extension(tmp_path, """
kb:X-3 a kbp:TaskSpecification ; kbp:specificationId "X-#3" ; kbp:hasAction kb:X-3-a1 .
kb:X-3-a1 a kbp:Action ; kbp:order 1 ; rdfs:label "go" ; kbp:usesSkill kb:NV-1 .
""")
    with pytest.raises(KnowledgeBaseError) as err:
        task_specification(load_kb([ext]), "X-#3")
    assert "does not bind its model input 'destination'" in str(err.value)
    assert str(ext) in str(err.value)


def test_a_binding_that_is_not_a_shacl_path_is_an_error(tmp_path: Path) -> None:
    ext = _extension(tmp_path, """
kb:X-4 a kbp:TaskSpecification ; kbp:specificationId "X-#4" ; kbp:hasAction kb:X-4-a1 .
kb:X-4-a1 a kbp:Action ; kbp:order 1 ; rdfs:label "go" ; kbp:usesSkill kb:NV-1 ; kbp:hasBinding kb:X-4-b .
kb:X-4-b a kbp:InputBinding ; kbp:bindsInput kb:NV-1-destination ; kbp:bindingPath [ rdfs:label "oops" ] .
""")
    with pytest.raises(KnowledgeBaseError, match="not a SHACL property path"):
        task_specification(load_kb([ext]), "X-#4")


def test_a_syntax_error_in_a_knowledge_base_extension_names_the_file_and_line(tmp_path: Path) -> None:
    ext = _extension(tmp_path, "kb:X a kbp:Skill ;\n kbp:skillId \"X\" \n kb:oops .\n")
    with pytest.raises(RdfSyntaxError) as err:
        load_kb([ext])
    assert str(ext) in str(err.value)


def test_a_knowledge_base_extension_is_traced_to_its_own_file(tmp_path: Path) -> None:
    ext = Path(__file__).parent / "kb_extension" / "fixing_point.ttl"
    kb = load_kb([ext])
    where = source_of(kb, URIRef("https://example.org/kb-extension#MM-R-1-fixingPoint")) or ""
    assert where.endswith("kb_extension/fixing_point.ttl")
    assert "ontology/kb/skills.ttl" in (source_of(kb, KB["MM-R-1"]) or "")
    assert kb.value(KB["MM-R-1"], KBP.skillId) == Literal("MM-R-1")
