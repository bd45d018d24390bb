"""How tight a lower bound on a leg's drive time must be for the one-turn search to skip legs (issue 14
item 2, docs/scale.md "Session 12: route planning, part 2 (nav12)").

Runs ``kbplanner simulate`` on the case study in this process (B4 cold as bench_plan_cost.py runs it,
no key frames) with the navigation skill's one-turn search
(:func:`~kbplanner.simulation.skills.load_turn_once.one_turn`) watched: per candidate turning pose, each
leg planned (first leg start -> pose, second leg pose -> goal), its drive time, its CPU seconds, the
straight-line bound the search prunes with
(:func:`~kbplanner.simulation.skills.load_turn_once.leg_time_bound`) and the grid yardstick's length
of the same leg on the skill's map
(:func:`~kbplanner.simulation.grid_yardstick.grid_shortest_path_length`: 8-connected Dijkstra and
line-of-sight shortcutting, slightly *optimistic*, so not a proven bound), with the time that length would
give as a bound (same formula). Per second leg, the bound it would have needed to be skipped given the
pair the search chose (``needed_s`` = the best pair's time minus the candidate's first leg): a search that
knew the winner first skips it exactly when its bound reaches that.

Usage: .venv/bin/python benchmarks/one_turn_legs.py [--scenario S] [--seed N] [--out JSON]
Prints one line per leg and writes the JSON (default benchmarks/results/one_turn_legs.json).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, write_json

OCTILE = 1.0 / math.cos(math.pi / 8)  # the 8-connected metric's most over a straight line (8.2 %)


def _watch(rows: list[dict[str, Any]], searches: list[dict[str, Any]]) -> None:
    """Wrap the skill's one-turn search so that each leg and the choice are recorded into ``rows`` and
    ``searches`` (the search itself, its legs and its result unchanged)."""
    import kbplanner.simulation.skills.navigation as nav
    from kbplanner.simulation.grid_yardstick import grid_shortest_path_length
    from kbplanner.simulation.skills.load_turn_once import leg_time_bound

    inner_search = nav.one_turn
    inner_plan_path = nav.plan_path
    inner_turn_once = nav.NavigationSkill._turn_once
    context: dict[str, Any] = {"queries": None}

    def plan_path(cs: Any, start: Any, goal: Any, *args: Any, **kwargs: Any) -> Any:
        c0 = time.process_time()
        got = inner_plan_path(cs, start, goal, *args, **kwargs)
        if context["queries"] is not None:  # inside a leg of the one-turn search
            context["queries"].append({"window": list(cs.grid.shape), "ok": got.ok, "planner": got.planner,
                                       "length_m": got.length_m, "cpu_s": round(time.process_time() - c0, 4)})
        return got

    def turn_once(self: Any, grid: Any, start: Any, free_start: list[str], free_goal: list[str],
                  fits: Any, why: list[str]) -> Any:
        if self.geo is not None and len(free_start) == 1 and len(free_goal) == 1:
            base = self.c.env.robot.spec.base
            context.update(grid=grid, fa=self.geo.footprint(free_start[0]),
                           fb=self.geo.footprint(free_goal[0]),
                           limits=(self.max_speed, base.max_accel_mps2, base.max_yaw_rate_rps))
        return inner_turn_once(self, grid, start, free_start, free_goal, fits, why)

    def search(fits: Any, start: Any, goal: Any, to_turn: Any, from_turn: Any, bound: Any = None) -> Any:
        first = len(rows)
        vmax, amax, wmax = context["limits"]

        def watched(leg: str, plan: Any, footprint: Any) -> Any:
            def run(c: Any) -> Any:
                a, b = (start, c) if leg == "first" else (c, goal)
                queries: list[dict[str, Any]] = []
                context["queries"] = queries
                c0 = time.process_time()
                try:
                    got = plan(c)
                finally:
                    context["queries"] = None
                cpu = time.process_time() - c0
                yard = grid_shortest_path_length(context["grid"], a, b, footprint=footprint)
                # the straight bound's formula with the yardstick's length for the distance
                far = (a[0] + yard, a[1], b[2]) if math.isfinite(yard) else b
                rows.append({"leg": leg, "pose": list(c), "drive_s": None if got is None else got[1],
                             "cpu_s": round(cpu, 4), "straight_bound_s": bound(a, b), "yardstick_m": yard,
                             "straight_m": math.hypot(b[0] - a[0], b[1] - a[1]),
                             "yardstick_bound_s": leg_time_bound(a, far, vmax, amax, wmax),
                             "yardstick_8pct_bound_s": leg_time_bound(
                                 a, (a[0] + yard / OCTILE, a[1], b[2]) if math.isfinite(yard) else b,
                                 vmax, amax, wmax),
                             "queries": queries})
                return got
            return run

        got = inner_search(fits, start, goal, watched("first", to_turn, context["fa"]),
                           watched("second", from_turn, context["fb"]), bound)
        legs = rows[first:]
        best = None if got is None else got[3]
        firsts = {tuple(r["pose"]): r["drive_s"] for r in legs if r["leg"] == "first"}
        for r in legs:
            if r["leg"] == "second" and best is not None and firsts.get(tuple(r["pose"])) is not None:
                r["needed_s"] = best - firsts[tuple(r["pose"])]
                r["winner"] = tuple(r["pose"]) == tuple(got[0])
        search = {"start": list(start), "goal": list(goal), "best_s": best,
                  "pose": None if got is None else list(got[0]), "legs": len(legs),
                  "cpu_s": round(sum(r["cpu_s"] for r in legs), 4)}
        seconds = [r for r in legs if "needed_s" in r]
        after = [r for i, r in enumerate(seconds) if any(w.get("winner") for w in seconds[:i])]
        for key in ("yardstick_bound_s", "yardstick_8pct_bound_s"):
            # the second legs a bound this tight skips: after the chosen one (the search's order), and
            # with the chosen candidate tried first
            for name, pool in (("in_order", after), ("winner_first", seconds)):
                hit = [r for r in pool if not r.get("winner") and r[key] >= r["needed_s"]]
                search[f"skipped_{name}_{key}"] = {"legs": len(hit),
                                                   "cpu_s": round(sum(r["cpu_s"] for r in hit), 4)}
        searches.append(search)
        return got

    nav.one_turn = search
    nav.plan_path = plan_path
    nav.NavigationSkill._turn_once = turn_once


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="storage-outside")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "one_turn_legs.json")
    ap.add_argument("--markdown", action="store_true", help="also print the second legs as table rows")
    args = ap.parse_args()
    sys.path.insert(0, str(REPO / "src"))
    try:
        import kbplanner.planning.refine_cache as rc
        rc._read = lambda _path: None  # B4 cold, as bench_plan_cost.py runs it
    except ImportError:
        pass
    from kbplanner.cli import main as cli

    rows: list[dict[str, Any]] = []
    searches: list[dict[str, Any]] = []
    _watch(rows, searches)
    with tempfile.TemporaryDirectory() as tmp, contextlib.redirect_stdout(io.StringIO()):
        code = cli(["simulate", str(REPO / "data" / "case_study"), "--scenario", args.scenario,
                    "--seed", str(args.seed), "--out", str(Path(tmp) / "run"), "--no-keyframes"])
    for s in searches:
        print(f"one-turn search: best {s['best_s']} s at {s['pose']}, {s['legs']} legs, {s['cpu_s']} s CPU")
        for key, name in (("yardstick_bound_s", "as tight as the yardstick"),
                          ("yardstick_8pct_bound_s", "the yardstick less 8.2 %")):
            a, b = s[f"skipped_in_order_{key}"], s[f"skipped_winner_first_{key}"]
            print(f"  a bound {name} skips {a['legs']} second legs ({a['cpu_s']} s CPU) in the search's "
                  f"order, {b['legs']} ({b['cpu_s']} s) with the chosen candidate first")
    print("leg     pose                        drive_s  cpu_s  straight  bound_s  yard_m  yard_bound_s"
          "  needed_s")
    for r in rows:
        pose = "(" + ", ".join(f"{v:.3f}" for v in r["pose"]) + ")"
        drive = "-" if r["drive_s"] is None else f"{r['drive_s']:.2f}"
        needed = f"{r['needed_s']:.2f}" + (" (winner)" if r.get("winner") else "") if "needed_s" in r else ""
        print(f"{r['leg']:7} {pose:27} {drive:>8} {r['cpu_s']:6.3f} {r['straight_m']:8.2f} "
              f"{r['straight_bound_s']:8.2f} {r['yardstick_m']:7.2f} {r['yardstick_bound_s']:12.2f}"
              f"  {needed}")
    if args.markdown:
        print("| seed | candidate | drive_s | CPU s | straight m | bound_s | yardstick m | yard_bound_s "
              "| yard_bound_s less 8.2 % | needed_s | planner queries (window cells, path, CPU) |")
        print("| ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- |")
        for r in rows:
            if r["leg"] != "second":
                continue
            pose = "(" + ", ".join(f"{v:.2f}" if i < 2 else f"{v:.3f}" for i, v in enumerate(r["pose"])) + ")"
            queries = ", ".join(f"{q['planner']} {q['window'][0]}x{q['window'][1]} {q['length_m']:.2f} m "
                                f"{q['cpu_s']:.3f} s" for q in r["queries"])
            needed = "chosen" if r.get("winner") else f"{r['needed_s']:.2f}" if "needed_s" in r else "-"
            drive = "-" if r["drive_s"] is None else f"{r['drive_s']:.2f}"
            print(f"| {args.seed} | {pose} | {drive} | {r['cpu_s']:.3f} | {r['straight_m']:.2f} | "
                  f"{r['straight_bound_s']:.2f} | {r['yardstick_m']:.2f} | {r['yardstick_bound_s']:.2f} | "
                  f"{r['yardstick_8pct_bound_s']:.2f} | {needed} | {queries} |")
    write_json(args.out, {"scenario": args.scenario, "seed": args.seed, "exit": code, "searches": searches,
                          "legs": rows, "machine": machine_info()})
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
