"""Floors on a real two-storey building (issue 11): the robot frames Level 2 while people work on the ground.

A generated 2-storey building (``kbplanner generate-building``) with one more worker, written in Turtle
as a user would: an electrician who walks from the site into the ground floor and stands right under the
robot's Level-2 pickup location. Upstairs, nobody on the ground is in the robot's hazard scope: no stop,
slow-down or make-way, and the robot drives exactly as without the electrician; the workers walk on the
ground floor's map, not the upper storey's (where the site round the building is not floor). Framing
Level 1 with the same electrician, the robot reacts to him.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from kbplanner.cli import main
from kbplanner.scale.building_generator import generate_building

pytestmark = pytest.mark.slow

BASE = "https://w3id.org/kbplanner/data/generated-2x1-s0/"
SPOT_XY = (2.05, 2.0)  # under the Level-2 pickup location of the generated unit (same x, y on Level 1)

ELECTRICIAN = f"""@prefix kbp: <https://w3id.org/kbplanner/ontology#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .

<{BASE}site/electrician-spot> a kbp:Workspace ;
    rdfs:label "Electrician's spot, ground floor living room" ;
    kbp:obstructs false ;
    kbp:sizeX 0.6e0 ; kbp:sizeY 0.6e0 ; kbp:sizeZ 2.0e0 ;
    kbp:installedPose <{BASE}site/electrician-spot-pose> .
<{BASE}site/electrician-spot-pose> a kbp:Pose ;
    kbp:x {SPOT_XY[0]}e0 ; kbp:y {SPOT_XY[1]}e0 ; kbp:z 0.0e0 ;
    kbp:roll 0.0e0 ; kbp:pitch 0.0e0 ; kbp:yaw 0.0e0 .
<{BASE}worker/electrician> a kbp:Worker ;
    rdfs:label "Electrician" ;
    kbp:role "electrician" ;
    kbp:walkingSpeed 1.2e0 ;
    kbp:routeStop <{BASE}worker/electrician-stop-1> .
<{BASE}worker/electrician-stop-1> a kbp:RouteStop ;
    kbp:order 1 ; kbp:location <{BASE}site/electrician-spot> ; kbp:dwellTime 3600.0e0 .
"""


@pytest.fixture(scope="module")
def building(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The generated 2 x 1 building with a second scenario that adds the electrician."""
    root = generate_building(tmp_path_factory.mktemp("up") / "b2x1", storeys=2, units_per_storey=1, seed=0).directory
    (root / "site" / "electrician.ttl").write_text(ELECTRICIAN, encoding="utf-8")
    toml = (root / "project.toml").read_text(encoding="utf-8")
    old = 'overlays = ["scenarios/storage_in_units.ttl", "augmentation/grasp_points.ttl"]'
    assert old in toml
    toml += ('\n[scenarios.with-electrician]\ndescription = "storage in units, an electrician on the ground floor"\n'
             'overlays = ["scenarios/storage_in_units.ttl", "augmentation/grasp_points.ttl", '
             '"site/electrician.ttl"]\n')
    (root / "project.toml").write_text(toml, encoding="utf-8")
    return root


def _simulate(root: Path, out: Path, scenario: str, task: str, n: int) -> tuple[int, dict, list[dict[str, str]]]:  # type: ignore[type-arg]
    code = main(["simulate", str(root), "--scenario", scenario, "--task", task, "--max-elements", str(n),
                 "--no-keyframes", "--seed", "3", "--out", str(out)])
    metrics = json.loads((out / "metrics.json").read_text(encoding="utf-8"))
    with (out / "trajectories.csv").open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return code, metrics, rows


def _events(out: Path) -> list[str]:
    return [json.loads(line)["kind"] for line in (out / "events.jsonl").read_text(encoding="utf-8").splitlines()]


def test_workers_on_the_ground_walk_the_ground_floor_map_while_the_robot_frames_level_2(
        building: Path, tmp_path: Path) -> None:
    from kbplanner.project import Project
    from kbplanner.simulation.floors import walk_grid
    from kbplanner.world.build import build_world
    from kbplanner.world.maps import storey_map

    project = Project.load(building, scenario="with-electrician")
    world = build_world(project, project.world_date(), "T-FRAME-L02")
    upper = storey_map(world).grid
    ground = walk_grid(world, upper)
    assert storey_map(world).storey.label == "Level 2"
    lumber = (-9.0, -6.0)  # the carpenters' lumber storage stands on the site, outside the building
    assert upper.is_occupied(*lumber) and not ground.is_occupied(lumber[0] + 2.5, lumber[1])
    assert ground.free_fraction > 2 * upper.free_fraction

    code, with_e, rows = _simulate(building, tmp_path / "e", "with-electrician", "T-FRAME-L02", 2)
    s = with_e["safety"]
    assert code == 0 and s["workers_off_robot_floor"] == 3 and s["dz_m"] == 3.0
    assert s["collisions"] == 0 and s["stops"] == 0 and s["slowdowns"] == 0
    assert not {"collision", "stop", "slow", "make_way"} & set(_events(tmp_path / "e"))
    # the electrician got to his spot under the robot's pickup location, and the robot went there too
    at_spot = [r for r in rows if (float(r["electrician_x"]) - SPOT_XY[0]) ** 2
               + (float(r["electrician_y"]) - SPOT_XY[1]) ** 2 < 0.5 ** 2]
    assert at_spot
    assert min((float(r["x"]) - SPOT_XY[0]) ** 2 + (float(r["y"]) - SPOT_XY[1]) ** 2 for r in at_spot) < 0.5 ** 2

    # the robot drives exactly as without him
    code, _without, rows_without = _simulate(building, tmp_path / "n", "storage-in-units", "T-FRAME-L02", 2)
    assert code == 0
    robot_cols = ["t_s", "x", "y", "yaw", "q1", "q2", "q3", "q4", "q5", "q6", "carried", "carry_mode", "step"]
    assert [[r[c] for c in robot_cols] for r in rows] == [[r[c] for c in robot_cols] for r in rows_without]


def test_framing_level_1_the_robot_reacts_to_the_same_electrician(building: Path, tmp_path: Path) -> None:
    _code, metrics, _rows = _simulate(building, tmp_path / "g", "with-electrician", "T-FRAME-L01", 1)
    s = metrics["safety"]
    assert s["workers_off_robot_floor"] == 0 and s["collisions"] == 0
    reacted = {"stop", "slow", "make_way"} & set(_events(tmp_path / "g"))
    assert reacted or s["stops"] + s["slowdowns"] > 0
