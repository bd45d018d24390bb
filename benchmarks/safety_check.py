"""Independent recomputation of a run's safety figures from its files (no kbplanner import).

Reads ``trajectories.csv``, ``footprints.json``, ``manifest.json`` and ``metrics.json`` of one or more
run directories, recomputes with plain numpy: per sample the robot's footprint (base rectangle plus
the carried element's rectangle of its carry mode; lifted/placing: normal), the distance of each
worker's disc (0.25 m) to it, the robot's speed from consecutive positions and the ISO/TS 15066
protective separation distance with the constants in ``metrics.json`` (``safety.ssm``); then compares
the minimum separation, time below 1 m and time below S_p with ``metrics.json`` and checks that every
sample where a worker overlaps the footprint lies within a collision interval of ``events.jsonl``.

Usage: python benchmarks/safety_check.py RUN_DIR [RUN_DIR ...]   (exit 1 on any disagreement)
"""

from __future__ import annotations

import csv
import json
import math
import sys
from pathlib import Path

import numpy as np

TOL_M = 0.002
TOL_S = 0.25
MODES = {"normal": "normal", "narrow": "narrow", "lifted": "normal", "placing": "normal"}


def _dist(px, py, rx, ry, ryaw, rects):  # type: ignore[no-untyped-def]
    c, s = np.cos(ryaw), np.sin(ryaw)
    dx, dy = px - rx, py - ry
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    best = np.full(px.shape, np.inf)
    for r in rects:
        cr, sr = math.cos(r.get("yaw", 0.0)), math.sin(r.get("yaw", 0.0))
        qx, qy = lx - r["cx"], ly - r["cy"]
        ux, uy = cr * qx + sr * qy, -sr * qx + cr * qy
        ex = np.maximum(np.abs(ux) - r["length"] / 2, 0)
        ey = np.maximum(np.abs(uy) - r["width"] / 2, 0)
        best = np.minimum(best, np.hypot(ex, ey))
    return best


def check(run: Path) -> list[str]:
    """Disagreements between the recomputation and metrics.json (empty: all agree)."""
    rows = list(csv.reader((run / "trajectories.csv").open(encoding="utf-8")))
    head, body = rows[0], rows[1:]
    col = {c: i for i, c in enumerate(head)}
    fp = json.loads((run / "footprints.json").read_text())
    man = json.loads((run / "manifest.json").read_text())
    met = json.loads((run / "metrics.json").read_text())["safety"]
    events = [json.loads(line) for line in (run / "events.jsonl").read_text().splitlines() if line]
    t = np.array([float(r[col["t_s"]]) for r in body])
    x, y, yaw = (np.array([float(r[col[k]]) for r in body]) for k in ("x", "y", "yaw"))
    dz = abs(float(man.get("robot_floor_z", 0)) - float(man.get("ground_z", 0)))
    v = np.zeros(len(t))
    v[1:] = np.hypot(np.diff(x), np.diff(y)) / np.diff(t)
    s = met["ssm"]
    a = s["deceleration_mps2"]
    sp = (
        s["human_speed_mps"] * (s["reaction_time_s"] + v / a)
        + v * s["reaction_time_s"]
        + v * v / (2 * a)
        + s["intrusion_m"]
        + s["uncertainty_m"]
    )
    dt = float(np.median(np.diff(t)))
    workers = sorted(c[:-2] for c in head if c.endswith("_x") and c != "x")
    rects_of = []
    for r in body:
        gid, mode = r[col["carried"]], MODES.get(r[col["carry_mode"]])
        el = fp["elements"].get(gid, {})
        rects_of.append(fp["robot"] + ([el[mode]] if gid and mode in el else []))
    keys = [json.dumps(rs, sort_keys=True) for rs in rects_of]
    groups: dict[str, list[int]] = {}
    for i, k in enumerate(keys):
        groups.setdefault(k, []).append(i)
    problems: list[str] = []
    seps = {}
    centre = {}
    for w in workers:
        wx = np.array([float(r[col[w + "_x"]]) for r in body])
        wy = np.array([float(r[col[w + "_y"]]) for r in body])
        d = np.empty(len(t))
        for k, idx_list in groups.items():
            idx = np.array(idx_list)
            d[idx] = _dist(wx[idx], wy[idx], x[idx], y[idx], yaw[idx], json.loads(k))
        centre[w] = d
        seps[w] = np.maximum(np.hypot(d, dz) - 0.25, 0.0)
    mins = min((float(v.min()) for v in seps.values()), default=None)
    below1 = np.zeros(len(t), bool)
    belowp = np.zeros(len(t), bool)
    for v_ in seps.values():
        below1 |= v_ < 1.0
        belowp |= v_ < sp
    figures = {
        "min_separation_m": mins,
        "time_below_1m_s": below1.sum() * dt,
        "time_below_protective_s": belowp.sum() * dt,
    }
    for k, mine in figures.items():
        theirs = met[k]
        if mine is None or theirs is None:
            if mine != theirs:
                problems.append(f"{k}: recomputed {mine}, metrics {theirs}")
            continue
        tol = TOL_M if k.endswith("_m") else TOL_S
        if abs(mine - theirs) > tol:
            problems.append(f"{k}: recomputed {mine:.3f}, metrics {theirs}")
    starts = {}
    for e in events:
        if e["kind"] == "collision":
            starts.setdefault(e["details"]["worker"], []).append(e["t_s"])
    for w, d in centre.items():
        overlap = t[(d < 0.25) & (dz == 0)]
        for tt in overlap:
            if not any(t0 - TOL_S <= tt for t0 in starts.get(w, [])):
                problems.append(f"{w} overlaps the footprint at t = {tt} s without a collision event")
                break
    n_events = sum(len(v_) for v_ in starts.values())
    if n_events != met["collisions"]:
        problems.append(f"collision events {n_events} != metrics {met['collisions']}")
    print(
        f"{run}: min separation {figures['min_separation_m']}, below 1 m {figures['time_below_1m_s']:.1f} s, "
        f"below S_p {figures['time_below_protective_s']:.1f} s, collisions {n_events}: "
        + ("agree" if not problems else "; ".join(problems))
    )
    return problems


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__)
        return 2
    bad = [p for run in argv for p in check(Path(run))]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
