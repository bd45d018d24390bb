"""Human-robot safety: reactive workers, speed and separation monitoring, contact as events."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from kbplanner.simulation.crowd import Crowd
from kbplanner.simulation.executor import simulate
from kbplanner.simulation.separation import WORKER_RADIUS_M, SsmParameters, rects_distance
from kbplanner.simulation.skills import ExecSettings
from kbplanner.simulation.social_force import Obstacle
from kbplanner.simulation.workers import RouteStop, WorkerMotion, WorkerSpec
from kbplanner.world.footprint import Rect
from sim_project_factory import load_sim_case

REPO = Path(__file__).resolve().parents[1]
ROBOT = [Rect(0.0, 0.0, 0.99, 0.67), Rect(0.0, 0.0, 0.72, 2.4)]  # base + a frame carried across it


def test_protective_separation_distance_and_its_inverse() -> None:
    p = SsmParameters()
    assert float(p.separation_m(0.0)) == pytest.approx(1.6 * 0.14 + 1.08 + 0.1)
    for sep in (1.5, 2.0, 3.0):
        assert float(p.separation_m(p.allowed_speed(sep))) == pytest.approx(sep)
    assert p.allowed_speed(1.0) == 0.0


def _walker(seed_iri: str, a: tuple[float, float], b: tuple[float, float]) -> WorkerSpec:
    return WorkerSpec(
        seed_iri,
        "Walker",
        "carpenter",
        1.2,
        (RouteStop("a", "A", a[0], a[1], 1.0), RouteStop("b", "B", b[0], b[1], 1.0)),
    )


@pytest.mark.parametrize("seed", range(20))
def test_a_worker_walking_straight_at_the_robot_walks_round_it_never_into_it(seed: int) -> None:
    crowd = Crowd([_walker("urn:w", (-6.0, 0.1), (6.0, -0.1))], None, seed=seed)
    robot = Obstacle((0.0, 0.0, 0.0), ROBOT)
    closest, xs = math.inf, []
    for _ in range(600):
        crowd.step(robot)
        d, _, _ = rects_distance(crowd.pos[:, 0], crowd.pos[:, 1], robot.pose, robot.rects)
        closest = min(closest, float(d[0]))
        xs.append(float(crowd.pos[0, 0]))
    assert closest >= WORKER_RADIUS_M
    assert max(xs) > 3.0 or min(xs) < -3.0  # they got past (or were walking the other way first)


def test_the_crowd_is_deterministic_and_a_worker_s_draws_do_not_depend_on_the_others() -> None:
    specs = [_walker("urn:w1", (-6.0, 0.0), (6.0, 0.0)), _walker("urn:w2", (0.0, -6.0), (0.0, 6.0))]
    runs = []
    for _ in range(2):
        c = Crowd(specs, None, seed=4)
        for _ in range(300):
            c.step(Obstacle((0.0, 0.0, 0.0), ROBOT))
        runs.append(c.pos.copy())
    assert np.array_equal(runs[0], runs[1])
    alone = Crowd(specs[:1], None, seed=4)
    both = Crowd(specs, None, seed=4)
    assert alone.agents[0].v0 == both.agents[0].v0 and alone.agents[0].k == both.agents[0].k


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    c = load_sim_case(tmp_path_factory.mktemp("safety") / "p", high_panel=False)
    c.refined.keep_first(1)
    return c


def _run(case, out: Path, **kw):  # type: ignore[no-untyped-def]
    workers = kw.pop("workers", None)
    return simulate(
        case.project,
        case.refined,
        seed=kw.pop("seed", 3),
        out_dir=out,
        world=case.world,
        grid=case.grid,
        settings=ExecSettings(keyframes=False, **kw),
        workers=workers,
    )


@pytest.mark.parametrize("seed", [3, 11])
def test_with_monitoring_the_reactive_worker_crossing_the_robot_s_way_is_never_touched(
    case, tmp_path: Path, seed: int
) -> None:  # type: ignore[no-untyped-def]
    r = _run(case, tmp_path / "run", seed=seed)
    s = r.metrics["safety"]
    assert s["collisions"] == 0 and not [e for e in r.events if e["kind"] == "collision"]
    assert s["min_separation_m"] is not None and s["min_separation_m"] > 0
    assert r.all_installed
    check = subprocess.run(
        [sys.executable, str(REPO / "benchmarks" / "safety_check.py"), str(tmp_path / "run")],
        capture_output=True,
        text=True,
    )
    assert check.returncode == 0, check.stdout


def _standing(x: float, y: float) -> WorkerMotion:
    spec = WorkerSpec("urn:test:stander", "Stander", "carpenter", 1.0, (RouteStop("s", "S", x, y, 1e6),))
    return WorkerMotion(spec, [(0.0, 1e6, np.array([[x, y]]), np.zeros(1))])


def test_without_monitoring_driving_into_a_worker_is_a_collision_event_and_counted(
    case, tmp_path: Path
) -> None:  # type: ignore[no-untyped-def]
    # a worker standing (not yielding) on the way the robot drives alone, 2 m from its start
    free = _run(case, tmp_path / "free", monitoring="off", workers=[])
    row = next(
        line.split(",")
        for line in (tmp_path / "free" / "trajectories.csv").read_text().splitlines()[1:]
        if float(line.split(",")[0]) >= 10.0
        and (float(line.split(",")[1]) - 6.5) ** 2 + (float(line.split(",")[2]) + 5.0) ** 2 > 4.0
    )
    wx, wy = float(row[1]), float(row[2])
    del free
    r = _run(case, tmp_path / "off", monitoring="off", workers=[_standing(wx, wy)])
    hits = [e for e in r.events if e["kind"] == "collision"]
    assert hits, "the robot drove through the worker without a collision event"
    d = hits[0]["details"]
    assert d["worker"] == "stander" and d["cause"] == "robot moved into the worker"
    assert "robot_speed_mps" in d and "worker_speed_mps" in d and hits[0]["t_s"] > 0
    assert r.metrics["safety"]["collisions"] == len(hits)
    assert r.metrics["safety"]["min_separation_m"] == 0.0
    on = _run(case, tmp_path / "on", workers=[_standing(wx, wy)])
    assert on.metrics["safety"]["collisions"] == 0
    assert on.metrics["safety"]["stops"] + on.metrics["safety"]["slowdowns"] > 0
    metrics = json.loads((tmp_path / "off" / "metrics.json").read_text())
    assert metrics["safety"]["collision_events"][0]["worker"] == "stander"


def test_workers_on_another_floor_are_out_of_the_robot_s_hazard_scope(
    case, tmp_path: Path
) -> None:  # type: ignore[no-untyped-def]
    # the same task with the ground 3 m below the robot's storey (the robot works upstairs) and a
    # worker standing on the ground right under the robot's way: nobody yields, stops or collides
    from dataclasses import replace

    from kbplanner.simulation.sim_env import FLOOR_GAP_M

    upstairs = replace(case, world=replace(case.world, ground_z=case.world.ground_z - 3.0))
    _run(upstairs, tmp_path / "free", workers=[])
    row = next(
        line.split(",")
        for line in (tmp_path / "free" / "trajectories.csv").read_text().splitlines()[1:]
        if float(line.split(",")[0]) >= 10.0
        and (float(line.split(",")[1]) - 6.5) ** 2 + (float(line.split(",")[2]) + 5.0) ** 2 > 4.0
    )
    r = _run(upstairs, tmp_path / "under", workers=[_standing(float(row[1]), float(row[2]))])
    s = r.metrics["safety"]
    assert FLOOR_GAP_M < 3.0 and s["dz_m"] == 3.0 and s["workers_off_robot_floor"] == 1
    assert s["collisions"] == 0 and s["stops"] == 0 and s["slowdowns"] == 0
    assert not [e for e in r.events if e["kind"] in ("collision", "stop", "slow", "make_way")]
    assert s["min_separation_m"] >= 3.0 - WORKER_RADIUS_M
    assert r.all_installed
    # the robot drives exactly as with nobody on site
    def robot(run: str) -> list[list[str]]:
        rows = (tmp_path / run / "trajectories.csv").read_text().splitlines()
        return [line.split(",")[:13] for line in rows]

    assert robot("under") == robot("free")
    # on the robot's own floor the same worker stops it (the ground-floor behaviour is unchanged)
    ground = _run(case, tmp_path / "ground", workers=[_standing(float(row[1]), float(row[2]))])
    assert ground.metrics["safety"]["workers_off_robot_floor"] == 0
    assert ground.metrics["safety"]["stops"] + ground.metrics["safety"]["slowdowns"] > 0


def _corridor_with_alcove():  # type: ignore[no-untyped-def]
    from kbplanner.world.occupancy import OccupancyGrid

    res, x0, y0 = 0.05, -7.0, -2.0
    ys, xs = np.mgrid[0:140, 0:280]
    cx, cy = x0 + (xs + 0.5) * res, y0 + (ys + 0.5) * res
    free = (np.abs(cy) < 1.2) | ((cx > 2.0) & (cx < 4.0) & (cy < 4.5))  # a corridor and an alcove off it
    return OccupancyGrid(occupied=~free, origin=(x0, y0), resolution=res)


def test_a_worker_waiting_in_the_robot_s_way_makes_way_and_goes_back_only_once_the_robot_has_passed() -> None:
    from kbplanner.simulation.crowd import MAKE_WAY_MAX_HOLD_S

    spec = WorkerSpec("urn:test:waiter", "Waiter", "carpenter", 1.2, (RouteStop("s", "S", 3.0, 0.0, 1e6),))
    crowd = Crowd([spec], _corridor_with_alcove(), seed=3)
    robot = Obstacle((-2.0, 0.0, 0.0), ROBOT[:1])
    crowd.step(robot)
    path = np.array([(x, 0.0) for x in np.arange(-2.0, 6.01, 0.25)])
    comfort = crowd.agents[0].params.comfort_distance_m
    spot = crowd.make_way(0, path, 2.0)
    # into the alcove, off the path by the clearance asked for plus the worker's comfort distance
    assert spot is not None and 2.0 < spot[0] < 4.0 and spot[1] >= 2.0 + comfort
    for _ in range(int(30 / crowd.dt)):
        crowd.step(robot)
    assert math.hypot(crowd.pos[0, 0] - spot[0], crowd.pos[0, 1] - spot[1]) < 0.3
    # a robot that stands still (longer than the old fixed 60 s) is not passed: the worker keeps waiting
    for _ in range(int(120 / crowd.dt)):
        crowd.step(robot)
    assert math.hypot(crowd.pos[0, 0] - spot[0], crowd.pos[0, 1] - spot[1]) < 0.3
    # the robot drives its path at 0.3 m/s: the worker is still aside while it is at the alcove
    x = -2.0
    while x < 6.0:
        x = min(6.0, x + 0.03)
        crowd.step(Obstacle((x, 0.0, 0.0), ROBOT[:1]))
        if abs(x - 3.0) < 1.0:
            assert math.hypot(crowd.pos[0, 0] - 3.0, crowd.pos[0, 1]) > 2.0 + comfort - 0.3
    for _ in range(int(30 / crowd.dt)):
        crowd.step(Obstacle((6.0 + 2.0 + comfort, 0.0, 0.0), ROBOT[:1]))  # gone on past the path's end
    assert crowd.t < MAKE_WAY_MAX_HOLD_S  # released because the robot passed, not by the time bound
    assert math.hypot(crowd.pos[0, 0] - 3.0, crowd.pos[0, 1]) < 0.3  # back at their stop


def test_the_way_to_a_make_way_spot_never_passes_the_robot() -> None:
    # the worker stands just past the robot's nose; the nearest clear spots beyond the robot are not taken
    spec = WorkerSpec("urn:test:waiter", "Waiter", "carpenter", 1.2, (RouteStop("s", "S", 1.6, 0.0, 1e6),))
    crowd = Crowd([spec], _corridor_with_alcove(), seed=3)
    robot = Obstacle((0.0, 0.0, 0.0), ROBOT[:1])
    crowd.step(robot)
    path = np.array([(x, 0.0) for x in np.arange(0.0, 6.01, 0.25)])
    spot = crowd.make_way(0, path, 1.5)
    assert spot is not None
    p = crowd.pos[0]
    f = np.linspace(0.0, 1.0, 200)
    leg = p[None, :] + f[:, None] * (np.array(spot) - p)[None, :]
    d, _, _ = rects_distance(leg[:, 0], leg[:, 1], robot.pose, robot.rects)
    assert float(d.min()) >= min(WORKER_RADIUS_M + 0.3, float(d[0])) - 1e-9


def test_nowhere_better_to_stand_is_no_move() -> None:
    spec = WorkerSpec("urn:test:waiter", "Waiter", "carpenter", 1.2, (RouteStop("s", "S", 0.0, 0.0, 1e6),))
    from kbplanner.world.occupancy import OccupancyGrid

    occ = np.ones((40, 40), dtype=bool)
    occ[18:22, :] = False  # a 0.2 m wide slot along x: every spot stays on the path
    crowd = Crowd([spec], OccupancyGrid(occupied=occ, origin=(-1.0, -1.0), resolution=0.05), seed=1)
    path = np.array([(x, 0.0) for x in np.arange(-1.0, 1.01, 0.1)])
    assert crowd.make_way(0, path, 1.0) is None
    assert crowd.agents[0].anchor == (0.0, 0.0)


@pytest.fixture(scope="module")
def door_case(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    """The small project with its carpenter standing (reactive) just outside the door, on the robot's way."""
    from rdflib import Literal

    from kbplanner.core.vocab import KBP

    c = load_sim_case(tmp_path_factory.mktemp("door") / "p", high_panel=False)
    c.refined.keep_first(1)
    g = c.project.model
    for stop in set(g.objects(None, KBP.routeStop)):
        g.set((stop, KBP.dwellTime, Literal(1e6)))
        for location in g.objects(stop, KBP.location):
            for pose in g.objects(location, KBP.installedPose):
                g.set((pose, KBP.x, Literal(DOOR_STANDER[0])))
                g.set((pose, KBP.y, Literal(DOOR_STANDER[1])))
    return c


DOOR_STANDER = (2.5, -0.9)  # 0.75 m south of the 0.9 m door (x 2.05-2.95, wall y 0-0.3), on the way in


def test_a_worker_standing_in_the_robot_s_way_costs_a_bounded_wait_and_no_stop_and_go(
    door_case, tmp_path: Path
) -> None:  # type: ignore[no-untyped-def]
    free = _run(door_case, tmp_path / "free", workers=[])
    assert free.all_installed
    r = _run(door_case, tmp_path / "run")
    assert r.all_installed and r.metrics["safety"]["collisions"] == 0
    # bounded: the robot reaches its goal after a wait, not a stop-and-go until the step gives up
    assert r.sim_time_s - free.sim_time_s < ExecSettings().replan_after_s + 60.0
    stops = [e for e in r.events if e["kind"] == "stop"]
    resumes = [e for e in r.events if e["kind"] == "resume"]
    assert stops and len(stops) <= 4
    # hysteresis: no resume before the hold time, none with the person within stop distance + margin
    margin, hold = 0.0, 0.0  # kbp:resumeMargin, kbp:resumeHoldTime defaults of NV-2 (ontology/kb/skills.ttl)
    limit = max(e["details"]["stop_distance_m"] for e in stops) + margin
    for e in resumes:
        assert e["details"]["waited_s"] >= hold - 1e-6
        sep = e["details"].get("separation_m")
        assert sep is None or sep > limit - 1e-3


def test_a_worker_pushed_to_and_fro_against_a_wall_by_the_robot_still_walks_to_the_make_way_spot() -> None:
    # the worker stands at a wall; the stopped robot (carrying a frame) is diagonally in front, so its push
    # is into the wall and away from the spot: they slide to and fro along the wall, never slow, never nearer
    from kbplanner.world.occupancy import OccupancyGrid

    res, x0, y0 = 0.05, -6.0, -6.0
    cy = y0 + (np.mgrid[0:240, 0:240][0] + 0.5) * res
    grid = OccupancyGrid(occupied=~(cy < 0.0), origin=(x0, y0), resolution=res)  # a wall along y = 0
    spec = WorkerSpec("urn:test:waiter", "Waiter", "carpenter", 1.2, (RouteStop("s", "S", 0.0, -0.3, 1e6),))
    crowd = Crowd([spec], grid, seed=3)
    robot = Obstacle((1.3, -1.8, 1.75), ROBOT)
    crowd.step(robot)
    path = np.array([(x, -1.8) for x in np.arange(1.3, -5.0, -0.25)])  # the robot drives on to the west
    spot = crowd.make_way(0, path, 2.0)
    assert spot is not None and spot[0] > 3.3  # east along the wall, past the robot's end of the path
    for _ in range(int(30 / crowd.dt)):
        crowd.step(robot)
    assert math.hypot(crowd.pos[0, 0] - spot[0], crowd.pos[0, 1] - spot[1]) < 0.3
    d, _, _ = rects_distance(crowd.pos[:1, 0], crowd.pos[:1, 1], robot.pose, robot.rects)
    assert float(d[0]) >= WORKER_RADIUS_M
