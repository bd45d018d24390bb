"""B4 feedback on the order: an element whose install is blocked by elements installed before it moves
before them, unless the stack or an explicit kbp:workSequence forbids it (planning/install_order.py)."""

from __future__ import annotations

import copy

from kbplanner.core.vocab import KBP
from kbplanner.planning.install_order import blocked_move, installable, move_before
from kbplanner.planning.plan_model import ElementInfo, Plan, Pose6, SkillCall

BLOCKED_REASON = ("installed pose out of reach from 0 free base pose(s) tried: no base pose near the "
                  "installed pose is free")
KINDS = (KBP.Navigation, KBP.MoveManipulatorAndGrasp, KBP.NavigationWithObject, KBP.MoveManipulatorAndRelease)


def _plan(xs: dict[str, float], sequences: dict[str, int] | None = None) -> Plan:
    """Elements named by ``xs`` (install x, y = 0), four steps each, in the given order."""
    elements = [ElementInfo(f"urn:{n}", n, n, 5.0, (0.6, 0.09, 2.4), Pose6(x, 0.0, 0.0),
                            Pose6(-5.0, 0.0, 0.5), None, (sequences or {}).get(n)) for n, x in xs.items()]
    steps = [SkillCall(step=4 * i + k + 1, element=e.iri, action=f"urn:a{k}", action_label=f"a{k}",
                       action_order=k + 1, skill=f"urn:s{k}", skill_id=f"S{k}", skill_kind=str(kind))
             for i, e in enumerate(elements) for k, kind in enumerate(KINDS)]
    return Plan("p", None, "T", "", "S", "r", "R", "r.urdf", "rule", elements=elements, steps=steps)


def _refined(plan: Plan, blocked: str, reason: str = BLOCKED_REASON) -> Plan:
    out = copy.deepcopy(plan)
    install = [s for s in out.steps_for(f"urn:{blocked}")
               if s.skill_kind == str(KBP.MoveManipulatorAndRelease)]
    install[0].feasible, install[0].reason = False, reason
    return out


def test_a_blocked_install_moves_before_the_nearest_earlier_neighbour() -> None:
    plan = _plan({"A": 0.0, "B": 10.0, "C": 1.0})  # C is blocked; A stands 1 m from it, B 9 m
    refined = _refined(plan, "C")
    assert installable(refined) == 2
    move = blocked_move(plan, refined, {}, 3.0, set())
    assert move == ("urn:C", "urn:A")
    moved = move_before(plan, *move)
    assert [e.label for e in moved.elements] == ["C", "A", "B"]
    assert [s.step for s in moved.steps] == list(range(1, 13))
    assert [s.element for s in moved.steps[:4]] == ["urn:C"] * 4
    assert [e.label for e in plan.elements] == ["A", "B", "C"]  # the input plan is not changed


def test_no_move_for_a_reason_that_no_neighbour_causes_or_without_a_neighbour() -> None:
    plan = _plan({"A": 0.0, "B": 10.0, "C": 1.0})
    high = _refined(plan, "C", "out of reach from any base pose: the tool would have to be at 3.00 m")
    assert blocked_move(plan, high, {}, 3.0, set()) is None
    far = _plan({"A": 0.0, "B": 10.0, "C": 5.0})
    assert blocked_move(far, _refined(far, "C"), {}, 3.0, set()) is None
    assert blocked_move(plan, _refined(plan, "C"), {}, 3.0, {("urn:C", "urn:A")}) is None  # tried


def test_the_stack_holds_the_elements_lying_on_it_move_with_it() -> None:
    plan = _plan({"A": 0.0, "B": 0.5, "C": 1.0})  # C blocked, A and B near; B lies on C at the storage
    above = {"urn:C": {"urn:B"}}
    move = blocked_move(plan, _refined(plan, "C"), above, 3.0, set())
    assert move == ("urn:C", "urn:A")
    moved = move_before(plan, *move, above["urn:C"])
    assert [e.label for e in moved.elements] == ["B", "C", "A"]  # B is still taken before C
    with_sequence = _plan({"A": 0.0, "B": 0.5, "C": 1.0}, sequences={"B": 2})
    assert blocked_move(with_sequence, _refined(with_sequence, "C"), above, 3.0, set()) is None


def test_an_explicit_work_sequence_wins() -> None:
    plan = _plan({"A": 0.0, "B": 10.0, "C": 1.0}, sequences={"C": 3})
    assert blocked_move(plan, _refined(plan, "C"), {}, 3.0, set()) is None
    plan = _plan({"A": 0.0, "B": 10.0, "C": 1.0}, sequences={"A": 1})
    assert blocked_move(plan, _refined(plan, "C"), {}, 3.0, set()) is None


def test_no_move_before_an_element_lying_on_it() -> None:
    """The element named as closing the carry way, or the only near one, lies on the blocked element at the
    storage: moving it before that one breaks the stack (it raised ValueError in move_before): no move."""
    plan = _plan({"A": 10.0, "B": 0.5, "C": 1.0})  # C blocked; only B is near, and B lies on C
    above = {"urn:C": {"urn:B"}}
    named = _refined(plan, "C", "carry way walled off: ...; the way is open until B is installed (carry way "
                                "closed by urn:B): install this element before B")
    assert blocked_move(plan, named, above, 3.0, set()) is None
    assert blocked_move(plan, _refined(plan, "C"), above, 3.0, set()) is None
    assert blocked_move(plan, _refined(plan, "C"), {}, 3.0, set()) == ("urn:C", "urn:B")  # no stack: moves
