"""``kbplanner init`` names what takes the floor around a frame no base pose can reach (issue 10,
scale/init_floor.py): on the split-level fixture the frame in the corner between the raised floor and the
south wall gets both, with distances and the share of occupied floor, and a fix that says no order frees
it."""

from __future__ import annotations

from pathlib import Path

import pytest

from ifc_traits import write_traits
from kbplanner.cli import main
from kbplanner.model.project_data import ProjectData
from kbplanner.scale import init_site as site
from kbplanner.scale.init_floor import FLOOR_FIX, floor_around, with_floor
from kbplanner.scale.init_plan_check import Failure
from kbplanner.scale.init_proposals import UNBOUND
from kbplanner.world.build import world_of
from kbplanner.world.maps import storey_map


@pytest.mark.slow  # init and a world: about 35 s on a busy machine
def test_the_corner_frame_of_the_split_level_names_the_raised_floor_and_the_wall(tmp_path: Path) -> None:
    ifc = tmp_path / "split.ifc"
    write_traits(ifc)
    project = tmp_path / "p"
    assert main(["init", str(ifc), "--out", str(project), "--no-plan-check"]) == 0
    world = world_of(ProjectData.load(project, scenario="storage-outside"), task_id=site.FRAME_TASK)
    m = storey_map(world)
    corner = min(world.task_elements, key=lambda e: e.installed_pose.y if e.installed_pose else 1e9)
    assert corner.installed_pose is not None
    text = floor_around(world, m, corner.installed_pose.x, corner.installed_pose.y)
    assert text.startswith(f"within 1.5 m of its installed pose ({corner.installed_pose.x:.2f}, "
                           f"{corner.installed_pose.y:.2f}) ")
    assert "Split-level floor (raised floor, top +1.44 m) 0.10 m away" in text
    assert "Exterior wall L1 south (Wall)" in text
    why = ("step 28 (MM-R-1 install frame): installed pose out of reach from 0 free base pose(s) tried: "
           + UNBOUND)
    other = Failure("urn:x", "x", "step 4 (MM-G-1 pick frame): payload", "lighter")
    got = with_floor(world, m, [Failure(corner.iri, corner.label, why, "free the floor"), other], UNBOUND)
    assert got[0].reason == f"{why}; {text}"
    assert got[0].fix == f"free the floor; {FLOOR_FIX}"
    assert got[1] == other
