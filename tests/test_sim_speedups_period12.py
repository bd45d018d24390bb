"""B5 per-period loop speed-ups of session 12 (period12) that claim identical results, each against the
full computation: the robot's far checks on one shared nearest centre distance against "every worker
farther than r", the crowd's kept (x, y) list, the step's reused speeds against numpy's hypot of the
velocities it leaves (capped, pushed by the robot, standing), the workers' walking graph built straight
into compressed rows against the sparse matrix of its edge lists."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kbplanner.planning.manipulation import robot_name
from kbplanner.simulation.crowd import Crowd
from kbplanner.simulation.sim_env import SimEnv
from kbplanner.simulation.social_force import Obstacle
from kbplanner.simulation.workers import RouteStop, WorkerSpec, _Router
from kbplanner.world.footprint import Rect
from kbplanner.world.occupancy import OccupancyGrid
from sim_project_factory import load_sim_case


def _spec(name: str, a: tuple[float, float], b: tuple[float, float], speed: float = 1.0) -> WorkerSpec:
    return WorkerSpec(f"urn:test:{name}", name, "carpenter", speed,
                      (RouteStop("a", "A", a[0], a[1], 0.5), RouteStop("b", "B", b[0], b[1], 0.5)))


@pytest.fixture(scope="module")
def case(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return load_sim_case(tmp_path_factory.mktemp("period12") / "p", high_panel=False)


def test_the_shared_nearest_centre_distance_answers_every_far_check(case) -> None:  # type: ignore[no-untyped-def]
    """``nearest_centre_m(x, y) > r`` is ``all(hypot(worker - (x, y)) > r)`` for the environment's workers
    at every period of a walk, at points and radii around them (ties included); the kept answer is
    given again only for the same positions and point."""
    specs = [_spec("w1", (-3.0, -4.0), (4.0, -4.0)), _spec("w2", (4.0, -5.0), (-3.0, -5.0)),
             _spec("w3", (0.0, -7.0), (0.0, -2.0), 1.2)]
    env = SimEnv(case.world, robot_name(case.refined), grid=case.grid, reactive=specs)
    rng = np.random.default_rng(12)
    checks = 0
    try:
        env.reset(seed=3)
        for _ in range(60):
            env.step()
            xy = env.worker_xy_list()
            assert env.worker_xy_list() is xy  # the crowd's list, kept until the workers move
            assert xy == list(zip(env.crowd._xs, env.crowd._ys, strict=True))  # type: ignore[union-attr]
            for _ in range(5):
                x, y = float(rng.uniform(-5, 5)), float(rng.uniform(-8, 0))
                d = [math.hypot(wx - x, wy - y) for wx, wy in xy]
                for r in (*d, min(d) - 1e-12, max(d) + 1e-12, 0.0, float(rng.uniform(0, 6))):
                    assert (env.nearest_centre_m(x, y) > r) is all(v > r for v in d)
                    checks += 1
    finally:
        env.close()
    assert checks > 2000


def test_nearest_centre_distance_of_no_worker_and_of_a_position_not_a_number(case) -> None:  # type: ignore[no-untyped-def]
    env = SimEnv(case.world, robot_name(case.refined), grid=case.grid)
    try:
        env.reset(seed=1)
        assert env.nearest_centre_m(1.0, 2.0) == math.inf  # all() of nothing: every check says far
    finally:
        env.close()
    env = SimEnv(case.world, robot_name(case.refined), grid=case.grid,
                 reactive=[_spec("w1", (0.0, -4.0), (3.0, -4.0)), _spec("w2", (1.0, -6.0), (1.0, -2.0))])
    try:
        env.reset(seed=1)
        crowd = env.crowd
        assert crowd is not None
        crowd.pos = np.array([[math.nan, -4.0], [1.0, -6.0]])
        d = env.nearest_centre_m(0.0, 0.0)
        assert math.isnan(d) and not d > 0.0  # as all(...) with a distance not a number: not far
    finally:
        env.close()


def test_the_steps_speeds_are_numpys_hypot_of_the_velocities_it_leaves() -> None:
    """Workers meeting head on, one fast enough to be capped, the robot standing in their way (its push
    and the step cut back at its footprint): after every step the kept speeds are, bit for bit,
    numpy's hypot of the velocities; the headings numpy's arctan2 of those moving."""
    specs = [_spec("w1", (-4.0, 0.0), (4.0, 0.0)), _spec("w2", (4.0, 0.2), (-4.0, 0.2), 1.6),
             _spec("w3", (0.0, -3.0), (0.0, 3.0))]
    crowd = Crowd(specs, None, seed=4)
    rects = [Rect(0.0, 0.0, 1.0, 0.7, 0.0)]
    capped = 0
    for k in range(400):
        robot = Obstacle((-4.0 + 0.02 * k, 0.1, 0.3), rects)  # driving through them along their line
        crowd.step(robot if k % 50 < 40 else None)
        vx, vy = np.array(crowd._vxs), np.array(crowd._vys)
        assert crowd.speed_list() == np.hypot(vx, vy).tolist()
        moving = np.hypot(vx, vy) > 0.05
        assert np.array_equal(crowd.heading[moving], np.arctan2(vy, vx)[moving])
        assert crowd.xy() is crowd.xy() and crowd.xy() == list(zip(crowd._xs, crowd._ys, strict=True))
        capped += sum(math.isclose(math.hypot(a, b), m) for a, b, m in zip(vx, vy, crowd._vmax_list,
                                                                              strict=True))
    assert capped > 0  # the cap was met (its speeds worked out again)


def _former_graph(free: np.ndarray):  # type: ignore[no-untyped-def]
    """The walking graph as session 11 built it: the sparse matrix of (row, column, weight) lists."""
    from scipy import sparse

    ny, nx = free.shape
    index = np.full(free.shape, -1, dtype=np.int64)
    index[free] = np.arange(int(free.sum()))
    rows, cols, weights = [], [], []
    for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
        ys0, ys1 = max(0, -dy), ny - max(0, dy)
        xs0, xs1 = max(0, -dx), nx - max(0, dx)
        a = index[ys0:ys1, xs0:xs1]
        b = index[ys0 + dy:ys1 + dy, xs0 + dx:xs1 + dx]
        both = (a >= 0) & (b >= 0)
        rows.append(a[both])
        cols.append(b[both])
        weights.append(np.full(int(both.sum()), math.hypot(dx, dy)))
    n = int(free.sum())
    graph = sparse.csr_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
                              shape=(n, n))
    return graph, index


@pytest.mark.parametrize("fill", [0.0, 0.05, 0.3, 0.7])
def test_the_walking_graph_is_the_former_sparse_matrix_array_for_array(fill: float) -> None:
    """Random walking maps (edges, one-cell strips, a map with one free cell): the compressed rows, the
    columns (their order too), the weights' bits, the dtypes and the node numbers are the former ones,
    and the same shortest walks come out."""
    from scipy.sparse import csgraph

    rng = np.random.default_rng(int(fill * 100))
    for shape in ((1, 9), (9, 1), (7, 11), (40, 33)):
        occupied = rng.random(shape) < fill
        occupied[0, 0] = False
        router = _Router(OccupancyGrid(occupied, origin=(0.0, 0.0), resolution=0.1), 1e-9)
        assert router.free is not None
        graph, index = router._graph()
        g0, i0 = _former_graph(router.free)
        assert np.array_equal(index, i0) and index.dtype == i0.dtype
        assert graph.has_canonical_format and g0.has_canonical_format
        for a, b in ((graph.indptr, g0.indptr), (graph.indices, g0.indices), (graph.data, g0.data)):
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
        free = np.argwhere(router.free)
        for _ in range(5):
            (sy, sx), (ty, tx) = free[rng.integers(len(free), size=2)]
            cells = router._dijkstra((int(sx), int(sy)), (int(tx), int(ty)))
            assert cells[0] == (sx, sy) and cells[-1] == (tx, ty)
            src = int(index[sy, sx])
            _, pred0 = csgraph.dijkstra(g0, directed=False, indices=src, return_predecessors=True)
            assert np.array_equal(router._pred[src], pred0)  # the same search, ties and all
