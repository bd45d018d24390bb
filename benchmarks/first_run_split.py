"""Where a first run's simulation step goes (issue 14, session 14): CPU seconds of the pieces of
``executor.simulate`` that build what later runs read from ``PROJECT/.kbplanner-cache`` (configuration
spaces, grid cell paths and yardstick lengths, corridor routes, the workers' walking map and legs, the
static bodies' triangles), on a first run (the kept ``cspace``, ``cells``, ``walks`` and ``static``
folders removed first) with and without the early builds' process (``simulation/early_builds.py``), and
on a repeated run (everything kept).

Each run is ``kbplanner simulate data/case_study --scenario S --seed N --out DIR --force`` in its own
process with B4 run (its kept plan not read), wrappers round the pieces (``time.process_time``, inclusive,
counted within the step only); the early process's CPU is what the command's process gets back when it
waits for it (``RUSAGE_CHILDREN`` round ``EarlyBuilds.finish``).

Usage: PYTHONPATH=src .venv/bin/python benchmarks/first_run_split.py [--scenario S ...] [--seed 7]
       [--rounds 1] [--out benchmarks/results/first_run_split.json]
Prints a table per scenario (medians over rounds) and writes the JSON.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, write_json

PROJECT = REPO / "data" / "case_study"
KEPT = ("cspace", "cells", "walks", "static")
#: (module, function or Class.method, label): the pieces timed within the step
PIECES = (
    ("kbplanner.simulation.executor", "_Run.run", "run loop"),
    ("kbplanner.simulation.skills.navigation", "NavigationSkill.start", "navigation planning"),
    ("kbplanner.world.cspace_cache", "configuration_space", "configuration spaces"),
    ("kbplanner.world.footprint", "ConfigurationSpace.build", "  of it: built (FFT)"),
    ("kbplanner.world.cspace_cache", "_cropped", "  of it: cropped from one kept in memory"),
    ("kbplanner.world.cspace_store", "write", "  of it: written to cspace/"),
    ("kbplanner.world.cspace_store", "read", "  of it: read from cspace/"),
    ("kbplanner.simulation.grid_yardstick", "grid_shortest_path_length", "yardstick lengths"),
    ("kbplanner.simulation.grid_yardstick", "_cells", "grid shortest cell paths (Dijkstra)"),
    ("kbplanner.simulation.corridor_cells", "corridor_cells", "corridor routes"),
    ("kbplanner.simulation.cell_path", "bfs_cells", "breadth-first cell searches"),
    ("kbplanner.simulation.workers", "_Router.path", "walking legs"),
    ("kbplanner.simulation.workers", "_Router._dijkstra", "  of it: searched (Dijkstra)"),
    ("kbplanner.simulation.walk_store", "walk_cells_kept", "walking map"),
    ("kbplanner.simulation.workers", "walk_cells", "  of it: made (distance transform)"),
    ("kbplanner.simulation.sim_world", "static_chunks", "static bodies' triangles"),
    ("kbplanner.world.meshes", "element_mesh", "  of it: mesh files read"),
    ("kbplanner.simulation.cell_store", "flush", "cells/ written"),
    ("kbplanner.simulation.walk_store", "write_from", "walks/ written"),
)


def _child(mode: str, out: str, command: list[str]) -> int:
    """One command in this process, its step's pieces timed (``mode``: first, first-no-early, repeated)."""
    import kbplanner.planning.refine_cache as rc
    import kbplanner.simulation.early_builds as eb
    import kbplanner.simulation.executor as ex
    from kbplanner.cli import main

    rc._read = lambda _path: None  # type: ignore[attr-defined]  # B4 runs (cold)
    if mode == "first-no-early":
        eb.start = lambda *_a, **_k: eb.EarlyBuilds()  # type: ignore[assignment]
    seconds: dict[str, float] = {}
    calls: dict[str, int] = {}
    active: set[str] = set()
    in_step = [False]

    def wrap(label: str, f: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*a: Any, **k: Any) -> Any:
            if not in_step[0] or label in active:
                return f(*a, **k)
            active.add(label)
            c = time.process_time()
            try:
                return f(*a, **k)
            finally:
                active.discard(label)
                seconds[label] = seconds.get(label, 0.0) + time.process_time() - c
                calls[label] = calls.get(label, 0) + 1
        return timed

    for module, name, label in PIECES:
        m = importlib.import_module(module)
        if "." in name:
            cls_name, meth = name.split(".")
            cls = getattr(m, cls_name)
            raw = cls.__dict__[meth]
            if isinstance(raw, classmethod):
                setattr(cls, meth, classmethod(wrap(label, raw.__func__)))
            else:
                setattr(cls, meth, wrap(label, raw))
            continue
        orig = getattr(m, name)
        timed = wrap(label, orig)
        for mod in list(sys.modules.values()):  # also where it was imported by name
            if getattr(mod, "__name__", "").startswith("kbplanner") and getattr(mod, name, None) is orig:
                setattr(mod, name, timed)
    inner = ex.simulate

    def step(*a: Any, **k: Any) -> Any:
        in_step[0] = True
        c = time.process_time()
        try:
            return inner(*a, **k)
        finally:
            seconds["simulation step"] = time.process_time() - c
            in_step[0] = False

    ex.simulate = step  # type: ignore[assignment]
    finish = eb.EarlyBuilds.finish

    def finished(self: eb.EarlyBuilds) -> int | None:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        try:
            return finish(self)
        finally:
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            if self.pid is not None:
                seconds["early process"] = seconds.get("early process", 0.0) + (
                    after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)

    eb.EarlyBuilds.finish = finished  # type: ignore[method-assign]
    code = main(command)
    Path(out).write_text(json.dumps({"exit": code, "cpu_s": {k: round(v, 4) for k, v in seconds.items()},
                                     "calls": calls}))
    return 0


def _one(mode: str, scenario: str, seed: int, tmp: Path) -> dict[str, Any]:
    if mode != "repeated":
        for sub in KEPT:
            shutil.rmtree(PROJECT / ".kbplanner-cache" / sub, ignore_errors=True)
    out = tmp / f"{scenario}-{mode}.json"
    cmd = [sys.executable, __file__, "--child", mode, str(out), "simulate", str(PROJECT),
           "--scenario", scenario, "--seed", str(seed), "--out", str(tmp / f"{scenario}-{mode}"), "--force"]
    subprocess.run(cmd, check=True, capture_output=True, env=dict(os.environ))
    got: dict[str, Any] = json.loads(out.read_text())
    return got


def main(argv: list[str]) -> int:
    if argv and argv[0] == "--child":
        return _child(argv[1], argv[2], argv[3:])
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", action="append")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "first_run_split.json")
    args = ap.parse_args(argv)
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    modes = ("first-no-early", "first", "repeated")
    result: dict[str, Any] = {"machine": machine_info(), "seed": args.seed, "rounds": args.rounds,
                              "load_average_start": list(os.getloadavg()), "scenarios": {}}
    with tempfile.TemporaryDirectory(prefix="first-run-split-") as tmp:
        for scenario in scenarios:
            runs: dict[str, list[dict[str, Any]]] = {m: [] for m in modes}
            for _ in range(args.rounds):
                for mode in modes:
                    runs[mode].append(_one(mode, scenario, args.seed, Path(tmp)))
            labels = ["simulation step"] + [label for _, _, label in PIECES] + ["early process"]
            table = {label: {m: round(statistics.median(r["cpu_s"].get(label, 0.0) for r in runs[m]), 3)
                             for m in modes} for label in labels}
            result["scenarios"][scenario] = {"median_cpu_s": table, "runs": runs}
            print(f"\n{scenario}, seed {args.seed}: CPU seconds (median of {args.rounds})")
            print(f"{'piece':45s} " + " ".join(f"{m:>15s}" for m in modes))
            for label in labels:
                print(f"{label:45s} " + " ".join(f"{table[label][m]:15.3f}" for m in modes))
    result["load_average_end"] = list(os.getloadavg())
    write_json(args.out, result)
    print(f"\nload average {result['load_average_start'][0]:.1f} -> {result['load_average_end'][0]:.1f}; "
          f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
