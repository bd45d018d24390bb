"""The grid route searches of a first run (issue 14, session 15): CPU seconds of the searches a first
``kbplanner simulate`` makes and a repeated run reads from ``PROJECT/.kbplanner-cache/cells``, by a
baseline's functions and by this tree's, on the very inputs of the case study's run.

1. One first run per scenario (``cspace``, ``cells``, ``walks``, ``static`` of the case study's kept
   folder removed first), in a child process of this tree, records the inputs of every call of
   ``cell_path.bfs_cells`` (the corridor routes' breadth-first searches), ``grid_yardstick._dijkstra_cells``
   (the grid shortest paths, with the graph ``_graph`` built) and the line-of-sight shortening
   (``grid_yardstick._farthest_visible`` from each path's first point to its last), and the corridors
   round the grid paths (``corridor_cells.corridor_box``; before session 15 inline in ``_route``: a
   distance transform of the whole grid, reproduced here as it was).
2. The baseline's ``cell_path.py`` and ``grid_yardstick.py`` (``git show REF:...``, imported beside this
   tree's package) and this tree's run each recorded call, alternately (which goes first alternates per
   round), CPU per function (``time.process_time``), and every answer is compared (``same``).

Usage: PYTHONPATH=src .venv/bin/python benchmarks/bench_route_searches.py [--before main] [--rounds 3]
       [--scenario S ...] [--seed 7] [--out benchmarks/results/route_searches.json]
Prints a table (seconds summed over a scenario's calls, median over rounds; ratio = before / after)
and writes the JSON.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import pickle
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from _common import REPO, RESULTS_DIR, machine_info, write_json

PROJECT = REPO / "data" / "case_study"
KEPT = ("cspace", "cells", "walks", "static")
FILES = ("cell_path.py", "grid_yardstick.py")


class _Grid:
    """The grid's origin and resolution (all ``_farthest_visible`` reads of it)."""

    def __init__(self, origin: tuple[float, float], resolution: float) -> None:
        self.origin, self.resolution = origin, resolution


def _child(into: str, command: list[str]) -> int:
    """One command in this process, the searches' inputs pickled into the folder ``into``."""
    from kbplanner.cli import main
    from kbplanner.simulation import cell_path, corridor_cells, grid_yardstick

    calls: list[tuple[str, Any]] = []
    bfs, dijkstra = cell_path.bfs_cells, grid_yardstick._dijkstra_cells
    visible, box = grid_yardstick._farthest_visible, corridor_cells.corridor_box
    seen: set[int] = set()

    def box_rec(shape: Any, path: Any, reach: float) -> Any:
        calls.append(("corridor", (tuple(shape), list(path), reach)))
        return box(shape, path, reach)

    def bfs_rec(free: Any, src: Any, dst: Any) -> Any:
        calls.append(("bfs", (np.array(free), src, dst)))
        return bfs(free, src, dst)

    def dijkstra_rec(free: Any, s: Any, t: Any, graph_of: Any = None) -> Any:
        calls.append(("dijkstra", (np.array(free), s, t)))
        return dijkstra(free, s, t, graph_of)

    def visible_rec(pts: Any, i: int, free: Any, g: Any) -> Any:
        if id(pts) not in seen:  # each path's points once (its shortening from the first point on)
            seen.add(id(pts))
            calls.append(("visible", (list(pts), np.array(free), tuple(g.origin), float(g.resolution))))
        return visible(pts, i, free, g)

    cell_path.bfs_cells = corridor_cells.bfs_cells = bfs_rec  # type: ignore[assignment]
    grid_yardstick._dijkstra_cells = dijkstra_rec  # type: ignore[assignment]
    grid_yardstick._farthest_visible = visible_rec  # type: ignore[assignment]
    corridor_cells.corridor_box = box_rec  # type: ignore[assignment]
    code = main(command)
    Path(into, "calls.pkl").write_bytes(pickle.dumps(calls))
    return code


def _record(scenario: str, seed: int, tmp: Path) -> list[tuple[str, Any]]:
    for sub in KEPT:
        shutil.rmtree(PROJECT / ".kbplanner-cache" / sub, ignore_errors=True)
    into = tmp / scenario
    into.mkdir()
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    subprocess.run([sys.executable, __file__, "--child", str(into), "simulate", str(PROJECT), "--scenario",
                    scenario, "--seed", str(seed), "--out", str(into / "run"), "--force"],
                   check=True, capture_output=True, env=env)
    got: list[tuple[str, Any]] = pickle.loads((into / "calls.pkl").read_bytes())
    return got


def _baseline(ref: str, tmp: Path) -> dict[str, ModuleType]:
    out = {}
    for name in FILES:
        text = subprocess.run(["git", "-C", str(REPO), "show", f"{ref}:src/kbplanner/simulation/{name}"],
                              check=True, capture_output=True, text=True).stdout
        path = tmp / f"before_{name}"
        path.write_text(text)
        spec = importlib.util.spec_from_file_location(f"before_{name[:-3]}", path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        out[name] = module
    return out


def _corridor_on_the_whole_grid(shape: tuple[int, int], path: list[tuple[int, int]], reach: float
                                ) -> tuple[Any, tuple[int, int, int, int]]:
    """The corridor as corridor_cells._route made it before session 15: the distance transform of the
    whole grid, then the corridor's bounding box."""
    from scipy import ndimage

    off = np.ones(shape, dtype=bool)
    ys, xs = zip(*path, strict=True)
    off[list(ys), list(xs)] = False
    near = ndimage.distance_transform_edt(off) <= reach
    rows, cols = np.flatnonzero(near.any(axis=1)), np.flatnonzero(near.any(axis=0))
    y0, y1, x0, x1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    return near[y0:y1, x0:x1], (y0, y1, x0, x1)


def _runner(kind: str, args: Any, cp: ModuleType, gy: ModuleType) -> Callable[[], Any]:
    if kind == "corridor":
        from kbplanner.simulation import corridor_cells

        after = cp.__name__.startswith("kbplanner")
        box = corridor_cells.corridor_box if after else _corridor_on_the_whole_grid

        def near() -> Any:
            got, bounds = box(*args)
            return got.tobytes(), got.shape, bounds
        return near
    if kind == "bfs":
        free, src, dst = args
        return lambda: cp.bfs_cells(free, src, dst)
    if kind == "dijkstra":
        free, s, t = args
        return lambda: gy._dijkstra_cells(free, s, t, gy._graph(free))
    pts, free, origin, resolution = args
    g = _Grid(origin, resolution)

    def shorten() -> list[int]:
        i, walk = 0, []
        while i < len(pts) - 1:
            i = gy._farthest_visible(pts, i, free, g)
            walk.append(i)
        return walk
    return shorten


LABELS = {"bfs": "cell_path.bfs_cells (corridor routes)",
          "dijkstra": "grid_yardstick._graph + _dijkstra_cells",
          "visible": "grid_yardstick._farthest_visible (line of sight)",
          "corridor": "corridor_cells: the corridor round the grid path"}


def main(argv: list[str]) -> int:
    if argv and argv[0] == "--child":
        return _child(argv[1], argv[2:])
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="main")
    ap.add_argument("--scenario", action="append")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "route_searches.json")
    args = ap.parse_args(argv)
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    from kbplanner.simulation import cell_path, grid_yardstick

    result: dict[str, Any] = {"machine": machine_info(), "before": args.before, "seed": args.seed,
                              "rounds": args.rounds, "load_average_start": list(os.getloadavg()),
                              "scenarios": {}}
    with tempfile.TemporaryDirectory(prefix="route-searches-") as tmp_name:
        tmp = Path(tmp_name)
        before = _baseline(args.before, tmp)
        trees = {"before": (before["cell_path.py"], before["grid_yardstick.py"]),
                 "after": (cell_path, grid_yardstick)}
        for scenario in scenarios:
            calls = _record(scenario, args.seed, tmp)
            per: dict[str, dict[str, list[float]]] = {k: {"before": [], "after": []} for k in LABELS}
            same = {k: True for k in LABELS}
            counts = {k: sum(1 for kind, _ in calls if kind == k) for k in LABELS}
            for r in range(args.rounds):
                sums = {k: {"before": 0.0, "after": 0.0} for k in LABELS}
                for kind, call_args in calls:
                    answers = {}
                    for tree in (("before", "after") if r % 2 == 0 else ("after", "before")):
                        run = _runner(kind, call_args, *trees[tree])
                        c = time.process_time()
                        answers[tree] = run()
                        sums[kind][tree] += time.process_time() - c
                    same[kind] &= answers["before"] == answers["after"]
                for k in LABELS:
                    for tree in ("before", "after"):
                        per[k][tree].append(sums[k][tree])
            table = {}
            for k, label in LABELS.items():
                b, a = statistics.median(per[k]["before"]), statistics.median(per[k]["after"])
                table[label] = {"calls": counts[k], "before_cpu_s": round(b, 4), "after_cpu_s": round(a, 4),
                                "ratio": round(b / a, 2) if a > 0 else None, "same": same[k],
                                "rounds_before": per[k]["before"], "rounds_after": per[k]["after"]}
            b_all = sum(v["before_cpu_s"] for v in table.values())
            a_all = sum(v["after_cpu_s"] for v in table.values())
            table["all"] = {"before_cpu_s": round(b_all, 4), "after_cpu_s": round(a_all, 4),
                                  "ratio": round(b_all / a_all, 2) if a_all > 0 else None,
                                  "same": all(same.values())}
            result["scenarios"][scenario] = table
            print(f"\n{scenario}, seed {args.seed}: CPU seconds over the run's calls "
                  f"(median of {args.rounds})")
            print(f"{'function':52s} {'calls':>5s} {'before':>8s} {'after':>8s} {'ratio':>6s} same")
            for label, row in table.items():
                print(f"{label:52s} {row.get('calls', ''):>5} {row['before_cpu_s']:8.3f} "
                      f"{row['after_cpu_s']:8.3f} {row['ratio']!s:>6s} {'yes' if row['same'] else 'NO'}")
    result["load_average_end"] = list(os.getloadavg())
    write_json(args.out, result)
    print(f"\nload average {result['load_average_start'][0]:.1f} -> {result['load_average_end'][0]:.1f}; "
          f"wrote {args.out}")
    print(json.dumps({s: t["all"] for s, t in result["scenarios"].items()}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
