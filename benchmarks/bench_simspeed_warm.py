"""The case study's ``kbplanner simulate`` with both trees warm (issue 14, session 12): a baseline and this
tree each simulate a scenario once (keeping their refined plan, configuration spaces and, where the
tree keeps them, maps in their project cache), then run the same command again, alternately, for
``--rounds`` rounds; the command's CPU seconds (``os.wait4``: the process and the key-frame workers it
waited for) and wall seconds per run, the medians, and whether the deterministic files of both trees'
last runs are byte-identical. ``bench_simspeed.py --b4-cache warm`` compares a baseline's first run with
this tree's warm one; this script compares warm with warm (what a user who ran ``make run`` meets).

Usage: .venv/bin/python benchmarks/bench_simspeed_warm.py [--before REF] [--rounds N] [--out JSON]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, write_json

FILES = ("trajectories.csv", "events.jsonl", "metrics.json", "plan.json", "footprints.json")


def _run(tree: Path, scenario: str, out: Path) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(tree / "src"))
    cmd = [sys.executable, "-m", "kbplanner", "simulate", str(tree / "data" / "case_study"), "--scenario",
           scenario, "--seed", "7", "--out", str(out), "--force"]
    w0 = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, ru = os.wait4(proc.pid, 0)
    return {"cpu_s": round(ru.ru_utime + ru.ru_stime, 3), "wall_s": round(time.perf_counter() - w0, 3),
            "exit": os.waitstatus_to_exitcode(status)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "simspeed-warm.json")
    args = ap.parse_args(argv)
    out: dict[str, Any] = {"before": args.before, "rounds": args.rounds,
                           "load_average_start": os.getloadavg()}
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        archive = subprocess.run(["git", "-C", str(REPO), "archive", args.before], check=True,
                                 capture_output=True).stdout
        (tmp / "before").mkdir()
        subprocess.run(["tar", "-x", "-C", str(tmp / "before")], input=archive, check=True)
        trees = {"before": tmp / "before", "after": REPO}
        for scenario in ("storage-outside", "storage-inside"):
            for name, tree in trees.items():
                _run(tree, scenario, tmp / f"{name}-{scenario}")  # keeps what the timed runs read
            rows: dict[str, list[dict[str, Any]]] = {n: [] for n in trees}
            for _ in range(args.rounds):
                for name, tree in trees.items():
                    rows[name].append(_run(tree, scenario, tmp / f"{name}-{scenario}"))
            b, a = tmp / f"before-{scenario}", tmp / f"after-{scenario}"
            same = all((b / f).read_bytes() == (a / f).read_bytes() for f in FILES)
            med = {n: round(statistics.median(r["cpu_s"] for r in rows[n]), 3) for n in rows}
            out[scenario] = {"runs": rows, "median_cpu_s": med, "identical": same,
                             "speedup_cpu": round(med["before"] / med["after"], 3)}
            sys.stdout.write(f"{scenario}: command CPU s before {med['before']} / after {med['after']} "
                             f"(x{out[scenario]['speedup_cpu']}); identical {same}\n")
    out["load_average_end"] = os.getloadavg()
    write_json(args.out, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
