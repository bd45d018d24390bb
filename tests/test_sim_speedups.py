"""B5 speed-ups that claim identical results: the plain-float paths against the numpy ones."""

from __future__ import annotations

import math

import numpy as np

from kbplanner.simulation import separation
from kbplanner.simulation.separation import rects_distance
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid


def _vectorised(px: np.ndarray, py: np.ndarray, pose: tuple[float, float, float], rects: list[Rect]):
    old = separation.SCALAR_POINTS
    separation.SCALAR_POINTS = -1
    try:
        return rects_distance(px, py, pose, rects)
    finally:
        separation.SCALAR_POINTS = old


def test_point_distance_is_bit_identical_to_the_numpy_path() -> None:
    rng = np.random.default_rng(3)
    rects = [Rect(0.0, 0.0, 0.99, 0.67), Rect(0.4, 0.1, 1.2, 0.3, 0.3), Rect(-0.2, 0.0, 0.5, 2.0, 1.2)]
    for trial in range(300):
        pose = (float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3)), float(rng.uniform(-4, 4)))
        n = int(rng.integers(1, separation.SCALAR_POINTS + 1))
        px, py = rng.uniform(-5, 5, n), rng.uniform(-5, 5, n)
        if trial % 10 == 0:  # points inside and on the axes of a rectangle
            px[0], py[0] = pose[0], pose[1]
        got = rects_distance(px, py, pose, rects[: 1 + trial % 3])
        want = _vectorised(px, py, pose, rects[: 1 + trial % 3])
        for g, w in zip(got, want, strict=True):
            assert g.shape == w.shape
            assert g.tobytes() == w.tobytes()
    d, ux, uy = rects_distance(np.array([2.0]), np.array([0.0]), (0.0, 0.0, 0.0), [Rect(0.0, 0.0, 1.0, 0.6)])
    assert (float(d[0]), float(ux[0]), float(uy[0])) == (1.5, 1.0, 0.0)


def _components_union_find(free: np.ndarray, diagonal: bool) -> np.ndarray:
    """The former implementation of ConfigurationSpace.components (union-find in Python)."""
    from scipy import ndimage

    structure = np.ones((3, 3, 3), dtype=bool) if diagonal else ndimage.generate_binary_structure(3, 1)
    labels, n = ndimage.label(free, structure=structure)
    parent = np.arange(n + 1)

    def find(a: int) -> int:
        while parent[a] != a:
            a = int(parent[a])
        return a

    first, last = labels[0], labels[-1]
    shifts = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1)] if diagonal else [(0, 0)]
    for dy, dx in shifts:
        b = np.roll(np.roll(last, dy, axis=0), dx, axis=1)
        both = (first > 0) & (b > 0)
        for a_lab, b_lab in sorted(set(zip(first[both].tolist(), b[both].tolist(), strict=True))):
            ra, rb = find(a_lab), find(b_lab)
            if ra != rb:
                parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(i) for i in range(n + 1)], dtype=np.int64)
    return np.asarray(roots[labels], dtype=np.int64)


def test_components_equal_the_union_find_labels() -> None:
    from kbplanner.world.footprint import ConfigurationSpace, Footprint
    from kbplanner.world.occupancy import OccupancyGrid

    rng = np.random.default_rng(5)
    for density in (0.3, 0.5, 0.7, 1.0):
        free = rng.random((8, 30, 40)) < density
        grid = OccupancyGrid(np.zeros((30, 40), dtype=bool), origin=(0.0, 0.0), resolution=0.05)
        cs = ConfigurationSpace(grid=grid, footprint=Footprint((Rect(0, 0, 0.1, 0.1),)), free=free)
        for diagonal in (False, True):
            want = _components_union_find(free, diagonal)
            assert np.array_equal(cs.components(diagonal=diagonal), want)
            poses = [(float(x), float(y), float(t)) for x, y, t in
                     zip(rng.uniform(-0.2, 2.2, 50), rng.uniform(-0.2, 1.7, 50), rng.uniform(-4, 4, 50),
                         strict=True)]
            assert cs.components_of(poses, diagonal=diagonal) == [cs.component_of(want, *p) for p in poses]


def test_inlined_motion_check_equals_the_pose_by_pose_check() -> None:
    import itertools
    import math

    from kbplanner.simulation.motion_check import ExactMotion
    from kbplanner.simulation.nav_path import wrap
    from kbplanner.world.footprint import ConfigurationSpace, Footprint
    from kbplanner.world.occupancy import OccupancyGrid

    rng = np.random.default_rng(11)
    occ = rng.random((60, 80)) < 0.02
    grid = OccupancyGrid(occ, origin=(-1.0, -0.5), resolution=0.05)
    cs = ConfigurationSpace.build(grid, Footprint((Rect(0, 0, 0.5, 0.3),)), 36)
    m = ExactMotion(cs)

    def reference(a: tuple[float, float, float], b: tuple[float, float, float]) -> bool:
        t0 = float(a[2])
        d = wrap(float(b[2]) - t0)
        n = max(2, math.ceil(max(abs(b[0] - a[0]), abs(b[1] - a[1])) * m.inv_res / 2))
        for i in (n // 2, n, *range(1, n)):
            u = i / n
            if not m.pose_free(a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]), t0 + u * d):
                return False
        cuts = [0.0]
        if d != 0.0:
            k0, k1 = math.floor(t0 / m.w + 0.5), math.floor((t0 + d) / m.w + 0.5)
            borders = range(k0, k1) if d > 0 else range(k0 - 1, k1 - 1, -1)
            cuts += [((k + 0.5) * m.w - t0) / d for k in borders]
        cuts.append(1.0)
        ax, ay = (a[0] - m.ox) * m.inv_res, (a[1] - m.oy) * m.inv_res
        dx, dy = (b[0] - m.ox) * m.inv_res - ax, (b[1] - m.oy) * m.inv_res - ay
        for ua, ub in itertools.pairwise(cuts):
            k = math.floor((t0 + 0.5 * (ua + ub) * d) / m.w + 0.5) % m.n_bins
            if not m._segment_free(k, ax + ua * dx, ay + ua * dy, ax + ub * dx, ay + ub * dy):
                return False
        return True

    answers = set()
    for _ in range(3000):
        a = (float(rng.uniform(-1.2, 3.2)), float(rng.uniform(-0.7, 2.7)), float(rng.uniform(-4, 4)))
        b = (a[0] + float(rng.normal(0, 0.6)), a[1] + float(rng.normal(0, 0.6)), float(rng.uniform(-4, 4)))
        want = reference(a, b)
        assert m.motion_free(a, b) == want
        answers.add(want)
    assert answers == {True, False}


def _free_maps_linear_fft(grid: OccupancyGrid, footprint: Footprint, n_bins: int) -> np.ndarray:
    """The former ConfigurationSpace.build: a transform long enough for the whole linear correlation."""
    from scipy import fft as sp_fft

    res, width = grid.resolution, 2 * math.pi / n_bins
    kernels = [footprint.kernel(res, k * width - width / 2, k * width + width / 2, 0.0)
               for k in range(n_bins)]
    h = max(k.shape[0] for k in kernels) // 2
    padded = np.pad(grid.occupied, h, constant_values=True).astype(np.float32)
    size = 2 * h + 1
    shape = tuple(sp_fft.next_fast_len(n + size - 1, real=True) for n in padded.shape)
    grid_f = sp_fft.rfft2(padded, shape)
    ny, nx = grid.shape
    free = np.empty((n_bins, ny, nx), dtype=bool)
    for k, kern in enumerate(kernels):
        hk = kern.shape[0] // 2
        full = np.zeros((size, size), dtype=np.float32)
        full[h - hk : h + hk + 1, h - hk : h + hk + 1] = kern
        conv = sp_fft.irfft2(grid_f * sp_fft.rfft2(full[::-1, ::-1], shape), shape)
        free[k] = conv[size - 1 : size - 1 + ny, size - 1 : size - 1 + nx] < 0.5
    return free


def test_configuration_space_by_the_shorter_circular_transform_equals_the_linear_one() -> None:
    rng = np.random.default_rng(11)
    robot = Footprint((Rect(0.0, 0.0, 0.99, 0.67),), name="robot")
    carry = Footprint((Rect(0.0, 0.0, 0.99, 0.67), Rect(0.3, 0.5, 2.4, 0.15, 0.2)), name="carry")
    for trial in range(12):
        ny, nx = int(rng.integers(20, 160)), int(rng.integers(20, 160))
        occ = rng.random((ny, nx)) < (0.02 + 0.02 * (trial % 4))
        occ[rng.integers(0, ny), :] = True  # a wall with a door
        occ[:, rng.integers(0, nx)] = True
        occ[rng.integers(0, ny), rng.integers(0, nx)] = False
        origin = (float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)))
        grid = OccupancyGrid(occ, origin=origin, resolution=0.05)
        fp = robot if trial % 2 else carry
        got = ConfigurationSpace.build(grid, fp, 24).free
        assert got.tobytes() == _free_maps_linear_fft(grid, fp, 24).tobytes()



def _bfs_scipy(free: np.ndarray, src: tuple[int, int, int], dst: tuple[int, int, int]) -> list[int] | None:
    """The former face_path search: scipy's breadth_first_order on the graph of face-adjacent free cells."""
    from scipy import sparse
    from scipy.sparse import csgraph

    index = np.full(free.shape, -1, dtype=np.int64)
    flat = np.flatnonzero(free)
    index.ravel()[flat] = np.arange(len(flat))
    rows, cols = [], []
    for a, b in ((index[:, :, :-1], index[:, :, 1:]), (index[:, :-1, :], index[:, 1:, :]),
                 (index[:-1], index[1:]), (index[-1:], index[:1])):
        both = (a >= 0) & (b >= 0)
        rows.append(a[both])
        cols.append(b[both])
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = sparse.csr_matrix((np.ones(len(r), dtype=np.int8), (r, c)), shape=(len(flat), len(flat)))
    s, d = int(index[src]), int(index[dst])
    _order, pred = csgraph.breadth_first_order(graph, s, directed=False, return_predecessors=True)
    if s != d and pred[d] < 0:
        return None
    nodes = [d]
    while nodes[-1] != s:
        nodes.append(int(pred[nodes[-1]]))
    return [int(v) for v in flat[nodes[::-1]]]


def test_the_cell_search_gives_the_path_of_scipys_breadth_first_search() -> None:
    from kbplanner.simulation.cell_path import bfs_cells

    rng = np.random.default_rng(5)
    met = {True: 0, False: 0}
    for trial in range(300):
        shape = (int(rng.integers(1, 12)), int(rng.integers(1, 20)), int(rng.integers(1, 20)))
        free = rng.random(shape) < rng.uniform(0.45, 0.9)
        cells = np.argwhere(free)
        if len(cells) < 1:
            continue
        a, b = (tuple(int(v) for v in cells[rng.integers(len(cells))]) for _ in range(2))
        want = _bfs_scipy(free, a, b)
        assert bfs_cells(free, a, b) == want, (trial, shape, a, b)  # type: ignore[arg-type]
        met[want is not None] += 1
    assert met[True] > 50 and met[False] > 10


def test_the_cell_search_from_the_goal_agrees_on_rooms_doors_and_blocked_starts() -> None:
    """The layered search from the goal and its first-ranked walk against scipy's ordered search:
    rooms joined by doors (many shortest paths, so the tie-breaking decides), the yaw axis wrapping,
    and a start in a blocked cell (the ordered search still leaves it)."""
    from kbplanner.simulation.cell_path import bfs_cells

    rng = np.random.default_rng(17)
    met = {True: 0, False: 0}
    for trial in range(120):
        nb, ny, nx = int(rng.integers(1, 9)), int(rng.integers(8, 30)), int(rng.integers(8, 30))
        free = np.ones((nb, ny, nx), dtype=bool)
        wall = int(rng.integers(2, nx - 2))
        free[:, :, wall] = False  # a wall with a door in some yaw bins only
        door = int(rng.integers(0, ny))
        free[rng.random(nb) < 0.6, door, wall] = True
        free &= rng.random(free.shape) < rng.uniform(0.8, 1.0)
        cells = np.argwhere(free)
        if len(cells) < 2:
            continue
        a, b = (tuple(int(v) for v in cells[rng.integers(len(cells))]) for _ in range(2))
        if trial % 5 == 0:
            a = (int(rng.integers(0, nb)), int(rng.integers(0, ny)), wall)  # maybe in the wall
        want = _bfs_scipy_from(free, a, b)
        assert bfs_cells(free, a, b) == want, (trial, free.shape, a, b)  # type: ignore[arg-type]
        met[want is not None] += 1
    assert met[True] > 40 and met[False] > 5


def _bfs_scipy_from(free: np.ndarray, src: tuple[int, int, int], dst: tuple[int, int, int]
                    ) -> list[int] | None:
    """:func:`_bfs_scipy`, also from a blocked start (the search leaves it for its free neighbours)."""
    if free[src]:
        return _bfs_scipy(free, src, dst)
    opened = free.copy()
    opened[src] = True
    if src == dst:
        return [int(np.ravel_multi_index(src, free.shape))]
    if not free[dst]:
        return None
    return _bfs_scipy(opened, src, dst)
