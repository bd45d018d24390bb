"""Navigation (B5): the fast motion check and the lazy walled-off question give the answers of the former
code (a verbatim copy here) on random maps and on motions recorded from planner runs."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from kbplanner.simulation import cell_path, navigation
from kbplanner.simulation.motion_check import ExactMotion, probe_fractions
from kbplanner.simulation.nav_path import NavPath, NavSettings, Pose2D, failed_path
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

_PI = math.pi
_TAU = 2 * math.pi


def former_free6(m: ExactMotion, a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> bool:
    """ExactMotion.free6 as it was before the quick accept and the middle-first samples."""
    inv_res, ox, oy, nx, ny, w, n_bins, plane, free = (m.inv_res, m.ox, m.oy, m.nx, m.ny, m.w, m.n_bins,
                                                       m.plane, m.free)
    floor = math.floor
    t0 = float(a2)
    d = (float(b2) - t0 + _PI) % _TAU - _PI
    bx, by = b0 - a0, b1 - a1
    n = max(2, math.ceil(max(abs(bx), abs(by)) * inv_res / 2))
    for i in itertools.chain((n // 2, n), range(1, n)):
        u = i / n
        ix = floor((a0 + u * bx - ox) * inv_res)
        iy = floor((a1 + u * by - oy) * inv_res)
        if not (0 <= ix < nx and 0 <= iy < ny):
            return False
        if free[(floor((t0 + u * d) / w + 0.5) % n_bins) * plane + iy * nx + ix] != 1:
            return False
    cuts = [0.0]
    if d != 0.0:
        k0 = floor(t0 / w + 0.5)
        k1 = floor((t0 + d) / w + 0.5)
        borders = range(k0, k1) if d > 0 else range(k0 - 1, k1 - 1, -1)
        cuts += [((k + 0.5) * w - t0) / d for k in borders]
    cuts.append(1.0)
    ax, ay = (a0 - ox) * inv_res, (a1 - oy) * inv_res
    dx, dy = (b0 - ox) * inv_res - ax, (b1 - oy) * inv_res - ay
    ua = 0.0
    for ub in cuts[1:]:
        base = (floor((t0 + 0.5 * (ua + ub) * d) / w + 0.5) % n_bins) * plane
        x0, y0, x1, y1 = ax + ua * dx, ay + ua * dy, ax + ub * dx, ay + ub * dy
        ua = ub
        if x0 > x1:
            x0, y0, x1, y1 = x1, y1, x0, y0
        ixa, ixb = floor(x0), floor(x1)
        if ixa < 0 or ixb >= nx:
            return False
        if x1 > x0:
            slope = (y1 - y0) / (x1 - x0)
            for ix in range(ixa, ixb + 1):
                ya = y0 + ((ix if ix > x0 else x0) - x0) * slope
                yb = y0 + ((ix + 1 if ix + 1 < x1 else x1) - x0) * slope
                if ya > yb:
                    ya, yb = yb, ya
                lo, hi = floor(ya), floor(yb)
                if lo < 0 or hi >= ny:
                    return False
                if lo == hi:
                    if free[base + lo * nx + ix] != 1:
                        return False
                elif 0 in free[base + lo * nx + ix : base + hi * nx + ix + 1 : nx]:
                    return False
        else:
            lo, hi = (floor(y0), floor(y1)) if y0 <= y1 else (floor(y1), floor(y0))
            if lo < 0 or hi >= ny:
                return False
            for ix in range(ixa, ixb + 1):
                if 0 in free[base + lo * nx + ix : base + hi * nx + ix + 1 : nx]:
                    return False
    return True


def random_space(seed: int, density: float, read_only: bool) -> ConfigurationSpace:
    """A 4 x 3 m site of random blocks (``density`` of the cells seed one), walls all round."""
    rng = np.random.default_rng(seed)
    occ = np.zeros((60, 80), dtype=bool)
    for y, x in zip(*np.nonzero(rng.random(occ.shape) < density), strict=True):
        occ[y : y + int(rng.integers(1, 6)), x : x + int(rng.integers(1, 6))] = True
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    grid = OccupancyGrid(occ, origin=(-0.5, 0.25), resolution=0.05)
    fp = Footprint((Rect(0.0, 0.0, float(rng.uniform(0.2, 0.7)), float(rng.uniform(0.1, 0.4))),))
    cs = ConfigurationSpace.build(grid, fp, 36)
    if read_only:
        cs.free.setflags(write=False)
    return cs


def random_motions(rng: np.random.Generator, count: int) -> list[tuple[float, ...]]:
    out = []
    for _ in range(count):
        a = (float(rng.uniform(-0.7, 3.7)), float(rng.uniform(0.05, 3.4)), float(rng.uniform(-4, 4)))
        scale = float(rng.choice([0.02, 0.1, 0.4, 1.5]))
        b = (a[0] + float(rng.normal(0, scale)), a[1] + float(rng.normal(0, scale)),
             float(rng.uniform(-4, 4)) if rng.random() < 0.7 else a[2])
        out.append((*a, *b))
    return out


def test_the_samples_are_every_sample_once() -> None:
    for n in range(2, 400):
        got = probe_fractions(n)
        assert sorted(got) == [i / n for i in range(1, n + 1)]
        assert got[:2] == ((n // 2) / n, 1.0)


@pytest.mark.parametrize(("seed", "density", "read_only"),
                         [(1, 0.002, True), (2, 0.01, False), (3, 0.015, True), (4, 0.0, False)])
def test_the_fast_motion_check_answers_as_the_former_one(seed: int, density: float, read_only: bool) -> None:
    cs = random_space(seed, density, read_only)
    m = ExactMotion(cs)
    rng = np.random.default_rng(100 + seed)
    answers = []
    for motion in random_motions(rng, 4000):
        want = former_free6(m, *motion)
        assert m.free6(*motion) == want, motion
        answers.append(want)
    assert any(answers) and not all(answers)


def test_the_fast_motion_check_answers_as_the_former_one_on_a_planners_motions() -> None:
    cs = random_space(5, 0.004, True)
    seen: list[tuple[float, ...]] = []
    fast = ExactMotion.free6

    def recording(self: ExactMotion, *motion: float) -> bool:
        seen.append(motion)
        return fast(self, *motion)

    ExactMotion.free6 = recording  # type: ignore[method-assign]
    try:
        rng = np.random.default_rng(5)
        xs, ys, ts = rng.uniform(-0.4, 3.4, 400), rng.uniform(0.3, 3.2, 400), rng.uniform(-3, 3, 400)
        poses = [p for p in ((float(x), float(y), float(t)) for x, y, t in zip(xs, ys, ts, strict=True))
                 if cs.is_free(*p)]
        for k in range(4):
            navigation.plan_path(cs, poses[2 * k], poses[2 * k + 1], settings=NavSettings(seed=k + 1))
    finally:
        ExactMotion.free6 = fast  # type: ignore[method-assign]
    m = ExactMotion(cs)
    assert len(seen) > 100
    assert [m.free6(*motion) for motion in seen] == [former_free6(m, *motion) for motion in seen]


def test_a_free_motion_joins_its_end_cells(  # the reason a found path needs no walled-off question
) -> None:
    cs = random_space(6, 0.01, True)
    m = ExactMotion(cs)
    rng = np.random.default_rng(6)
    free = 0
    for motion in random_motions(rng, 3000):
        if not m.free6(*motion):
            continue
        free += 1
        ends = [motion[:3], motion[3:]]
        for diagonal in (True, False):
            a, b = cs.components_of(ends, diagonal=diagonal)
            assert a == b > 0, motion
    assert free > 100


def eager(cs: ConfigurationSpace, start: Pose2D, goal: Pose2D, settings: NavSettings) -> NavPath:
    """plan_path with the walled-off question asked before planning, as it was."""
    if cs.is_free(*start) and cs.is_free(*goal) and not navigation._connected(cs, start, goal):
        return failed_path("no path: the goal is walled off from the start for this footprint",
                           settings.planner, cs.footprint.name)
    return navigation.plan_path(cs, start, goal, settings=settings)


@pytest.mark.parametrize("ask_after", [50, navigation.WALLED_OFF_AFTER_CHECKS])
def test_the_lazy_walled_off_question_gives_the_results_of_the_eager_one(
        ask_after: int, monkeypatch: pytest.MonkeyPatch) -> None:
    occ = np.zeros((60, 80), dtype=bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    occ[:, 38:41] = True  # a wall across the site: west and east apart...
    occ[20:28, 38:41] = False  # ...but for a door in it
    closed = occ.copy()
    closed[20:28, 38:41] = True
    occ[40:43, 40:] = True  # a closed room in the east
    occ[43:, 60:63] = True
    monkeypatch.setattr(navigation, "WALLED_OFF_AFTER_CHECKS", ask_after)
    fp = Footprint((Rect(0.0, 0.0, 0.4, 0.25),), name="small")
    rng = np.random.default_rng(8)
    kinds = set()
    for cells in (occ, closed):
        cs = ConfigurationSpace.build(OccupancyGrid(cells, origin=(0.0, 0.0), resolution=0.05), fp, 36)
        for k in range(8):
            start = (float(rng.uniform(0.3, 1.7)), float(rng.uniform(0.3, 2.7)), float(rng.uniform(-3, 3)))
            goal = (float(rng.uniform(2.2, 3.7)), float(rng.uniform(0.3, 2.7)), float(rng.uniform(-3, 3)))
            settings = NavSettings(seed=k + 1, max_motion_checks=4000)
            got = navigation.plan_path(cs, start, goal, settings=settings)
            want = eager(cs, start, goal, settings)
            assert (got.status, got.reason, got.poses, got.planner) == (want.status, want.reason, want.poses,
                                                                       want.planner)
            kinds.add("walled" if "walled off" in got.reason else got.status)
    assert {"walled", "ok"} <= kinds


def test_a_walled_off_query_stops_once_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    occ = np.zeros((60, 80), dtype=bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    occ[:, 38:41] = True
    cs = ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05),
                                  Footprint((Rect(0.0, 0.0, 0.4, 0.25),)), 36)
    checks = 0
    fast = ExactMotion.free6

    def counting(self: ExactMotion, *motion: float) -> bool:
        nonlocal checks
        checks += 1
        return fast(self, *motion)

    monkeypatch.setattr(ExactMotion, "free6", counting)
    monkeypatch.setattr(navigation, "WALLED_OFF_AFTER_CHECKS", 300)
    path = navigation.plan_path(cs, (1.0, 1.5, 0.0), (3.0, 1.5, 0.0), settings=NavSettings(time_limit_s=60.0))
    assert not path.ok and "walled off" in path.reason
    assert 300 <= checks < 400  # the planner ends the iteration it is in, then stops


def test_the_validator_alarm_stops_the_planner_where_a_python_condition_does(
        monkeypatch: pytest.MonkeyPatch) -> None:
    import time

    from ompl import base as ob

    def former_run(ss, validator, limit, deadline, walled_off):  # type: ignore[no-untyped-def]
        """The termination condition as it was: a Python function asked at every iteration."""
        def stop() -> bool:
            return (validator.calls >= limit or time.perf_counter() > deadline
                    or (walled_off is not None and validator.calls >= navigation.WALLED_OFF_AFTER_CHECKS
                        and walled_off()))
        return ss.solve(ob.PlannerTerminationCondition(stop))

    occ = np.zeros((60, 100), dtype=bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    occ[:, 48:52] = True
    occ[26:36, 48:52] = False  # a 0.5 m door
    cs = ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05),
                                  Footprint((Rect(0.0, 0.0, 0.5, 0.3),)), 36)
    cs.free.setflags(write=False)
    checks = 0
    fast = ExactMotion.free6

    def counting(self: ExactMotion, *motion: float) -> bool:
        nonlocal checks
        checks += 1
        return fast(self, *motion)

    monkeypatch.setattr(ExactMotion, "free6", counting)
    monkeypatch.setattr(navigation, "WALLED_OFF_AFTER_CHECKS", 150)
    outcomes = set()
    for seed, budget, cells in itertools.product((1, 2), (40, 200, 1500, 400_000), (True, False)):
        got = []
        for run in (navigation._run, former_run):
            monkeypatch.setattr(navigation, "_run", run)
            monkeypatch.setattr(cell_path, "_ROUTES", {})  # count the cell path's checks in both runs
            checks = 0
            path = navigation.plan_path(cs, (0.8, 0.8, 0.3), (4.2, 2.2, 2.0),
                                        settings=NavSettings(seed=seed, max_motion_checks=budget,
                                                             cell_fallback=cells))
            got.append((path.status, path.reason, path.poses, checks))
        assert got[0] == got[1], (seed, budget, cells)
        outcomes.add(got[0][0] + ("+cells" if "cell search" in got[0][1] else ""))
    assert outcomes == {"ok", "ok+cells", "failed"}
