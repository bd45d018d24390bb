"""B5 navigation's grid route searches (simulation/grid_yardstick.py, corridor_cells.py): the cheaper
searches of session 15 give the very answers of the searches they replace - the line of sight checked
coarsely first (``grid_yardstick._farthest_visible``) and the corridor's distance to the grid path on
the path's grown bounding box (``corridor_cells.corridor_box``), on random grids and the yardstick's own
cell paths."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from kbplanner.simulation import grid_yardstick
from kbplanner.simulation.corridor_cells import corridor_box
from kbplanner.world.occupancy import OccupancyGrid


def _farthest_visible_in_full(pts: list[tuple[float, float]], i: int, free: np.ndarray,
                              g: OccupancyGrid) -> int:
    """The former search: every candidate's line sampled in full, 32 candidates per query."""
    ny, nx = free.shape
    a = pts[i]
    j = len(pts) - 1
    while j > i + 1:
        cands = range(j, max(i + 1, j - 32), -1)
        xs, ys, counts = [], [], []
        for k in cands:
            b = pts[k]
            n = max(1, math.ceil(math.hypot(b[0] - a[0], b[1] - a[1]) / (g.resolution / 2)))
            u = np.linspace(0.0, 1.0, n + 1)
            xs.append(a[0] + u * (b[0] - a[0]))
            ys.append(a[1] + u * (b[1] - a[1]))
            counts.append(n + 1)
        x, y = np.concatenate(xs), np.concatenate(ys)
        ix = np.floor((x - g.origin[0]) / g.resolution).astype(np.int64)
        iy = np.floor((y - g.origin[1]) / g.resolution).astype(np.int64)
        ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        ok[ok] = free[iy[ok], ix[ok]]
        seen = np.logical_and.reduceat(ok, np.concatenate([[0], np.cumsum(counts)[:-1]]))
        hit = np.flatnonzero(seen)
        if hit.size:
            return cands[int(hit[0])]
        j = cands[-1] - 1
    return i + 1


def _random_free(rng: np.random.Generator) -> np.ndarray:
    ny, nx = int(rng.integers(20, 90)), int(rng.integers(20, 120))
    free = np.ones((ny, nx), dtype=bool)
    for _ in range(int(rng.integers(3, 25))):
        y, x = rng.integers(0, ny), rng.integers(0, nx)
        if rng.random() < 0.5:
            free[y : y + rng.integers(1, 30), x : x + rng.integers(1, 3)] = False
        else:
            free[y : y + rng.integers(1, 3), x : x + rng.integers(1, 40)] = False
    return free


@pytest.mark.parametrize("seed", range(10))
def test_the_coarse_first_line_of_sight_gives_the_full_searchs_points(seed: int) -> None:
    rng = np.random.default_rng(seed)
    met = 0
    for _ in range(6):
        free = _random_free(rng)
        g = OccupancyGrid(~free, origin=(float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3))),
                          resolution=float(rng.choice([0.05, 0.1, 0.037])))
        cells = np.argwhere(free)
        s, t = (tuple(int(v) for v in cells[rng.integers(len(cells))]) for _ in range(2))
        path = grid_yardstick._dijkstra_cells(free, s, t)  # type: ignore[arg-type]
        if path is None or len(path) < 3:
            continue
        # the yardstick's points: the cells' centres, the ends anywhere in their cells
        pts = [g.center_of(x, y) for y, x in path]
        pts[0] = (pts[0][0] + float(rng.uniform(-0.4, 0.4)) * g.resolution, pts[0][1])
        pts[-1] = (pts[-1][0], pts[-1][1] + float(rng.uniform(-0.4, 0.4)) * g.resolution)
        for i in range(len(pts) - 1):
            want = _farthest_visible_in_full(pts, i, free, g)
            assert grid_yardstick._farthest_visible(pts, i, free, g) == want, (seed, i)
            met += want > i + 1
    assert met > 0


def test_lines_through_a_thin_gap_and_off_the_grid() -> None:
    """A wall one cell thick that a coarse sample can step over: the full samples decide."""
    free = np.ones((30, 60), dtype=bool)
    free[:, 30] = False
    free[14, 30] = True  # a one-cell gap
    g = OccupancyGrid(~free, origin=(0.0, 0.0), resolution=0.1)
    pts = [(0.5 + 0.1 * k, 1.45) for k in range(50)] + [(5.5, 0.2), (7.0, 1.45)]
    for i in range(len(pts) - 1):
        assert grid_yardstick._farthest_visible(pts, i, free, g) == _farthest_visible_in_full(pts, i, free, g)


def _corridor_on_the_whole_grid(shape: tuple[int, int], path: list[tuple[int, int]], reach: float
                                ) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """The former corridor: the distance transform of the whole grid, then the corridor's bounding box."""
    off = np.ones(shape, dtype=bool)
    ys, xs = zip(*path, strict=True)
    off[list(ys), list(xs)] = False
    near = ndimage.distance_transform_edt(off) <= reach
    rows, cols = np.flatnonzero(near.any(axis=1)), np.flatnonzero(near.any(axis=0))
    y0, y1, x0, x1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    return near[y0:y1, x0:x1], (y0, y1, x0, x1)


@pytest.mark.parametrize("seed", range(8))
def test_the_corridor_on_the_paths_box_is_the_whole_grids(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(25):
        shape = (int(rng.integers(1, 60)), int(rng.integers(1, 80)))
        free = _random_free(rng)[: shape[0], : shape[1]] if rng.random() < 0.5 else np.ones(shape, dtype=bool)
        shape = free.shape
        cells = np.argwhere(free)
        if len(cells) == 0:
            continue
        s, t = (tuple(int(v) for v in cells[rng.integers(len(cells))]) for _ in range(2))
        path = grid_yardstick._dijkstra_cells(free, s, t) or [s]  # type: ignore[arg-type]
        reach = float(rng.choice([0.0, 1.0, 2.0, 3.5, 10.0, 0.5 / 0.05, 0.5 / 0.037, 1e-9]))
        near, box = corridor_box(shape, path, reach)  # type: ignore[arg-type]
        near0, box0 = _corridor_on_the_whole_grid(shape, path, reach)  # type: ignore[arg-type]
        assert box == box0
        assert np.array_equal(near, near0)
