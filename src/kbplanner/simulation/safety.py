"""B5 safety record: contact events while the run goes, and the safety summary of ``metrics.json``.

**Contact is an event, never a distance.** :class:`ContactMonitor` checks every control period,
once after the robot moved and once after the workers moved, whether a worker's disc overlaps the
robot's hazard footprint (:mod:`kbplanner.simulation.separation`). The first period of an overlap is
a ``collision`` event (worker, where, the robot's speed - its fastest footprint point - and the
worker's speed, the carried element, and the cause: ``robot moved into the worker`` or ``worker
walked into the robot``); its end a ``collision_end`` event with the duration.

:func:`safety_summary` computes the run's safety figures from what ``trajectories.csv`` holds (the
recorded, rounded values, so that an independent script reading the file gets the same numbers):
per worker and overall the minimum separation, the time below 1 m and below the ISO/TS 15066
protective separation distance S_p at the robot's recorded speed, plus the collisions, stops,
slow-downs and time lost from the events and the navigation steps.

**Floors.** Workers walk on the ground; when the robot works on a floor more than
:data:`~kbplanner.simulation.sim_env.FLOOR_GAP_M` above or below it (an upper storey), nobody is on
its floor: no contact is checked, the separations include the storeys between (``dz_m``), and
``workers_off_robot_floor`` counts the workers out of the robot's hazard scope.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from kbplanner.simulation.separation import (
    MODE_RECT,
    WORKER_RADIUS_M,
    SsmParameters,
    distance_at_poses,
    reach_m,
    rects_distance,
    robot_speed,
    time_below_s,
)
from kbplanner.simulation.sim_env import FLOOR_GAP_M, SimEnv
from kbplanner.simulation.social_force import Obstacle
from kbplanner.world.footprint import Rect

FIXED_THRESHOLD_M = 1.0
Pose = tuple[float, float, float]


class ContactMonitor:
    """Overlap of workers with the robot's hazard footprint, as events (see module docstring)."""

    def __init__(
        self,
        env: SimEnv,
        hazard: Callable[[], Obstacle],
        emit: Callable[..., None],
        carried: Callable[[], str],
    ) -> None:
        self.env = env
        self.hazard = hazard
        self.emit = emit
        self.carried = carried
        self.inside: dict[str, float] = {}
        self.count = 0
        self._prev_pose = env.base_pose()
        self._prev_xy = env.worker_xy_list()
        # this period's robot move: the poses before and after, and the footprint (its speed is worked
        # out when a collision event needs it)
        self._move: tuple[Pose, Pose, Sequence[Rect]] | None = None

    @property
    def _robot_speed(self) -> float:
        """The robot's speed in this period: translation plus yaw rate times the footprint's reach."""
        if self._move is None:
            return 0.0
        prev, pose, rects = self._move
        reach = reach_m(rects)
        dyaw = math.atan2(math.sin(pose[2] - prev[2]), math.cos(pose[2] - prev[2]))
        return (math.hypot(pose[0] - prev[0], pose[1] - prev[1]) + abs(dyaw) * reach) * self.env.control_hz

    def after_robot(self) -> None:
        """Check after the robot's move in this period."""
        pose = self.env.base_pose()
        obs = self.hazard()
        self._move = (self._prev_pose, pose, obs.rects)
        self._prev_pose = pose
        self._check(obs, "robot moved into the worker")

    def after_workers(self) -> None:
        """Check after the workers' move in this period."""
        self._check(self.hazard(), "worker walked into the robot")
        self._prev_xy = self.env.worker_xy_list()

    def _check(self, obs: Obstacle, cause: str) -> None:
        env = self.env
        if not env.workers or not env.workers_on_robot_floor:
            return  # nobody, or everybody on another floor: no overlap is possible
        if not self.inside:  # nobody to see out: done when everyone is certainly clear of the footprint
            far = WORKER_RADIUS_M + reach_m(obs.rects) + 1e-6
            if env.nearest_centre_m(obs.pose[0], obs.pose[1]) > far:  # (all of them farther than far)
                return
        xy = env.worker_xy()
        d, _, _ = rects_distance(xy[:, 0], xy[:, 1], obs.pose, obs.rects)
        for k, w in enumerate(env.workers):
            overlap = float(d[k]) < WORKER_RADIUS_M
            if overlap and w.slug not in self.inside:
                self.inside[w.slug] = env.t
                self.count += 1
                wv = (
                    float(np.hypot(*(xy[k] - np.array(self._prev_xy[k], dtype=np.float64)))) * env.control_hz
                    if len(self._prev_xy) > k
                    else 0.0
                )
                self.emit(
                    "collision",
                    worker=w.slug,
                    cause=cause,
                    robot_speed_mps=round(self._robot_speed, 3),
                    worker_speed_mps=round(wv, 3),
                    penetration_m=round(WORKER_RADIUS_M - float(d[k]), 3),
                    x=round(float(xy[k, 0]), 3),
                    y=round(float(xy[k, 1]), 3),
                    carried=self.carried(),
                )
            elif not overlap and w.slug in self.inside and cause.startswith("worker"):
                t0 = self.inside.pop(w.slug)
                self.emit("collision_end", worker=w.slug, duration_s=round(env.t - t0, 3))


def _rects_of(footprints: Mapping[str, Any]) -> tuple[list[Rect], dict[str, dict[str, Rect]]]:
    def rect(d: Mapping[str, Any]) -> Rect:
        return Rect(
            float(d["cx"]), float(d["cy"]), float(d["length"]), float(d["width"]), float(d.get("yaw", 0))
        )

    robot = [rect(r) for r in footprints.get("robot", [])]
    elements = {
        gid: {m: rect(r) for m, r in modes.items()} for gid, modes in footprints.get("elements", {}).items()
    }
    return robot, elements


def separation_samples(
    x: np.ndarray,
    y: np.ndarray,
    yaw: np.ndarray,
    carried: Sequence[str],
    carry_mode: Sequence[str],
    workers: Mapping[str, tuple[np.ndarray, np.ndarray]],
    footprints: Mapping[str, Any],
    dz_m: float,
    radius_m: float = WORKER_RADIUS_M,
) -> dict[str, np.ndarray]:
    """{worker: separation per sample} of recorded samples: the one definition used by ``metrics.json``
    and the analysis (footprint of the base plus the carried element's carry-mode rectangle to the
    worker's disc, plus the storeys between, see :mod:`kbplanner.simulation.separation`)."""
    robot, elements = _rects_of(footprints)
    keys = []
    for gid, mode in zip(carried, carry_mode, strict=True):
        key = MODE_RECT.get(mode)
        keys.append((gid, key) if gid and key and key in elements.get(gid, {}) else ("", ""))
    groups: dict[tuple[str, str], list[int]] = {}
    for i, k in enumerate(keys):
        groups.setdefault(k, []).append(i)
    out: dict[str, np.ndarray] = {}
    for w, (wx, wy) in sorted(workers.items()):
        sep = np.empty(len(x))
        for carry, members in sorted(groups.items()):
            idx = np.array(members, dtype=np.int64)
            rects = robot if not carry[0] else [*robot, elements[carry[0]][carry[1]]]
            d = distance_at_poses(wx[idx], wy[idx], x[idx], y[idx], yaw[idx], rects)
            sep[idx] = np.maximum(np.hypot(d, dz_m) - radius_m, 0.0)
        out[w] = sep
    return out


def separations(
    csv_text: str, footprints: Mapping[str, Any], dz_m: float
) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """(t, robot speed, {worker: separation per sample}) from a trajectories.csv text."""
    rows = list(csv.reader(io.StringIO(csv_text)))
    header, body = rows[0], rows[1:]
    col = {c: i for i, c in enumerate(header)}

    def num(c: str) -> np.ndarray:
        return np.array([float(r[col[c]]) for r in body])

    t, x, y, yaw = num("t_s"), num("x"), num("y"), num("yaw")
    names = [c[:-2] for c in header if c.endswith("_x") and c[:-2] + "_y" in col and c != "x"]
    workers = {w: (num(w + "_x"), num(w + "_y")) for w in names}
    seps = separation_samples(x, y, yaw, [r[col["carried"]] for r in body],
                              [r[col["carry_mode"]] for r in body], workers, footprints, dz_m)
    return t, robot_speed(t, x, y), seps


def safety_summary(
    csv_text: str,
    footprints: Mapping[str, Any],
    dz_m: float,
    ssm: SsmParameters,
    events: Sequence[Mapping[str, Any]],
    navigation: Sequence[Mapping[str, Any]],
    monitoring: str,
) -> dict[str, Any]:
    """The ``safety`` section of metrics.json (see module docstring)."""
    t, speed, seps = separations(csv_text, footprints, dz_m)
    sp = ssm.separation_m(speed)
    per_worker = {}
    for w, s in sorted(seps.items()):
        k = int(np.argmin(s)) if len(s) else 0
        per_worker[w] = {
            "min_separation_m": round(float(s[k]), 3) if len(s) else None,
            "t_min_s": round(float(t[k]), 2) if len(s) else None,
            "time_below_1m_s": round(time_below_s(t, [s], FIXED_THRESHOLD_M), 2),
            "time_below_protective_s": round(time_below_s(t, [s], sp), 2),
        }
    allmin = min(
        (v["min_separation_m"] for v in per_worker.values() if v["min_separation_m"] is not None),
        default=None,
    )
    collisions = [
        {"t_s": e["t_s"], **{k: v for k, v in e["details"].items()}}
        for e in events
        if e["kind"] == "collision"
    ]
    return {
        "monitoring": monitoring,
        "collisions": len(collisions),
        "collision_events": collisions,
        "min_separation_m": allmin,
        "time_below_1m_s": round(time_below_s(t, list(seps.values()), FIXED_THRESHOLD_M), 2),
        "time_below_protective_s": round(time_below_s(t, list(seps.values()), sp), 2),
        "stops": sum(int(n.get("stops", 0)) for n in navigation),
        "stop_time_s": round(sum(float(n.get("stop_time_s", 0.0)) for n in navigation), 2),
        "slowdowns": sum(int(n.get("slowdowns", 0)) for n in navigation),
        "time_lost_s": round(sum(float(n.get("time_lost_s", 0.0)) for n in navigation), 2),
        "replans": sum(int(n.get("replans", 0)) for n in navigation),
        "per_worker": per_worker,
        "ssm": ssm.as_dict(),
        "dz_m": round(dz_m, 4),
        "workers_off_robot_floor": len(seps) if dz_m > FLOOR_GAP_M else 0,
        "worker_radius_m": WORKER_RADIUS_M,
        "fixed_threshold_m": FIXED_THRESHOLD_M,
        "definition": "separation: footprint (base + carried element's carry-mode rectangle; lifted/placing: "
        "normal) to the worker disc, per recorded sample; time below = samples at which any worker is "
        "below x the median recording period; S_p at the robot's translational speed from consecutive "
        "samples",
    }
