"""``kbplanner init`` abandons a storage proposal that can no longer beat the best (issue 10): B4's ``stop``
hook (planning/manipulation.refine_plan) and init's use of it (scale/init_plan_check.check_scenario).

Fast: on the small simulation project, a plan whose first panel is too heavy is abandoned after that panel
when the best so far installs as many as the plan can at most, and a hook that never stops gives the plan
without it. Slow: on the split-level fixture, init's check of a placement that cannot beat the best is
abandoned before its last frame, and a check that is not abandoned is the check without the hook.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from kbplanner.planning.install_order import installable
from kbplanner.planning.manipulation import STOPPED, refine_plan
from kbplanner.planning.plan_model import Plan, SkillCall
from kbplanner.scale.init_plan_check import cannot_beat
from sim_project_factory import SimCase, load_sim_case

SEED = 3


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory) -> SimCase:
    return load_sim_case(tmp_path_factory.mktemp("simproj"), seed=SEED, high_panel=False)


def _heavy_first(case: SimCase) -> Plan:
    """The case's plan with the panel B4 refines first too heavy for the arm: it cannot be installed."""
    first = case.plan.steps[0].element
    heavy = [dataclasses.replace(e, mass_kg=30.0) if e.iri == first else e for e in case.plan.elements]
    return dataclasses.replace(case.plan, elements=heavy)


def test_a_plan_that_cannot_beat_the_best_is_abandoned_after_its_first_failure(case: SimCase) -> None:
    plan = _heavy_first(case)
    total = len(plan.elements)
    assert total >= 2
    full = refine_plan(plan, case.world, seed=SEED, grid=case.grid)
    assert installable(full) < total  # the heavy panel (and the panels under it) fail
    asked: list[int] = []

    def stop(p: Plan) -> bool:
        asked.append(installable(p))
        return cannot_beat(total - 1, p)  # the best so far installs total - 1: one failure is enough

    stopped = refine_plan(plan, case.world, seed=SEED, grid=case.grid, stop=stop)
    assert asked == [total - 1]  # asked once, after the first element
    assert stopped.notes[-1] == f"{STOPPED}1 of {total} elements"
    first = plan.steps[0].element
    assert stopped.steps_for(first) == full.steps_for(first)
    rest = [s for s in stopped.steps if s.element != first]
    assert rest and all(s.base_pose is None and not s.arm_poses for s in rest)  # not refined


def test_a_hook_that_never_stops_gives_the_plan_without_it(case: SimCase) -> None:
    plan = _heavy_first(case)
    full = refine_plan(plan, case.world, seed=SEED, grid=case.grid)
    asked: list[int] = []

    def never(p: Plan) -> bool:
        asked.append(1)
        return cannot_beat(-1, p)

    kept = refine_plan(plan, case.world, seed=SEED, grid=case.grid, stop=never)
    assert len(asked) == len(plan.elements)
    assert kept.to_json() == full.to_json()


def test_cannot_beat_counts_the_elements_with_an_infeasible_step(case: SimCase) -> None:
    plan = case.refined
    n = installable(plan)
    assert n == len(plan.elements)
    assert cannot_beat(n, plan) and not cannot_beat(n - 1, plan)
    one = dataclasses.replace(plan, steps=[dataclasses.replace(s, feasible=False) if i == 0 else s
                                           for i, s in enumerate(plan.steps)])
    assert cannot_beat(n - 1, one) and not cannot_beat(n - 2, one)


@pytest.mark.slow
def test_init_abandons_a_placement_that_cannot_beat_the_best_and_keeps_the_others_whole(
        tmp_path: Path) -> None:
    from ifc_traits import write_traits
    from kbplanner.cli import main
    from kbplanner.scale import init_site as site
    from kbplanner.scale.init_plan_check import check_scenario

    ifc = tmp_path / "split.ifc"
    write_traits(ifc)
    project = tmp_path / "p"
    assert main(["init", str(ifc), "--out", str(project), "--no-plan-check"]) == 0
    full = check_scenario(project, "storage-inside", site.FRAME_TASK, 0)
    assert full.plan is not None and not full.abandoned
    b4 = installable(full.plan)  # what B4 alone installs (the check adds the way to each pickup)
    assert b4 < full.total  # measured: the first inside placement does not install every frame
    done: list[int] = []
    best = check_scenario(project, "storage-inside", site.FRAME_TASK, 0,
                          progress=lambda _iri, n, _total: done.append(n), beat=b4)
    assert best.abandoned.startswith("abandoned after ")
    assert f"(the best so far installs {b4})" in best.abandoned
    assert best.installable <= b4  # never kept over a proposal that installs b4
    assert done[-1] <= full.total
    whole = check_scenario(project, "storage-inside", site.FRAME_TASK, 0, beat=0)
    assert not whole.abandoned
    assert whole.plan is not None
    assert whole.plan.to_json() == full.plan.to_json()
    assert (whole.order, whole.failures) == (full.order, full.failures)


def _free(plan: Plan) -> Plan:
    """The plan without the elements' kbp:workSequence (B4 may reorder them, as in init's check)."""
    return dataclasses.replace(plan, elements=[dataclasses.replace(e, work_sequence=None)
                                               for e in plan.elements])


def _blocked_second(case: SimCase) -> tuple[Plan, str]:
    """The case's refined plan with the install of the element B4 refines second failing as a blocked one
    (no free base pose: the failure B4's install-order feedback answers by moving it earlier)."""
    from kbplanner.planning.manipulation import KIND_RELEASE, elements_in_order

    plan = _free(case.refined)
    second = elements_in_order(plan)[1]
    steps = [dataclasses.replace(s, feasible=False, reason="installed pose out of reach from 0 free base "
                                 "pose(s) tried: no base pose near the installed pose is free")
             if s.element == second and s.skill_kind == KIND_RELEASE else s for s in plan.steps]
    return dataclasses.replace(plan, steps=steps), second


def test_a_failure_the_reorder_rounds_could_rescue_holds_off_the_stop(case: SimCase) -> None:
    """A proposal whose failed element B4 would move before an element installed earlier (its reorder
    rounds, after the first pass) is not abandoned: the bound cannot tell what those rounds install. A
    failure they cannot answer (a panel too heavy; an element that lies under the one installed before
    it, or carries a kbp:workSequence) still stops it."""
    from kbplanner.planning.install_order import stack_above
    from kbplanner.scale.init_plan_check import Bound, reorderable

    blocked, second = _blocked_second(case)
    plan = _free(case.plan)
    apart = {e.iri: set[str]() for e in plan.elements}  # each element in a stack of its own
    n = len(blocked.elements)
    assert reorderable(plan, blocked, apart) == [second]
    assert reorderable(plan, _free(case.refined), apart) == []  # nothing failed: nothing to rescue
    assert reorderable(plan, blocked, stack_above(case.world)) == []  # the first lies on it
    assert reorderable(case.plan, blocked, apart) == []  # both carry a kbp:workSequence
    beat = n - 1  # the best so far installs all but one: the failure alone would stop the check

    def bound(stacks: dict[str, set[str]] | None) -> Bound:
        b = Bound(beat, plan, case.grid, None, lambda _p, _i: None, stacks)
        b.done = 1  # asked after the second element
        return b

    held = bound(apart)
    assert held(blocked) is False and held.held == [second]
    assert bound(None)(blocked) is True  # B4 without reordering: nothing can rescue it
    first_step = min(t.step for t in blocked.steps_for(second))

    def too_heavy(s: SkillCall) -> SkillCall:  # its first step fails, its install no longer
        if s.element != second:
            return s
        if s.step == first_step:
            return dataclasses.replace(s, feasible=False, reason="too heavy")
        return dataclasses.replace(s, feasible=True, reason=None)

    heavy = dataclasses.replace(blocked, steps=[too_heavy(s) for s in blocked.steps])
    assert bound(apart)(heavy) is True
