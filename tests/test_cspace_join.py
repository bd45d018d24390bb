"""Joined poses decided on a part of the grid (B4 carry-leg check): the same answers as the whole space."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kbplanner.planning.base_poses import escapes
from kbplanner.planning.carry_reach import CarryReach
from kbplanner.planning.plan_model import Pose2
from kbplanner.world import cspace_cache
from kbplanner.world.cspace_join import PartJoin, part_free
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid

RES = 0.05
BINS = 24
FOOTPRINTS = [Footprint((Rect(0, 0, 0.5, 0.3),), "base"),
              Footprint((Rect(0, 0, 0.5, 0.3), Rect(0.1, 0.0, 0.2, 1.1)), "carried across")]


def _rooms(seed: int, shape: tuple[int, int] = (100, 140)) -> OccupancyGrid:
    """Random walls with random openings, blocks and specks: spaces with several components."""
    rng = np.random.default_rng(seed)
    occ = np.zeros(shape, dtype=bool)
    for _ in range(3):
        if rng.random() < 0.5:
            x = int(rng.integers(10, shape[1] - 10))
            occ[:, x] = True
            y = int(rng.integers(0, shape[0] - 20))
            occ[y:y + int(rng.integers(6, 24)), x] = False
        else:
            y = int(rng.integers(10, shape[0] - 10))
            occ[y, :] = True
            x = int(rng.integers(0, shape[1] - 20))
            occ[y, x:x + int(rng.integers(6, 24))] = False
    for _ in range(6):
        y, x = int(rng.integers(0, shape[0])), int(rng.integers(0, shape[1]))
        occ[y:y + int(rng.integers(1, 12)), x:x + int(rng.integers(1, 12))] = True
    occ |= rng.random(shape) < 0.003
    return OccupancyGrid(occ, origin=(-1.3, 2.15), resolution=RES)


def _poses(g: OccupancyGrid, rng: np.random.Generator, n: int) -> list[tuple[float, float, float]]:
    ny, nx = g.shape
    xs = g.origin[0] + rng.uniform(0, nx * RES, n)
    ys = g.origin[1] + rng.uniform(0, ny * RES, n)
    yaws = rng.uniform(-math.pi, math.pi, n)
    return [(float(x), float(y), float(t)) for x, y, t in zip(xs, ys, yaws, strict=True)]


@pytest.mark.parametrize("diagonal", [True, False])
@pytest.mark.parametrize("seed", range(6))
def test_a_part_decides_as_the_whole_space(seed: int, diagonal: bool) -> None:
    cspace_cache.clear()
    g = _rooms(seed)
    rng = np.random.default_rng(100 + seed)
    decided = {True: 0, False: 0}
    for fp in FOOTPRINTS:
        whole = ConfigurationSpace.build(g, fp, BINS)
        free = np.argwhere(whole.free)  # pairs of free poses, most questions are about those
        for _ in range(25):
            picks = free[rng.integers(0, len(free), 2)]
            pair = [(*g.center_of(int(c[2]), int(c[1])), float(c[0]) * 2 * math.pi / BINS) for c in picks]
            pair += _poses(g, rng, 1)  # and now and then a blocked one
            a, b = pair[0], pair[int(rng.integers(1, 3))]
            part = PartJoin(g, fp, [a[:2], b[:2]], margin_cells=int(rng.integers(0, 25)), diagonal=diagonal,
                            n_bins=BINS)
            got = part.joined(a, b)
            want = whole.joined(a, b, diagonal=diagonal)
            if got is not None:
                assert got == want, (fp.name, a, b)
                decided[got] += 1
            assert part.joined(a, (a[0] + 50.0, a[1], a[2])) is None  # a pose off the part
    assert decided[True] > 0 and decided[False] > 0


@pytest.mark.parametrize("seed", range(5))
def test_part_free_is_the_whole_build_on_the_part(seed: int) -> None:
    """The part's free maps, computed on the part grown by the kernels' reach only, are the whole grid's
    build cut to the part: inside, at the grid's edges (cells off it occupied), for a footprint whose
    kernels repeat half a turn later (kept once) and for 72 bins."""
    g = _rooms(seed)
    rng = np.random.default_rng(200 + seed)
    ny, nx = g.shape
    symmetric = Footprint((Rect(0, 0, 0.6, 0.4),), "symmetric")
    for fp, bins in [(FOOTPRINTS[0], BINS), (FOOTPRINTS[1], BINS), (symmetric, BINS), (FOOTPRINTS[1], 72)]:
        whole = ConfigurationSpace.build(g, fp, bins)
        for _ in range(3):
            y0, x0 = int(rng.integers(0, ny // 2)), int(rng.integers(0, nx // 2))
            region = (y0, int(rng.integers(y0 + 1, ny + 1)), x0, int(rng.integers(x0 + 1, nx + 1)))
            got = part_free(g, fp, region, bins)
            np.testing.assert_array_equal(got, whole.free[:, region[0]:region[1], region[2]:region[3]])
        edge = (0, ny, nx - 7, nx)  # a strip at the grid's edge: off-grid cells occupied
        np.testing.assert_array_equal(part_free(g, fp, edge, bins), whole.free[:, :, nx - 7:])


@pytest.mark.parametrize("seed", range(4))
def test_the_carry_reach_joins_as_the_window_spaces(seed: int) -> None:
    cspace_cache.clear()
    g = _rooms(seed + 20)
    rng = np.random.default_rng(seed)
    poses = [Pose2(*p) for p in _poses(g, rng, 12)]
    reach = CarryReach(g, FOOTPRINTS, poses[0], (poses[1].x, poses[1].y), margins=(1.0, 2.0, None),
                       n_bins=BINS)
    for i, margin in enumerate(reach.margins):
        win = reach._window(i)
        for k, fp in enumerate(FOOTPRINTS):
            whole = ConfigurationSpace.build(win, fp, BINS)
            for a in (reach.start, *poses[1:4]):
                for b in poses[1:]:
                    want = whole.joined((a.x, a.y, a.yaw), (b.x, b.y, b.yaw), diagonal=True)
                    assert reach._joins(i, k, a, b) == want, (margin, k, a, b)


def test_the_box_test_is_kept_per_cell() -> None:
    g = _rooms(3)
    cs = ConfigurationSpace.build(g, FOOTPRINTS[0], BINS)
    free = np.argwhere(cs.free)
    rng = np.random.default_rng(0)
    pairs = [tuple((*g.center_of(int(c[2]), int(c[1])), float(c[0]) * 2 * math.pi / BINS)
                   for c in free[rng.integers(0, len(free), 2)]) for _ in range(10)]
    first = [cs.joined(a, b, diagonal=True) for a, b in pairs]
    assert cs.near_memo or cs.memo
    again = ConfigurationSpace.build(g, FOOTPRINTS[0], BINS)
    assert first == [again.joined(a, b, diagonal=True) for a, b in pairs]
    assert first == [cs.joined(a, b, diagonal=True) for a, b in pairs]


@pytest.mark.parametrize("seed", range(4))
def test_the_carry_reach_reaches_as_with_whole_windows(seed: int) -> None:
    """Reachability by changing footprint on the way (joint components): parts first, as the levels."""
    cspace_cache.clear()
    g = _rooms(seed + 40)
    rng = np.random.default_rng(seed)
    poses = [Pose2(*p) for p in _poses(g, rng, 16)]
    around = (poses[1].x, poses[1].y)
    fast = CarryReach(g, FOOTPRINTS, poses[0], around, margins=(1.5, None), n_bins=BINS)
    for goal in poses[1:]:
        whole = CarryReach(g, FOOTPRINTS, poses[0], around, margins=(1.5, None), n_bins=BINS)
        whole._parts.reaches = lambda _start, _goal: False  # type: ignore[method-assign]
        whole._parts.joins = lambda _i, _k, _a, _b: None  # type: ignore[method-assign]
        for i in range(2):  # no parts: every join on the whole windows
            for k in range(2):
                whole._space(i, k).labels_and_roots(True)
        assert fast.reaches(goal) == whole.reaches(goal), goal
        assert fast.way(goal) == whole.way(goal), goal


def _escapes_by_labels(grid: OccupancyGrid, fp: Footprint, pose: Pose2, radius_m: float) -> bool:
    """:func:`escapes` as it was: the whole window labelled, the pose's component against the band."""
    res = grid.resolution
    ny, nx = grid.shape
    ix0 = max(0, math.floor((pose.x - radius_m - grid.origin[0]) / res))
    iy0 = max(0, math.floor((pose.y - radius_m - grid.origin[1]) / res))
    ix1 = min(nx, math.ceil((pose.x + radius_m - grid.origin[0]) / res))
    iy1 = min(ny, math.ceil((pose.y + radius_m - grid.origin[1]) / res))
    sub = OccupancyGrid(grid.occupied[iy0:iy1, ix0:ix1], origin=(grid.origin[0] + ix0 * res,
                        grid.origin[1] + iy0 * res), resolution=res)
    cs = ConfigurationSpace.build(sub, fp, BINS)
    labels = cs.components()
    root = cs.component_of(labels, pose.x, pose.y, pose.yaw)
    if root == 0:
        return False
    band = math.ceil((fp.radius_m + 2 * res) / res)
    border = np.zeros(labels.shape[1:], dtype=bool)
    border[:, :band] |= ix0 > 0
    border[:, -band:] |= ix1 < nx
    border[:band, :] |= iy0 > 0
    border[-band:, :] |= iy1 < ny
    return bool((labels[:, border] == root).any())


@pytest.mark.parametrize("seed", range(5))
def test_escapes_straight_out_as_by_labels(seed: int) -> None:
    cspace_cache.clear()
    g = _rooms(seed + 60)
    rng = np.random.default_rng(seed)
    seen = set()
    for fp in FOOTPRINTS:
        for x, y, yaw in _poses(g, rng, 30):
            pose = Pose2(x, y, yaw)
            radius = float(rng.uniform(0.6, 2.5))
            want = _escapes_by_labels(g, fp, pose, radius)
            assert escapes(g, fp, pose, radius_m=radius, n_bins=BINS) == want, (fp.name, pose, radius)
            seen.add(want)
    assert seen == {True, False}
