"""``kbplanner world PROJECT --date D [--scenario S] [--task ID] --out DIR``: the world at a date (A6).

Builds the simulation world of a project (one scenario) at a date and writes, atomically (the
directory appears only when complete): ``world_existing.sdf`` + ``meshes/``, one
``element_<GlobalId>.sdf`` per element to install, ``world.glb``, ``map.pgm`` + ``map.yaml`` (ROS
map_server) of the task's storey, and ``world.json``. Prints a summary. Exit 2 on bad input (a date
that is not ISO, an unknown task, scenario or storey).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from kbplanner.cli.arguments import add_force, check_out, positive_float
from kbplanner.core.errors import KbplannerError, WorldError
from kbplanner.world.map_settings import MapSettings

MAP_LINES = 10  # level regions and map notes printed (all are in world.json)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "world",
        help="the world at a date: SDF, glTF, occupancy map (ROS) and world.json of a scenario (A6)",
    )
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--date", help="ISO date or date-time, local site time (default: [simulation] date)")
    p.add_argument("--scenario", help="scenario overlay to apply (default: the bare model)")
    p.add_argument("--task", help="robotized task whose elements wait at their storage "
                                  "(default: [simulation] task)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="output folder: new, or one kbplanner wrote (replaced)")
    add_force(p)
    p.add_argument("--storey", help="storey (label or IRI) of the occupancy map (default: the task's)")
    p.add_argument("--resolution", type=positive_float, default=MapSettings.resolution_m,
                   help="map cell size in metres (default %(default)s)")
    p.add_argument("--robot-height", type=positive_float, default=MapSettings.robot_height_m,
                   help="top of the map's height band above the floor, metres (default %(default)s)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from kbplanner.core.outputs import run_directory
    from kbplanner.model.dates import parse_date
    from kbplanner.project import Project
    from kbplanner.world.build import build_world
    from kbplanner.world.exports import export_world
    from kbplanner.world.maps import map_summary

    check_out(args.out)
    settings = MapSettings(resolution_m=args.resolution, robot_height_m=args.robot_height)
    at = parse_date(args.date) if args.date is not None else None  # checked before the project load
    project = Project.load(args.project, scenario=args.scenario)
    if at is None:
        if project.manifest.simulation.get("date") is None and args.task is None:
            raise WorldError("no --date and no [simulation] date in project.toml", file=project.manifest.path,
                             element="--date", fix="give --date YYYY-MM-DD[THH:MM]")
        at = project.world_date(args.task)
    world = build_world(project, at, args.task)
    if args.storey is not None and world.storey(args.storey) is None:
        known = ", ".join(s.label for s in world.storeys) or "none"
        raise KbplannerError(f"unknown storey {args.storey!r}", file=project.manifest.path,
                             element=args.storey, fix=f"choose one of: {known}")
    with run_directory(args.out) as stage:
        export = export_world(world, stage, settings=settings, storey=args.storey)
    counts = world.summary()
    out = [f"world of {world.project} ({world.scenario or 'bare model'}) at {world.at.isoformat()}"
           + (f", task {world.task_id}" if world.task_id else ", no task")]
    out.append(f"  static elements: {counts['static_elements']} in {counts['static_groups']} merged groups "
               f"({counts['in_progress_static']} in progress)")
    out.append(f"  open doors (no obstacle): {counts['open_doors']}")
    out.append(f"  absent (not started): {counts['absent_not_started']}")
    out.append(f"  task elements at storage: {counts['task_elements_at_storage']}")
    by_reason: dict[str, list[str]] = {}
    for o in world.unplaced():
        by_reason.setdefault(o.reason, []).append(o.label)
    for reason, labels in sorted(by_reason.items()):
        out.append(f"    not placed: {len(labels)} ({', '.join(sorted(labels)[:3])}"
                   f"{', ...' if len(labels) > 3 else ''}): {reason}")
    out.append(f"  site objects: {counts['solid_site_objects']} solid, {counts['areas']} areas; "
               f"workers: {counts['workers']}")
    if export.map is not None:
        out.append(f"  map: {map_summary(export.map)}")
        out += [f"    {region.text()}" for region in export.map.levels[:MAP_LINES]]
        out += [f"    note: {note}" for note in export.map.notes[:MAP_LINES]]
        more = max(0, len(export.map.levels) - MAP_LINES) + max(0, len(export.map.notes) - MAP_LINES)
        if more:
            out.append(f"    ... and {more} more in world.json (map.levels, map.notes)")
    out.append(f"  wrote {len(export.files)} files to {args.out}")
    sys.stdout.write("\n".join(out) + "\n")
    return 0
