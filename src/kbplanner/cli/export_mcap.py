"""``kbplanner export-mcap RUN_DIR --out run.mcap``: a simulation run as MCAP for Foxglove (B5 output).

Robot and worker poses as frame transforms (``/tf``), the task storey's occupancy map (``/map``), 2D
lidar scans reconstructed from that map and the workers (``/lidar``) and the run's events (``/events``),
with Foxglove's schemas (:mod:`kbplanner.analysis.mcap_export`). The project named in the run's manifest
gives the map, the scanner and the world date; without it, only ``/tf`` and ``/events`` are written.
``kbplanner simulate ... --mcap FILE`` writes the same file right after the run.
"""

from __future__ import annotations

import argparse
import math
import sys
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.core.errors import KbplannerError

if TYPE_CHECKING:
    from kbplanner.analysis.mcap_export import McapWritten
    from kbplanner.robot.lidar import LidarSpec
    from kbplanner.world.occupancy import OccupancyGrid


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("export-mcap", help="write a simulation run directory as MCAP (Foxglove schemas)",
                       description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run", type=Path, metavar="RUN_DIR", help="a directory written by 'kbplanner simulate'")
    p.add_argument("--out", type=Path, required=True, metavar="FILE", help="the MCAP file to write")
    p.add_argument("--scan-hz", type=float, default=2.0, help="lidar scans per simulated second (default 2)")
    p.set_defaults(func=run)


def scanner(robot_id: str) -> LidarSpec | None:
    """The 2D scanner of a robot of the robot table (ids with '-' or '_'), else None."""
    from kbplanner.robot.lidar import LidarSpec
    from kbplanner.robot.robot_model import load_robot_specs

    specs = load_robot_specs()
    spec = specs.get(robot_id) or specs.get(robot_id.replace("-", "_"))
    if spec is None:
        return None
    params = spec.base.lidar.params
    return LidarSpec(fov_rad=math.radians(params.get("fov_deg", 270.0)),
                     step_rad=math.radians(params.get("angular_resolution_deg", 0.5)),
                     range_min_m=params.get("range_min_m", 0.1), range_max_m=params.get("range_max_m", 20.0))


def write_run_mcap(run_dir: Path, out: Path, *, grid: OccupancyGrid | None = None,
                   start: datetime | None = None, scan_hz: float = 2.0) -> McapWritten:
    """MCAP of a run directory; the map and date come from the project when not given."""
    from kbplanner.analysis.mcap_export import export_mcap  # mcap, protobuf: only when asked
    from kbplanner.analysis.run_record import RunRecord

    rec = RunRecord.load(run_dir)
    task = str(rec.manifest.get("task") or "") or None
    project_dir = rec.manifest.get("project_dir")
    if (grid is None or start is None) and project_dir and Path(project_dir).is_dir():
        from kbplanner.project import Project
        from kbplanner.world.build import build_world
        from kbplanner.world.maps import storey_map

        project = Project.load(project_dir, scenario=rec.scenario)
        if start is None:
            start = project.world_date(task)
        if grid is None:
            grid = storey_map(build_world(project, start, task)).grid
    robot = str(rec.manifest.get("robot") or "")
    written = export_mcap(rec, out, grid=grid, start=start or datetime(2000, 1, 1),
                          lidar=scanner(robot) if robot else None, scan_hz=scan_hz)
    if start is None:
        written.notes.append("project not available: time stamps start at 2000-01-01")
    return written


def report(written: McapWritten) -> None:
    """Say what was written (stderr)."""
    counts = ", ".join(f"{t} {n}" for t, n in written.counts.items())
    sys.stderr.write(f"wrote MCAP {written.path}: {counts}\n")
    for note in written.notes:
        sys.stderr.write(f"  {note}\n")


def run(args: argparse.Namespace) -> int:
    if args.out.exists() and args.out.is_dir():
        raise KbplannerError("--out is a directory", file=args.out, fix="give a file name, e.g. run.mcap")
    report(write_run_mcap(args.run, args.out, scan_hz=args.scan_hz))
    return 0
