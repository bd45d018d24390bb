"""B1, element order and the stack: elements of one storage are taken from the top of their stack."""

from __future__ import annotations

from pathlib import Path

from rdflib import Graph, Literal, URIRef

from kb_fixtures import BASE, frame_gid, make_model
from kbplanner.core.iris import element_iri, task_iri
from kbplanner.core.vocab import KBP
from kbplanner.model.dates import parse_date
from kbplanner.planning.element_order import RULE_NEAREST, RULE_SEQUENCE, RULE_STACK, element_order
from kbplanner.planning.manipulation import refine_plan
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project
from kbplanner.world.build import build_world
from kbplanner.world.maps import storey_map
from sim_project_factory import DATE, make_sim_project


def _frames(n: int) -> list[URIRef]:
    return [element_iri(BASE, frame_gid(i)) for i in range(1, n + 1)]


def test_the_nearest_rule_gives_way_to_the_stack_top_first() -> None:
    g = make_model(4, storage=True)  # frame 1 nearest the pickup but at the bottom (stackIndex 0)
    f = _frames(4)
    order = element_order(g, task_iri(BASE, "T1"))
    assert order.elements == (f[3], f[2], f[1], f[0])
    assert order.rule.startswith(RULE_NEAREST) and order.rule.endswith(RULE_STACK)


def test_the_stack_keeps_the_nearest_order_where_it_allows_it() -> None:
    g = make_model(4, storage=True)
    f = _frames(4)
    for el, index in zip(f, (2, 3, 1, 0), strict=True):  # frame 2 on top, then 1, 3, 4
        g.set((el, KBP.stackIndex, Literal(index)))
    assert element_order(g, task_iri(BASE, "T1")).elements == (f[1], f[0], f[2], f[3])


def test_elements_without_a_stack_index_lie_on_top_as_the_world_stacks_them() -> None:
    g = make_model(3, storage=True)
    f = _frames(3)
    g.remove((f[0], KBP.stackIndex, None))  # the world puts unindexed elements on top
    order = element_order(g, task_iri(BASE, "T1"))
    assert order.elements[0] == f[0]
    assert order.elements[1:] == (f[2], f[1])


def test_a_work_sequence_wins_over_the_stack_between_sequenced_elements() -> None:
    g = make_model(3, storage=True)
    f = _frames(3)
    for el, seq in zip(f, (1, 2, 3), strict=True):  # bottom first: B4 reports the pick with the fix
        g.add((el, KBP.workSequence, Literal(seq)))
    order = element_order(g, task_iri(BASE, "T1"))
    assert order.elements == tuple(f)
    assert order.rule == RULE_SEQUENCE


def test_an_unsequenced_element_on_top_goes_before_a_sequenced_one_below_it() -> None:
    g = make_model(3, storage=True)
    f = _frames(3)
    g.add((f[1], KBP.workSequence, Literal(1)))  # frame 3 (unsequenced) lies on it
    order = element_order(g, task_iri(BASE, "T1"))
    assert order.elements == (f[2], f[1], f[0])
    assert RULE_STACK in order.rule


def test_elements_in_different_storages_do_not_constrain_each_other() -> None:
    g: Graph = make_model(2, storage=True)
    f = _frames(2)
    other = URIRef(f"{BASE}site/other-storage")
    g.set((f[0], KBP.storedIn, other))
    order = element_order(g, task_iri(BASE, "T1"), robot_start=(5.5, 4.5))  # the other has no pickup
    assert order.elements == (f[0], f[1])  # nearest first (0 m from the start), each alone on its stack
    assert RULE_STACK not in order.rule


def test_without_a_work_sequence_b4_picks_the_stack_from_the_top(tmp_path: Path) -> None:
    """The small executor project with its kbp:workSequence removed: P1 lies on P2 (nearest P2 first
    would leave P1 on it); the stack order makes both installable (P3 is out of reach anyway)."""
    make_sim_project(tmp_path)
    project = Project.load(tmp_path, scenario="stored")
    project.model.remove((None, KBP.workSequence, None))
    world = build_world(project, parse_date(DATE))
    plan = plan_task(project, world=world)
    assert [e.label for e in plan.elements][:2] == ["Panel P1", "Panel P2"]
    refined = refine_plan(plan, world, seed=3, grid=storey_map(world).grid)
    ok = {e.label: all(s.feasible for s in refined.steps_for(e.iri)) for e in refined.elements}
    assert ok == {"Panel P1": True, "Panel P2": True, "Panel P3": False}
