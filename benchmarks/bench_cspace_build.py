"""Configuration-space builds of a first command, replayed (issue 14; session 15, cspace15): the CPU seconds
a baseline's sources and this tree's spend on the very spaces a first ``kbplanner simulate`` of the case
study asks for, in one run of this script, and whether they give the same free maps.

1. Capture (this tree): per scenario, ``kbplanner simulate data/case_study --scenario S --seed N`` runs once
   in a child process with an empty cache folder (``KBPLANNER_CACHE_DIR``; the project loaded there first by
   ``kbplanner plan``; B4 run, its kept plan not read), recording every call of
   ``cspace_cache.configuration_space`` (grid cells, origin, footprint, yaw bins, margin; in order) and of
   ``cspace_join.part_free`` (B4's parts). The recording is the same for both trees when their free maps
   are (the run outputs are compared by bench_simspeed.py).
2. Replay, per round and tree alternately (baseline first, then this tree), in a child process with
   ``PYTHONPATH`` at the tree's sources: the calls again, in order, on a fresh process cache and no folder
   (so each space is built, cropped or patched as in a first command), timed with ``time.process_time``:
   the whole sequence, of it ``ConfigurationSpace.build`` (calls and CPU) and ``cspace_cache._cropped``,
   and the parts. Each child hashes every free map it returns (sha256): ``same`` compares the trees.

Usage: .venv/bin/python benchmarks/bench_cspace_build.py [--before REF] [--scenario S ...] [--seed N]
       [--rounds N] [--inputs DIR]
(``--inputs DIR``: keep the recordings there and reuse them when present.) Prints a table and writes
benchmarks/results/cspace15.json (or --out). Figures are medians over rounds; ratios before / after.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, write_scenarios

_CAPTURE = r'''import pickle, sys
import numpy as np
import kbplanner.world.cspace_cache as cc
import kbplanner.world.cspace_join as cj
import kbplanner.planning.refine_cache as rc
from kbplanner.cli import main
rc._read = lambda path: None
CALLS, PARTS = [], []
def rects(fp):
    return [(r.cx, r.cy, r.length, r.width, r.yaw) for r in fp.rects]
orig = cc.configuration_space
def configuration_space(grid, footprint, n_yaw_bins=72, margin_m=0.0):
    CALLS.append((np.packbits(grid.occupied), grid.occupied.shape, tuple(map(float, grid.origin)),
                  float(grid.resolution), rects(footprint), int(n_yaw_bins), float(margin_m)))
    return orig(grid, footprint, n_yaw_bins, margin_m)
orig_part = cj.part_free
def part_free(grid, footprint, region, n_bins=72):
    PARTS.append((np.packbits(grid.occupied), grid.occupied.shape, float(grid.resolution), rects(footprint),
                  tuple(map(int, region)), int(n_bins)))
    return orig_part(grid, footprint, region, n_bins)
cc.configuration_space = configuration_space
cj.part_free = part_free
for name in list(sys.modules):
    mod = sys.modules[name]
    if name.startswith("kbplanner.") and mod not in (cc, cj):
        if getattr(mod, "configuration_space", None) is orig:
            mod.configuration_space = configuration_space
        if getattr(mod, "part_free", None) is orig_part:
            mod.part_free = part_free
try:
    main(sys.argv[2:])
except SystemExit:
    pass
pickle.dump({"calls": CALLS, "parts": PARTS}, open(sys.argv[1], "wb"))
'''

_REPLAY = r'''import hashlib, json, pickle, sys, time
import numpy as np
import kbplanner.world.cspace_cache as cc
import kbplanner.world.cspace_join as cj
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid
rec = pickle.load(open(sys.argv[1], "rb"))
def grid(packed, shape, origin, res):
    occ = np.unpackbits(packed)[: shape[0] * shape[1]].reshape(shape).astype(bool)
    return OccupancyGrid(occ, origin=origin, resolution=res)
calls = [(grid(p, s, o, r), Footprint(tuple(Rect(*x) for x in rs)), n, m)
         for p, s, o, r, rs, n, m in rec["calls"]]
parts = [(grid(p, s, (0.0, 0.0), r), Footprint(tuple(Rect(*x) for x in rs)), reg, n)
         for p, s, r, rs, reg, n in rec["parts"]]
T = {"build": [0, 0.0], "crop": [0, 0.0]}
build = ConfigurationSpace.build.__func__
def timed_build(cls, *a, **k):
    t = time.process_time()
    try:
        return build(cls, *a, **k)
    finally:
        T["build"][0] += 1; T["build"][1] += time.process_time() - t
ConfigurationSpace.build = classmethod(timed_build)
crop = cc._cropped
def timed_crop(*a, **k):
    t = time.process_time()
    try:
        return crop(*a, **k)
    finally:
        T["crop"][0] += 1; T["crop"][1] += time.process_time() - t
cc._cropped = timed_crop
cc.clear()
h = hashlib.sha256()
t0 = time.process_time()
for g, fp, n, m in calls:
    h.update(cc.configuration_space(g, fp, n, m).free.tobytes())
seq = time.process_time() - t0
stats = cc.stats()
hp = hashlib.sha256()
t0 = time.process_time()
for g, fp, reg, n in parts:
    hp.update(cj.part_free(g, fp, reg, n).tobytes())
part = time.process_time() - t0
print(json.dumps({"sequence_cpu_s": round(seq, 4), "calls": len(calls),
                  "build_calls": T["build"][0], "build_cpu_s": round(T["build"][1], 4),
                  "crop_calls": T["crop"][0], "crop_cpu_s": round(T["crop"][1], 4),
                  "built": stats["built"], "cropped": stats["cropped"], "patched": stats["patched"],
                  "hits": stats["hits"], "parts": len(parts), "parts_cpu_s": round(part, 4),
                  "free_maps_sha256": h.hexdigest(), "parts_sha256": hp.hexdigest()}))
'''

_FIGURES = ("sequence_cpu_s", "build_cpu_s", "crop_cpu_s", "parts_cpu_s")


def _export(ref: str, into: Path) -> Path:
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src"


def _capture(scenario: str, seed: int, path: Path, tmp: Path) -> None:
    cache = tmp / f"cache-{scenario}"
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"), KBPLANNER_CACHE_DIR=str(cache))
    project = REPO / "data" / "case_study"
    subprocess.run([sys.executable, "-m", "kbplanner", "plan", str(project), "--scenario", scenario,
                    "--seed", str(seed), "--no-feasibility"], env=env, check=True, capture_output=True)
    proc = subprocess.run([sys.executable, "-c", _CAPTURE, str(path), "simulate", str(project), "--scenario",
                           scenario, "--seed", str(seed), "--out", str(tmp / f"out-{scenario}")],
                          env=env, capture_output=True, text=True)
    if not path.is_file():
        raise SystemExit(f"capture {scenario}: no recording (exit {proc.returncode}):\n{proc.stderr[-2000:]}")


def _replay(src: Path, recording: Path) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(src))
    proc = subprocess.run([sys.executable, "-c", _REPLAY, str(recording)], env=env, capture_output=True,
                          text=True)
    if proc.returncode:
        raise SystemExit(f"replay with {src}: exit {proc.returncode}\n{proc.stderr[-2000:]}")
    data: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return data


def _median(runs: list[dict[str, Any]]) -> dict[str, Any]:
    out = dict(runs[0])
    for k in _FIGURES:
        out[k] = round(statistics.median(r[k] for r in runs), 4)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--scenario", action="append", help="default storage-outside, storage-inside")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--inputs", type=Path, help="folder to keep (and reuse) the recordings in")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "cspace15.json")
    args = ap.parse_args()
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    rows = []
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        inputs = args.inputs or tmp
        inputs.mkdir(parents=True, exist_ok=True)
        (tmp / "before").mkdir()
        before_src = _export(args.before, tmp / "before")
        for s in scenarios:
            recording = inputs / f"cspace-calls-{s}-{args.seed}.pkl"
            if not recording.is_file():
                _capture(s, args.seed, recording, tmp)
            runs: dict[str, list[dict[str, Any]]] = {"before": [], "after": []}
            for _ in range(args.rounds):
                runs["before"].append(_replay(before_src, recording))
                runs["after"].append(_replay(REPO / "src", recording))
            b, a = _median(runs["before"]), _median(runs["after"])
            same = all(r[k] == b[k] for r in runs["before"] + runs["after"]
                       for k in ("free_maps_sha256", "parts_sha256"))
            ratios = {k: round(b[k] / a[k], 3) if a[k] else None for k in _FIGURES}
            rows.append({"scenario": s, "seed": args.seed, "rounds": args.rounds, "before": b, "after": a,
                         "ratios": ratios, "same": same, "runs": runs})
            print(f"{s} (seed {args.seed}, {b['calls']} configuration_space calls, {b['parts']} B4 parts): "
                  f"CPU s before / after (ratio), same {'yes' if same else 'NO'}")
            for k in _FIGURES:
                print(f"  {k:<16} {b[k]:7.3f} / {a[k]:7.3f}  ({ratios[k]})")
            for k in ("build_calls", "built", "cropped", "patched", "hits"):
                print(f"  {k:<16} {b[k]:>7} / {a[k]:<7}")
    write_scenarios(args.out, args.before, rows)


if __name__ == "__main__":
    main()
