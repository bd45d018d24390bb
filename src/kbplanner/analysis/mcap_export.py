"""MCAP out (B5 run, for robotics viewers such as Foxglove): a run directory as an MCAP file.

Writes, with Foxglove's well-known protobuf schemas (``foxglove-schemas-protobuf``) through the
``mcap`` / ``mcap-protobuf-support`` libraries:

* ``/tf`` (``foxglove.FrameTransforms``), one message per sample of ``trajectories.csv``: ``world`` ->
  ``base_link`` (the robot base) and ``world`` -> ``worker/<name>`` for every worker on site;
* ``/map`` (``foxglove.Grid``), once: the occupancy map of the task's storey (100 occupied, 0 free);
* ``/lidar`` (``foxglove.LaserScan``, frame ``base_link``), at ``scan_hz``: 2D scans with the robot's
  scanner (field of view, resolution, ranges of the robot table), reconstructed from the occupancy map
  and the recorded worker positions (0.25 m body radius): the run record keeps no scans, and this is
  the static map plus the workers, not PyBullet's 3D geometry;
* ``/events`` (``foxglove.Log``), one message per line of ``events.jsonl`` (stops and failures as
  warnings and errors).

Time stamps are the world date of the task plus the simulated time, so the same run gives the same file.
"""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.Grid_pb2 import Grid
from foxglove_schemas_protobuf.LaserScan_pb2 import LaserScan
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.Vector2_pb2 import Vector2
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3
from google.protobuf.timestamp_pb2 import Timestamp
from mcap_protobuf.writer import Writer
from scipy.ndimage import distance_transform_edt

from kbplanner.analysis.run_record import RunRecord
from kbplanner.core.errors import KbplannerError
from kbplanner.core.outputs import atomic_write_bytes
from kbplanner.robot.lidar import LidarSpec
from kbplanner.world.occupancy import OccupancyGrid

WORKER_RADIUS_M = 0.25
_WARN = {"stop", "step_failed", "resume"}
_ERROR = {"element_failed"}
TOPICS = ("/tf", "/map", "/lidar", "/events")


@dataclass
class McapWritten:
    """What :func:`export_mcap` wrote: messages per topic."""

    path: Path
    counts: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def _stamp(ns: int) -> Timestamp:
    ts = Timestamp()
    ts.FromNanoseconds(ns)
    return ts


def _quat(yaw: float) -> Quaternion:
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0))


def clearance(grid: OccupancyGrid) -> np.ndarray[Any, np.dtype[np.float64]]:
    """Per cell, the distance (m) from its centre to the nearest occupied cell's centre (0 when occupied)."""
    return np.asarray(distance_transform_edt(~grid.occupied), dtype=np.float64) * grid.resolution


FloatArray = np.ndarray[Any, np.dtype[np.float64]]


def grid_scan(grid: OccupancyGrid, x: float, y: float, yaw: float, spec: LidarSpec,
              workers: list[tuple[float, float]], free: FloatArray | None = None) -> FloatArray:
    """Ranges of one 2D scan from (x, y, yaw) in the occupancy grid and among worker discs (inf: none).

    Rays march by the clearance of the cell they are in (``free``, :func:`clearance`) less one cell, at
    least half a cell, and stop in the first occupied cell: exact to a cell, a few steps per ray.
    """
    free = clearance(grid) if free is None else free
    res = grid.resolution
    angles = yaw + spec.angles()
    ux, uy = np.cos(angles), np.sin(angles)
    ny, nx = grid.shape
    ranges = np.full(angles.shape, np.inf)
    r = np.full(angles.shape, spec.range_min_m)
    active = np.arange(angles.size)
    while active.size:
        ix = np.floor((x + ux[active] * r[active] - grid.origin[0]) / res).astype(np.int64)
        iy = np.floor((y + uy[active] * r[active] - grid.origin[1]) / res).astype(np.int64)
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny) & (r[active] <= spec.range_max_m)
        d = np.zeros(active.size)
        d[inside] = free[iy[inside], ix[inside]]
        hit = inside & (d <= 0.0)
        ranges[active[hit]] = r[active[hit]]
        go = inside & ~hit
        r[active[go]] += np.maximum(d[go] - res, 0.5 * res)
        active = active[go]
    for wx, wy in workers:
        dx, dy = wx - x, wy - y
        t = dx * ux + dy * uy
        perp2 = dx * dx + dy * dy - t * t
        inside_disc = perp2 <= WORKER_RADIUS_M ** 2
        t_hit = t - np.sqrt(np.clip(WORKER_RADIUS_M ** 2 - perp2, 0.0, None))
        ok = inside_disc & (t_hit >= spec.range_min_m) & (t_hit <= spec.range_max_m)
        ranges = np.where(ok & (t_hit < ranges), t_hit, ranges)
    return ranges


def _grid_message(grid: OccupancyGrid, ns: int) -> Grid:
    _ny, nx = grid.shape
    data = np.where(grid.occupied, 100, 0).astype(np.uint8)  # row 0 is the bottom row, as Grid expects
    return Grid(timestamp=_stamp(ns), frame_id="world",
                pose=Pose(position=Vector3(x=grid.origin[0], y=grid.origin[1], z=0.0),
                          orientation=_quat(0.0)),
                column_count=nx, cell_size=Vector2(x=grid.resolution, y=grid.resolution),
                row_stride=nx, cell_stride=1,
                fields=[PackedElementField(name="occupancy", offset=0, type=PackedElementField.UINT8)],
                data=data.tobytes())


def _log(event: dict[str, Any], ns: int) -> Log:
    kind = str(event.get("kind", ""))
    level = Log.ERROR if kind in _ERROR else Log.WARNING if kind in _WARN else Log.INFO
    parts = [kind]
    if event.get("element"):
        parts.append(f"element {event['element']}")
    if event.get("action"):
        parts.append(f"'{event['action']}'")
    details = event.get("details") or {}
    if details:
        parts.append(json.dumps(details, sort_keys=True))
    return Log(timestamp=_stamp(ns), level=level, message=": ".join([parts[0], " ".join(parts[1:])])
               if len(parts) > 1 else parts[0], name="kbplanner.executor", file="events.jsonl",
               line=int(event.get("step") or 0))


def export_mcap(rec: RunRecord, out: Path, *, grid: OccupancyGrid | None, start: datetime,
                lidar: LidarSpec | None, scan_hz: float = 2.0) -> McapWritten:
    """Write ``rec`` to ``out`` as MCAP (atomically); see the module docstring for the topics."""
    if not (math.isfinite(scan_hz) and 0.0 < scan_hz <= 50.0):
        raise KbplannerError(f"scan rate {scan_hz} Hz out of range", element="--scan-hz",
                             fix="give a rate in (0, 50] Hz")
    t0 = int(start.replace(tzinfo=UTC).timestamp()) * 1_000_000_000
    tr = rec.trajectories
    result = McapWritten(path=out, counts=dict.fromkeys(TOPICS, 0))

    def ns(t_s: float) -> int:
        return t0 + round(float(t_s) * 1e9)

    buf = io.BytesIO()
    with Writer(buf) as w:
        if grid is not None:
            w.write_message("/map", _grid_message(grid, t0), log_time=t0, publish_time=t0)
            result.counts["/map"] += 1
        else:
            result.notes.append("no occupancy map (project not available): no /map and no /lidar")
        if lidar is None and grid is not None:
            result.notes.append("robot's scanner not in the robot table: no /lidar")
        next_scan = 0.0
        free = clearance(grid) if grid is not None else None
        for i, t in enumerate(tr.t):
            stamp = ns(t)
            transforms = [FrameTransform(timestamp=_stamp(stamp), parent_frame_id="world",
                                         child_frame_id="base_link",
                                         translation=Vector3(x=float(tr.x[i]), y=float(tr.y[i]), z=0.0),
                                         rotation=_quat(float(tr.yaw[i])))]
            here: list[tuple[float, float]] = []
            for name, (wx, wy) in sorted(tr.workers.items()):
                if math.isfinite(wx[i]) and math.isfinite(wy[i]):
                    here.append((float(wx[i]), float(wy[i])))
                    transforms.append(FrameTransform(
                        timestamp=_stamp(stamp), parent_frame_id="world", child_frame_id=f"worker/{name}",
                        translation=Vector3(x=float(wx[i]), y=float(wy[i]), z=0.0), rotation=_quat(0.0)))
            w.write_message("/tf", FrameTransforms(transforms=transforms), log_time=stamp, publish_time=stamp)
            result.counts["/tf"] += 1
            if grid is not None and lidar is not None and t + 1e-9 >= next_scan:
                ranges = grid_scan(grid, float(tr.x[i]), float(tr.y[i]), float(tr.yaw[i]), lidar, here, free)
                w.write_message("/lidar", LaserScan(
                    timestamp=_stamp(stamp), frame_id="base_link", pose=Pose(position=Vector3(),
                                                                             orientation=_quat(0.0)),
                    start_angle=-lidar.fov_rad / 2, end_angle=lidar.fov_rad / 2, ranges=ranges.tolist()),
                    log_time=stamp, publish_time=stamp)
                result.counts["/lidar"] += 1
                next_scan += 1.0 / scan_hz
                while next_scan <= t:
                    next_scan += 1.0 / scan_hz
        for event in rec.events:
            stamp = ns(float(event.get("t_s") or 0.0))
            w.write_message("/events", _log(event, stamp), log_time=stamp, publish_time=stamp)
            result.counts["/events"] += 1
    atomic_write_bytes(out, buf.getvalue())
    return result


def read_mcap_counts(path: Path) -> dict[str, int]:
    """Messages per topic of an MCAP file, decoded with the mcap libraries (every message is parsed)."""
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    counts: dict[str, int] = {}
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _schema, channel, _message, _proto in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    return counts
