"""``kbplanner init MODEL.ifc --out DIR``: one command from an IFC file to a complete, runnable project.

``kbplanner init MODEL.ifc --task frame-interior-walls --out DIR [--storey NAME] [--walls ID,...]
[--max-walls N] [--seed S] [--force]`` derives stud-frame panels for the chosen partition walls (into a
copy of the IFC), a site layout, workers, jobsite, a schedule scaffold and the scenarios
``storage-inside`` / ``storage-outside`` (:mod:`kbplanner.scale.project_init`), and prints which walls
were chosen and why the others were not. Each scenario's storage proposals are planned as ``kbplanner
plan`` plans them (B1-B4; ``--no-plan-check`` skips it) and the best kept. Exit 0 when written and
every frame is installable; 1 when no wall qualifies (nothing written, the reason per wall) or when
the kept proposal of a scenario cannot install some frames (written, each such frame with its reason
and fix); 2 on bad input.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.cli.arguments import add_force, check_out, int_at_least, seed_int
from kbplanner.scale.init_tasks import TASK_TYPES

if TYPE_CHECKING:

    from kbplanner.scale.project_init import InitResult

SHOWN = 20  # walls not chosen listed one by one; the rest summarised by reason


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "init", help="set up a complete project (frames, site, schedule, scenarios) from an IFC file"
    )
    p.add_argument("ifc", type=Path, help="the IFC model (IFC2X3, IFC4, IFC4X3); it is only read")
    p.add_argument("--out", type=Path, required=True, help="project directory to write (new or empty)")
    p.add_argument(
        "--task",
        default="frame-interior-walls",
        help="task type (" + ", ".join(TASK_TYPES) + ") or a task specification id of that kind "
        "(default frame-interior-walls)",
    )
    p.add_argument(
        "--storey",
        help="the storey to frame (name or GlobalId; default: the lowest storey with "
        "qualifying walls and a door)",
    )
    p.add_argument("--walls", help="only these walls (GlobalIds or names, comma-separated)")
    p.add_argument(
        "--max-walls",
        type=int_at_least(1, 1000),
        default=8,
        help="at most this many walls, nearest the entrance first (default 8)",
    )
    p.add_argument("--seed", type=seed_int, default=0, help="the project's simulation seed (default 0)")
    p.add_argument(
        "--no-plan-check",
        action="store_true",
        help="write the first storage placement of each scenario without planning it (faster; by default "
        "each proposal is planned as `kbplanner plan` does and the best of up to 3 is kept)",
    )
    add_force(p)
    p.set_defaults(func=run)


def report(r: InitResult) -> list[str]:
    """The console lines of a result."""
    lines = [
        f"{r.source.name}: task {r.task} ({r.specification}), storey {r.storey}"
        + (f", entrance {r.entrance}" if r.entrance else "")
    ]
    chosen = r.chosen
    lines.append(
        f"  walls chosen: {len(chosen)} of {len(r.walls)}; frames: {len(r.frames)}"
        + (
            f" ({min(f.mass_kg for f in r.frames):.1f}-{max(f.mass_kg for f in r.frames):.1f} kg)"
            if r.frames
            else ""
        )
    )
    for w in chosen:
        lost = f", {w.lost_m:.2f} m left in short pieces" if w.lost_m > 0.005 else ""
        lines.append(f"    {w.global_id} {w.name!r}: {len(w.panels)} panels{lost}")
    others = [w for w in r.walls if not w.chosen]
    if others:
        lines.append(f"  walls not chosen: {len(others)}")
        on_storey = [w for w in others if w.storey == r.storey]
        for w in on_storey[:SHOWN]:
            lines.append(f"    {w.global_id} {w.name!r}: {w.reason}")
        rest = Counter(_kind(w.reason) for w in others if w not in on_storey[:SHOWN])
        for reason, n in sorted(rest.items()):
            lines.append(f"    {n} more: {reason}")
    for key, n in r.scenarios.items():
        c = r.checks.get(key)
        planned = f"; plan (B1-B4): {c.installable} of {c.total} frames installable" if c is not None else ""
        lines.append(f"  scenario {key}: {n} frame storage(s){planned}")
    lines += [f"  note: {n}" for n in r.notes]
    return lines


def _kind(reason: str) -> str:
    return reason.split(" (", 1)[0] if reason.startswith(("on storey", "beyond")) else reason


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from kbplanner.cli.progress import status
    from kbplanner.scale.project_init import init_project

    check_out(args.out)
    walls = [w.strip() for w in (args.walls or "").split(",") if w.strip()]
    with status(Console(stderr=True), f"reading {args.ifc}") as say:
        r = init_project(
            args.ifc,
            args.out,
            task=args.task,
            storey=args.storey,
            walls=walls,
            max_walls=args.max_walls,
            seed=args.seed,
            force=args.force,
            check_plan=not args.no_plan_check,
            progress=say,
        )
    lines = report(r)
    if not r.written:
        lines.append(
            f"Negative result: no wall of {r.source.name} qualifies for {r.task}; nothing written "
            "(the reasons are above). Fix: choose another --storey, or name the walls to frame with "
            "--walls GlobalId,... (a wall named there is framed even when its Pset_WallCommon says "
            "IsExternal or LoadBearing; the geometric rules still apply)"
        )
        sys.stdout.write("\n".join(lines) + "\n")
        return 1
    lines += [
        f"  wrote {r.directory} ({len(r.files)} files) in {r.seconds:.1f} s",
        f"  next: kbplanner requirements {r.directory}",
    ]
    failing = [(key, f) for key, c in r.checks.items() for f in c.failures]
    if r.scenarios:
        first = next(iter(r.scenarios))
        lines += [
            f"        kbplanner validate {r.directory} --scenario {first}",
            f"        kbplanner run {r.directory} --scenario {first}",
        ]
    if failing:
        keys = sorted({k for k, _f in failing})
        lines.append(
            f"Negative result: the plan of {', '.join(keys)} (the best of the storage proposals tried) "
            f"cannot install {len(failing)} frame(s); the project is written, each one with its reason:"
        )
        lines += [f"  {key}: {f.label}: {f.reason}\n      fix: {f.fix}" for key, f in failing]
    sys.stdout.write("\n".join(lines) + "\n")
    return 1 if failing else 0
