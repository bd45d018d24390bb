"""B4 moves a blocked install first, on a real geometry: a generated one-unit building planned without
its kbp:workSequence. The stack order alone leaves frame F06 with no free base pose (the frames of the
other storage, installed before it, stand where the robot must be); B4 moves it, with the frames lying
on it, before them, and all 14 frames become installable. About 40 s (two B4 runs): slow."""

from __future__ import annotations

from pathlib import Path

import pytest

from kbplanner.core.vocab import KBP
from kbplanner.planning.manipulation import refine_plan
from kbplanner.planning.plan_model import Plan
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project
from kbplanner.scale.building_generator import generate_building
from kbplanner.world.build import build_world
from kbplanner.world.maps import storey_map

pytestmark = pytest.mark.slow


def test_an_install_blocked_by_frames_installed_before_it_is_moved_first(tmp_path: Path) -> None:
    generate_building(tmp_path / "b", storeys=1, units_per_storey=1)
    project = Project.load(tmp_path / "b", scenario="storage-in-units")
    project.model.remove((None, KBP.workSequence, None))
    world = build_world(project, project.world_date(None), None)
    plan = plan_task(project, world=world)
    grid = storey_map(world).grid

    def installable(p: Plan) -> int:
        return sum(1 for e in plan.elements if all(s.feasible for s in p.steps_for(e.iri)))

    kept = refine_plan(plan, world, seed=7, grid=grid, reorder=False)
    assert installable(kept) == 13
    blocked = next(s for s in kept.steps if not s.feasible)
    assert "F06" in next(e.label for e in plan.elements if e.iri == blocked.element)
    assert "free base pose" in (blocked.reason or "")
    moved = refine_plan(plan, world, seed=7, grid=grid)
    assert installable(moved) == 14
    assert ("B4 moved Stud frame panel L01-U01-F06 (with the 5 element(s) lying on it) before"
            in moved.order_rule)
    order = [e.label[-3:] for e in moved.elements]
    assert order.index("F01") < order.index("F06") < order.index("F09")  # the stack still holds
