"""Workers walk their routes around obstacles, deterministically for a seed."""

from __future__ import annotations

import numpy as np
from rdflib import RDF, RDFS, Graph, Literal, URIRef

from kbplanner.core.vocab import KBP
from kbplanner.simulation.workers import load_workers, plan_worker_motion, plan_workers
from kbplanner.world.occupancy import OccupancyGrid


def _site() -> Graph:
    g = Graph()
    w = URIRef("urn:t:worker")
    g.add((w, RDF.type, KBP.Worker))
    g.add((w, RDFS.label, Literal("Carpenter")))
    g.add((w, KBP.role, Literal("carpenter")))
    g.add((w, KBP.walkingSpeed, Literal(1.0)))
    for i, (x, y, dwell) in enumerate([(1.0, 5.0, 10.0), (9.0, 5.0, 20.0)], start=1):
        loc, pose, stop = URIRef(f"urn:t:loc{i}"), URIRef(f"urn:t:pose{i}"), URIRef(f"urn:t:stop{i}")
        g.add((loc, RDF.type, KBP.Workspace))
        g.add((loc, KBP.installedPose, pose))
        g.add((pose, KBP.x, Literal(x)))
        g.add((pose, KBP.y, Literal(y)))
        g.add((w, KBP.routeStop, stop))
        g.add((stop, KBP.order, Literal(i)))
        g.add((stop, KBP.location, loc))
        g.add((stop, KBP.dwellTime, Literal(dwell)))
    return g


def _wall_grid() -> OccupancyGrid:
    occ = np.zeros((100, 100), dtype=bool)  # 10 x 10 m at 0.1 m
    occ[0:80, 48:52] = True  # a wall at x = 5 m from y = 0 to 8 m: walk around its north end
    return OccupancyGrid(occupied=occ, origin=(0.0, 0.0), resolution=0.1)


def test_workers_are_read_from_the_graph_with_their_ordered_route() -> None:
    (spec,) = load_workers(_site())
    assert spec.label == "Carpenter" and spec.speed_mps == 1.0
    assert [(s.x, s.dwell_s) for s in spec.stops] == [(1.0, 10.0), (9.0, 20.0)]


def test_a_worker_walks_around_a_wall_not_through_it() -> None:
    grid = _wall_grid()
    (spec,) = load_workers(_site())
    m = plan_worker_motion(spec, grid, seed=3, horizon_s=300.0)
    ts = np.arange(0.0, 300.0, 0.1)
    xy = np.array([m.position(t)[:2] for t in ts])
    assert all(not grid.is_occupied(x, y) for x, y in xy)
    crossing = xy[(xy[:, 0] > 4.8) & (xy[:, 0] < 5.2)]
    assert len(crossing) > 0 and crossing[:, 1].min() > 8.0  # passes north of the wall
    steps = np.linalg.norm(np.diff(xy, axis=0), axis=1) / 0.1
    assert steps.max() <= 1.1 * 1.1 + 1e-6  # never faster than the jittered walking speed


def test_the_same_seed_gives_the_same_motion_and_another_seed_differs() -> None:
    grid = _wall_grid()
    a = plan_workers(_site(), grid, seed=7, horizon_s=200.0)
    b = plan_workers(_site(), grid, seed=7, horizon_s=200.0)
    c = plan_workers(_site(), grid, seed=8, horizon_s=200.0)
    ts = np.arange(0.0, 200.0, 0.5)
    pa = [a[0].position(t) for t in ts]
    assert pa == [b[0].position(t) for t in ts]
    assert pa != [c[0].position(t) for t in ts]


def test_a_worker_waits_at_each_stop_for_about_its_dwell_time() -> None:
    (spec,) = load_workers(_site())
    m = plan_worker_motion(spec, None, seed=1, horizon_s=500.0)
    waits = [(t1 - t0, pts[0, 0]) for t0, t1, pts, _ in m.segments if len(pts) == 1 and t0 > 0]
    assert waits
    for dur, x in waits:
        nominal = 10.0 if x == 1.0 else 20.0
        assert 0.8 * nominal - 1e-9 <= dur <= 1.2 * nominal + 1e-9


def test_a_big_site_is_routed_on_a_coarser_grid_and_still_goes_around_walls() -> None:
    occ = np.zeros((1000, 1000), dtype=bool)  # 50 x 50 m at 0.05 m: 1,000,000 cells
    occ[0:800, 490:510] = True  # a wall at x = 25 m from y = 0 to 40 m
    grid = OccupancyGrid(occupied=occ, origin=(0.0, 0.0), resolution=0.05)
    g = _site()
    for pose, x in ((URIRef("urn:t:pose1"), 10.0), (URIRef("urn:t:pose2"), 40.0)):
        g.set((pose, KBP.x, Literal(x)))
        g.set((pose, KBP.y, Literal(20.0)))
    (motion,) = plan_workers(g, grid, seed=3, horizon_s=200.0)
    walk = next(pts for _t0, _t1, pts, _cum in motion.segments if len(pts) > 2)
    assert walk[:, 1].max() > 40.0  # around the north end of the wall
    xs = np.linspace(walk[:-1], walk[1:], 50).reshape(-1, 2)  # every leg, densely
    inside_wall = (xs[:, 0] > 24.5) & (xs[:, 0] < 25.5) & (xs[:, 1] < 40.0)
    assert not inside_wall.any()
