"""B4 speed before/after (issue 14, item 2): the case study's ``kbplanner plan`` (B1-B4), run by a
baseline's sources and by this tree's, alternately, in one run of this script.

The baseline is a git ref (default ``main``) exported (``git archive``) into a temporary folder; both
run the same command with the same shared virtualenv, one after the other per round, with
``PYTHONPATH`` pointing at their sources::

    kbplanner plan data/case_study --scenario S --seed N --out DIR

Per scenario it records the command's wall and CPU seconds and peak memory (``os.wait4``), and the
CPU and wall seconds of B4 (``refine_plan``, timed by a wrapper around it, the same for both trees)
with the configuration-space builds made in it (``ConfigurationSpace.build`` counted by the wrapper)
and whether every file the command wrote but the run folder's marker is byte-identical
(``outputs_identical``; ``plan_diff``: per element, which steps' poses changed, from the first round; both
read this
tree's ``data/case_study``, as the outputs name the project folder). Ratios are
baseline / this tree (> 1: faster now), from the median over rounds; the load average is recorded
before and after (on a shared machine CPU seconds are the steadier figure).

With ``--generated SxU`` (e.g. ``1x2``) it also plans a generated building (``kbplanner
generate-building --storeys S --units-per-storey U``, by this tree's generator, into the temporary
folder; both trees plan that same folder) with its scenario (``storage-in-units``): a storey of
another layout, the pickup locations inside the units.

Usage: .venv/bin/python benchmarks/bench_refine.py [--before REF] [--scenario S ...] [--rounds N]
       [--generated SxU]
Prints a table and writes benchmarks/results/refine.json (or --out); ``bench_refine.py --table FILE``
prints the docs/scale.md table of a written result.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, run_measured, write_json

# ``python -m kbplanner ARGS`` with B4 (manipulation.refine_plan, never read from the refined-plan cache)
# timed in CPU and wall seconds, the
# configuration-space builds counted, and the CPU seconds of B4's parts (PARTS: each function's calls
# that are not within another of its calls; wrapped by the same code in both trees, also where a module
# imported it by name), written to the file named by the first argument.
_TIMED = '''import json, sys, time
import kbplanner.planning.manipulation as m
from kbplanner.world.footprint import ConfigurationSpace
builds = [0]
build = ConfigurationSpace.build.__func__
def counted(cls, *args, **kwargs):
    builds[0] += 1
    return build(cls, *args, **kwargs)
ConfigurationSpace.build = classmethod(counted)
parts = {}
def part(name, owner, attr):
    raw = owner.__dict__[attr]
    fn = raw.__func__ if isinstance(raw, classmethod) else raw
    depth = [0]
    def wrapped(*args, **kwargs):
        if depth[0]:
            return fn(*args, **kwargs)
        depth[0] += 1
        c0 = time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            depth[0] -= 1
            got = parts.setdefault(name, [0, 0.0])
            got[0] += 1
            got[1] += time.process_time() - c0
    setattr(owner, attr, classmethod(wrapped) if isinstance(raw, classmethod) else wrapped)
    if not isinstance(owner, type):
        for mod in list(sys.modules.values()):
            if getattr(mod, "__name__", "").startswith("kbplanner") and getattr(mod, attr, None) is raw:
                setattr(mod, attr, wrapped)
for name, mod_name, owner_name, attr in PARTS:
    mod = sys.modules.get(mod_name) or __import__(mod_name, fromlist=["_"])
    part(name, getattr(mod, owner_name) if owner_name else mod, attr)
inner = m.refine_plan
def timed(*args, **kwargs):
    c0, w0, b0 = time.process_time(), time.perf_counter(), builds[0]
    try:
        return inner(*args, **kwargs)
    finally:
        with open(sys.argv[1], "w") as f:
            json.dump({"cpu_s": time.process_time() - c0, "wall_s": time.perf_counter() - w0,
                       "builds": builds[0] - b0,
                       "parts": {k: [v[0], round(v[1], 3)] for k, v in parts.items()}}, f)
m.refine_plan = timed
try:  # B4 is measured: a refined plan kept by an earlier run (planning/refine_cache.py) is not read
    import kbplanner.planning.refine_cache as rc
    rc._read = lambda path: None
    rc.refine_plan = timed
except ImportError:  # a tree without the cache
    pass
from kbplanner.cli import main
raise SystemExit(main(sys.argv[2:]))
'''
#: B4's parts timed: (name, module, class or "" for a module function, attribute). Present in both trees.
PARTS = (
    ("pick", "kbplanner.planning.grasp_poses", "PickSearch", "pick"),
    ("install", "kbplanner.planning.install_poses", "InstallSearch", "install"),
    ("IK", "kbplanner.robot.arm_ik", "", "solve_ik"),
    ("carry-leg check", "kbplanner.planning.carry_reach", "CarryReach", "way"),
    ("escape test", "kbplanner.planning.base_poses", "", "escapes"),
    ("configuration-space builds", "kbplanner.world.footprint", "ConfigurationSpace", "build"),
    ("labellings", "kbplanner.world.footprint", "ConfigurationSpace", "_labels_and_roots"),
)
_TIMED = _TIMED.replace("for name, mod_name, owner_name, attr in PARTS:",
                        f"for name, mod_name, owner_name, attr in {PARTS!r}:")


def _export(ref: str, into: Path) -> Path:
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src"


def _run(src: Path, scenario: str, seed: int, out: Path, log: Path, project: Path) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(src))
    step_file = log.with_suffix(".b4.json")
    # the same project folder for both trees: the outputs name it
    cmd = [sys.executable, "-c", _TIMED, str(step_file), "plan", str(project),
           "--scenario", scenario, "--seed", str(seed), "--out", str(out)]
    measured = run_measured(cmd, log=log, timeout_s=1800.0, env=env)
    if not step_file.is_file():
        tail = log.read_text()[-2000:]
        raise SystemExit(f"{' '.join(cmd)} did not run B4 (exit {measured['exit']}):\n{tail}")
    step = json.loads(step_file.read_text())
    return {"command_s": measured["seconds"], "exit": measured["exit"], "cpu_s": measured["cpu_s"],
            "peak_rss_mb": measured["peak_rss_mb"], "b4_s": round(step["wall_s"], 3),
            "b4_cpu_s": round(step["cpu_s"], 3), "b4_builds": step["builds"],
            **{f"part:{k}": v[1] for k, v in step.get("parts", {}).items()}}


def _median(rows: list[dict[str, Any]], key: str) -> float | None:
    values = [r[key] for r in rows if isinstance(r.get(key), (int, float))]
    return round(statistics.median(values), 3) if values else None


MARKER = ".kbplanner-run"  # the run folder's marker names the command and folder: not compared


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.name != MARKER}


def plan_diff(before: Path, after: Path) -> dict[str, Any]:
    """Per element, what B4 changed between two ``plan.json``: steps whose feasibility, base pose, arm
    poses or inputs differ, the largest base-pose move (m, rad) and whether the element is feasible."""
    b_plan = json.loads((before / "plan.json").read_text(encoding="utf-8"))
    a_plan = json.loads((after / "plan.json").read_text(encoding="utf-8"))
    labels = {e["iri"]: e["label"] for e in a_plan["elements"]}
    out: dict[str, Any] = {"order_same": [s["element"] for s in b_plan["steps"]]
                           == [s["element"] for s in a_plan["steps"]], "elements": {}}
    b_steps = {(s["element"], s["skill_id"]): s for s in b_plan["steps"]}
    for step in a_plan["steps"]:
        key = (step["element"], step["skill_id"])
        row = out["elements"].setdefault(labels.get(step["element"], step["element"]), {
            "changed_steps": [], "base_move_m": 0.0, "base_turn_rad": 0.0,
            "feasible_before": True, "feasible_after": True})
        old = b_steps.get(key)
        row["feasible_after"] = row["feasible_after"] and bool(step["feasible"])
        if old is None:
            row["changed_steps"].append(f"{step['skill_id']} (new)")
            continue
        row["feasible_before"] = row["feasible_before"] and bool(old["feasible"])
        fields = [f for f in ("feasible", "base_pose", "arm_poses", "inputs") if old.get(f) != step.get(f)]
        if fields:
            row["changed_steps"].append(f"{step['skill_id']}: {', '.join(fields)}")
        bp, ap = old.get("base_pose"), step.get("base_pose")
        if bp and ap:
            row["base_move_m"] = round(max(row["base_move_m"], math.dist((bp["x"], bp["y"]),
                                                                         (ap["x"], ap["y"]))), 3)
            turn = abs((ap["yaw"] - bp["yaw"] + math.pi) % (2 * math.pi) - math.pi)
            row["base_turn_rad"] = round(max(row["base_turn_rad"], turn), 3)
    out["elements_changed"] = sum(bool(r["changed_steps"]) for r in out["elements"].values())
    out["feasible_before"] = sum(r["feasible_before"] for r in out["elements"].values())
    out["feasible_after"] = sum(r["feasible_after"] for r in out["elements"].values())
    return out


def bench(before_src: Path, after_src: Path, scenario: str, seed: int, rounds: int, tmp: Path,
          project: Path = REPO / "data" / "case_study", name: str = "case study") -> dict[str, Any]:
    runs: dict[str, list[dict[str, Any]]] = {"before": [], "after": []}
    identical = True
    tag = f"{project.name}-{scenario}"
    for k in range(rounds):
        outs = {}
        for label, src in (("before", before_src), ("after", after_src)):
            out = tmp / f"{tag}-{label}-{k}"
            runs[label].append(_run(src, scenario, seed, out, tmp / f"{tag}-{label}-{k}.log", project))
            outs[label] = out
        identical = identical and _files(outs["before"]) == _files(outs["after"])
        if k == 0:
            diff = plan_diff(outs["before"], outs["after"])
    row: dict[str, Any] = {"project": name, "scenario": scenario, "seed": seed, "rounds": rounds,
                           "outputs_identical": identical, "plan_diff": diff}
    for label in ("before", "after"):
        rs = runs[label]
        keys = ("command_s", "cpu_s", "peak_rss_mb", "b4_s", "b4_cpu_s", "b4_builds",
                *(f"part:{name}" for name, *_ in PARTS))
        row[label] = {key: _median(rs, key) for key in keys}
        row[label]["runs"] = rs
    b, a = row["before"], row["after"]
    for key in ("command_s", "cpu_s", "b4_s", "b4_cpu_s"):
        row[f"speedup_{key}"] = round(b[key] / a[key], 2) if a[key] else None
    return row


def table(result: dict[str, Any]) -> str:
    """The docs/scale.md table (Markdown) of a result written by this script."""
    lines = ["| scenario | command CPU before / after | B4 CPU before / after | B4 wall before / after | "
             "configuration-space builds in B4 | peak memory | identical |",
             "| --- | ---: | ---: | ---: | ---: | ---: | --- |"]
    for r in result["scenarios"]:
        b, a = r["before"], r["after"]
        lines.append(f"| {_where(r)} | {b['cpu_s']:.1f} / {a['cpu_s']:.1f} s (x{r['speedup_cpu_s']}) | "
                     f"{b['b4_cpu_s']:.1f} / {a['b4_cpu_s']:.1f} s (x{r['speedup_b4_cpu_s']}) | "
                     f"{b['b4_s']:.1f} / {a['b4_s']:.1f} s (x{r['speedup_b4_s']}) | "
                     f"{b['b4_builds']:.0f} / {a['b4_builds']:.0f} | "
                     f"{b['peak_rss_mb']:.0f} / {a['peak_rss_mb']:.0f} MB | "
                     f"{'yes' if r['outputs_identical'] else 'no'} |")
    start, end = result["load_average_start"][0], result["load_average_end"][0]
    lines.append(f"\n(before = `{result['before']}`; load average {start:.1f} -> {end:.1f})")
    names = [name for name, *_ in PARTS if any(r["before"].get(f"part:{name}") is not None
                                                   for r in result["scenarios"])]
    if names:  # B4's parts, CPU seconds (a part's calls within another part are in both)
        heads = " | ".join(_where(r) for r in result["scenarios"])
        lines += ["", f"| B4 part, CPU s before / after | {heads} |",
                  "| --- |" + " ---: |" * len(result["scenarios"])]
        for name in names:
            cells = []
            for r in result["scenarios"]:
                b, a = r["before"].get(f"part:{name}"), r["after"].get(f"part:{name}")
                cells.append(f"{b:.2f} / {a:.2f}" if b is not None and a is not None else "-")
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _where(r: dict[str, Any]) -> str:
    project = r.get("project", "case study")
    return r["scenario"] if project == "case study" else f"{project}, {r['scenario']}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--rounds", type=int, default=1, help="before/after pairs per scenario (median)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "refine.json")
    ap.add_argument("--table", type=Path, help="print the docs table of this written result and stop")
    ap.add_argument("--generated", metavar="SxU", help="also plan a generated building, S storeys x U units")
    args = ap.parse_args(argv)
    if args.table:
        sys.stdout.write(table(json.loads(args.table.read_text(encoding="utf-8"))))
        return 0
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    load_before = list(os.getloadavg())
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        before_src = _export(args.before, tmp)
        rows = [bench(before_src, REPO / "src", s, args.seed, args.rounds, tmp) for s in scenarios]
        if args.generated:
            storeys, units = (int(v) for v in args.generated.lower().split("x"))
            project = tmp / f"generated-{storeys}x{units}"
            subprocess.run([sys.executable, "-m", "kbplanner", "generate-building", "--storeys", str(storeys),
                            "--units-per-storey", str(units), "--out", str(project)], check=True,
                           capture_output=True, env=dict(os.environ, PYTHONPATH=str(REPO / "src")))
            rows.append(bench(before_src, REPO / "src", "storage-in-units", args.seed, args.rounds, tmp,
                              project, f"generated {storeys} x {units}"))
    out = {"machine": machine_info(("python", "cpus", "platform")), "before": args.before,
           "load_average_start": load_before, "load_average_end": list(os.getloadavg()), "scenarios": rows}
    write_json(args.out, out)
    w = sys.stdout.write
    w(f"{'scenario':16} {'command s':>15} {'command CPU s':>15} {'B4 s':>15} {'B4 CPU s':>15} {'builds':>9} "
      f"{'peak MB':>11} {'same':>5}\n")
    for r in rows:
        b, a = r["before"], r["after"]
        if r["project"] != "case study":
            w(f"{r['project']}:\n")
        w(f"{r['scenario']:16} {b['command_s']:6.1f} / {a['command_s']:6.1f} "
          f"{b['cpu_s']:6.1f} / {a['cpu_s']:6.1f} "
          f"{b['b4_s']:6.1f} / {a['b4_s']:6.1f} {b['b4_cpu_s']:6.1f} / {a['b4_cpu_s']:6.1f} "
          f"{b['b4_builds']:4.0f}/{a['b4_builds']:<4.0f} {b['peak_rss_mb']:5.0f}/{a['peak_rss_mb']:<5.0f} "
          f"{'yes' if r['outputs_identical'] else 'no':>5}\n")
        w(f"{'':16} speed-up: command x{r['speedup_command_s']} (CPU x{r['speedup_cpu_s']}), "
          f"B4 x{r['speedup_b4_s']} (CPU x{r['speedup_b4_cpu_s']})\n")
        d = r["plan_diff"]
        order = "same" if d["order_same"] else "changed"
        w(f"{'':16} plan: {d['elements_changed']} of {len(d['elements'])} elements changed, feasible "
          f"{d['feasible_before']} -> {d['feasible_after']}, order {order}\n")
        for label, e in d["elements"].items():
            if e["changed_steps"]:
                w(f"{'':18}{label}: {'; '.join(e['changed_steps'])} (base moved {e['base_move_m']} m, "
                  f"turned {e['base_turn_rad']} rad)\n")
    w(f"load average {load_before[0]:.2f} -> {out['load_average_end'][0]:.2f}; wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
