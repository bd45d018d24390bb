"""B4 feedback on B1: an element whose base poses are blocked by elements installed before it goes first.

B1 (:mod:`kbplanner.planning.element_order`) orders by the knowledge base (work sequence, distance,
stack); only B4 (:mod:`kbplanner.planning.manipulation`) knows where the robot must stand to install
each element. When B4 finds no base pose to install an element E (no free base pose, the robot shut
in, no carry footprint or arm pose that fits) while elements installed earlier stand within
``RefineSettings.blocking_radius_m`` of E's installed pose, E is moved before the earliest of them
(:func:`blocked_move`, :func:`move_before`) and B4 runs again; when B4 names the element installed
before that closes E's carry way (:mod:`~kbplanner.planning.carry_reach`, wherever it stands), E is
moved before that one; the new order is kept only when more
elements become installable. The stack still holds (the elements lying on E at its storage move with
it, in their order), and an explicit ``kbp:workSequence`` wins: an element that carries one is
neither moved nor passed.

Takes the B1-B3 plan, the plan refined by B4, and the world (for the stack); gives the move (E, X)
and the reordered B1-B3 plan, whose steps are numbered again in the new order.
"""

from __future__ import annotations

import copy
import math
import re
from collections.abc import Collection, Mapping

from kbplanner.core.vocab import KBP
from kbplanner.planning.carry_reach import blocker_in
from kbplanner.planning.plan_model import Plan
from kbplanner.world.world_types import World

KIND_RELEASE = str(KBP.MoveManipulatorAndRelease)

#: Install failures that elements standing around the installed pose can cause.
BLOCKED = re.compile(r"free base pose|walled off|load turned|shut in|carry footprint|into the robot|"
                     r"place unreachable|pre-place|orient pose|retract pose")


def installable(plan: Plan) -> int:
    """How many elements of the plan have every step feasible."""
    return sum(1 for e in plan.elements if all(s.feasible for s in plan.steps_for(e.iri)))


def _blocked(refined: Plan, iri: str) -> bool:
    steps = refined.steps_for(iri)
    bad = next((s for s in steps if not s.feasible), None)
    return bad is not None and bad.skill_kind == KIND_RELEASE and bool(BLOCKED.search(bad.reason or ""))


def _named_blocker(refined: Plan, iri: str) -> str | None:
    """The element B4 named as closing the carry way of ``iri``
    (:func:`~kbplanner.planning.carry_reach.blocker_in`)."""
    bad = next((s for s in refined.steps_for(iri) if not s.feasible), None)
    return blocker_in(bad.reason or "") if bad is not None else None


def stack_above(world: World) -> dict[str, set[str]]:
    """Per task element, the elements lying on it at its storage (higher in the same stack, as the
    world stacks them: by ``kbp:stackIndex``, elements without one on top by IRI)."""

    def level(i: int | None, name: str) -> tuple[bool, int, str]:
        return (i is None, i or 0, name)

    out: dict[str, set[str]] = {}
    for me in world.task_elements:
        mine = level(me.stack_index, me.iri)
        out[me.iri] = {e.iri for e in world.task_elements if me.storage is not None and
                       e.storage == me.storage and e.iri != me.iri and level(e.stack_index, e.iri) > mine}
    return out


def blocked_move(plan: Plan, refined: Plan, above: Mapping[str, set[str]], radius_m: float,
                 tried: set[tuple[str, str]]) -> tuple[str, str] | None:
    """The first (element, before) move that may unblock an element, or None (see module docstring).

    ``above``: per element, the elements lying on it (:func:`stack_above`).
    """
    order = [e.iri for e in plan.elements]
    info = {e.iri: e for e in plan.elements}
    ok = {e.iri: all(s.feasible for s in refined.steps_for(e.iri)) for e in refined.elements}
    for n, iri in enumerate(order):
        me = info[iri]
        if me.work_sequence is not None or not _blocked(refined, iri):
            continue
        lying_on = above.get(iri, set())
        named = _named_blocker(refined, iri)
        if (named is not None and named in order[:n] and named not in lying_on and ok.get(named)
                and (iri, named) not in tried):  # not before an element lying on it: the stack forbids it
            k = order.index(named)
            if info[named].work_sequence is None and not any(
                    info[i].work_sequence is not None for i in order[k:n] if i in lying_on):
                return iri, named  # the element B4 found closing the carry way
        for k, other in enumerate(order[:n]):
            o = info[other]
            if not ok.get(other) or o.work_sequence is not None or (iri, other) in tried or other in lying_on:
                continue
            if any(info[i].work_sequence is not None for i in order[k:n] if i in lying_on):
                continue  # an element lying on it that would move with it has a work sequence
            near = math.hypot(o.installed_pose.x - me.installed_pose.x,
                              o.installed_pose.y - me.installed_pose.y) <= radius_m
            if not near:
                continue
            return iri, other  # with the elements lying on it (move_before), so the stack holds
    return None


def move_before(plan: Plan, iri: str, before: str, lying_on: Collection[str] = ()) -> Plan:
    """A copy of the B1-B3 ``plan`` with element ``iri`` (and its steps) moved before ``before``.

    Elements of ``lying_on`` (those lying on it at its storage) that come between ``before`` and it
    move with it, in their order, so that the stack still holds.
    """
    out = copy.deepcopy(plan)
    order = [e.iri for e in out.elements]
    k, n = order.index(before), order.index(iri)
    group = [i for i in order[k:n] if i in lying_on] + [iri]
    order = [i for i in order if i not in group]
    k = order.index(before)
    order[k:k] = group
    by_iri = {e.iri: e for e in out.elements}
    out.elements = [by_iri[i] for i in order]
    steps = []
    for i in order:
        steps.extend(out.steps_for(i))
    for n, s in enumerate(steps, start=1):
        s.step = n
    out.steps = steps
    return out
