"""Query results kept per unedited loaded graph (kbplanner.core.graph_memo): the same answers as the
per-element queries, and none kept once the graph is edited."""

from __future__ import annotations

from rdflib import Graph, Literal, URIRef

from kb_fixtures import BASE, frame_gid, make_model
from kbplanner.core.graph_memo import memo
from kbplanner.core.iris import element_iri
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.binding_paths import (
    AlternativePath,
    InversePath,
    PredicatePath,
    RepeatPath,
    SequencePath,
)
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.material_flow import material_flow, without_repetition
from kbplanner.knowledge.task_specs import robotized_tasks, task_specification
from kbplanner.model.graph_pickle import note_edits
from kbplanner.planning.skill_inputs import resolve_input


def _noted(graph: Graph) -> Graph:
    copy = Graph()
    for prefix, ns in graph.namespaces():
        copy.bind(prefix, ns, override=True)
    for t in graph:
        copy.add(t)
    note_edits(copy)  # as a project load with the cache on
    return copy


def test_only_a_graph_noting_its_edits_and_unedited_has_a_memo() -> None:
    plain = make_model(2, storage=True)
    assert memo(plain) is None
    noted = _noted(plain)
    kept = memo(noted)
    assert kept is not None and memo(noted) is kept
    noted.add((URIRef("urn:x:a"), KBP.x, Literal(1.0)))
    assert memo(noted) is None  # edited: every caller queries again


def test_memoised_answers_equal_the_per_element_queries() -> None:
    kb = load_kb()
    plain = make_model(3, storage=True)
    noted = _noted(plain)
    assert memo(noted) is not None
    assert robotized_tasks(noted) == robotized_tasks(plain)
    assert robotized_tasks(noted) == robotized_tasks(noted)  # from the memo
    flow = material_flow(kb, task_specification(kb, "I-W-F-#1"))
    assert flow.every_focus
    frames = [element_iri(BASE, frame_gid(i)) for i in (1, 2, 3)] + [URIRef("urn:x:not-an-element")]
    got = [flow.storages(noted, el) for el in frames]
    assert got == [flow.storages(plain, el) for el in frames]
    assert got[0] and got[-1] == []
    spec = task_specification(kb, "I-W-F-#1")
    bindings = [b for a in spec.actions for b in a.bindings]
    assert bindings
    for b in bindings:
        for el in frames:
            assert resolve_input(noted, b, el) == resolve_input(plain, b, el)


def test_a_path_that_may_have_zero_length_is_not_batched() -> None:
    p, q = PredicatePath(KBP.storedIn), PredicatePath(KBP.pickupLocation)
    assert without_repetition(SequencePath((p, InversePath(q))))
    assert without_repetition(AlternativePath((p, q)))
    assert not without_repetition(SequencePath((p, RepeatPath(q, "*"))))
    assert not without_repetition(RepeatPath(p, "+"))


def test_a_task_specification_is_read_once_per_unedited_knowledge_base() -> None:
    plain = load_kb()
    noted = _noted(plain)
    first = task_specification(noted, "I-W-F-#1")
    assert task_specification(noted, "I-W-F-#1") is first  # kept: robot selection, world and B1-B3 alike
    assert first == task_specification(plain, "I-W-F-#1")  # the same specification as the plain query
    assert task_specification(plain, "I-W-F-#1") is not task_specification(plain, "I-W-F-#1")
    noted.add((URIRef("urn:x:a"), KBP.x, Literal(1.0)))
    assert task_specification(noted, "I-W-F-#1") is not first  # edited: read again
