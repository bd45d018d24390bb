"""A simulation run directory, read back for analysis: durations and human-robot proximity.

``RunRecord.load(dir)`` reads what the executor wrote (``trajectories.csv``, ``events.jsonl``,
``metrics.json``, ``footprints.json``, ``manifest.json``, ``plan.json``). ``durations()`` gives the
time per action, per element and in total; ``proximity(threshold_m=1.0)`` gives, for each worker, the
distance over time from the robot's footprint *including the element it carries in its current carry
mode* to the worker's body (a circle of ``worker_radius_m``), the intervals below the fixed threshold
and below the ISO/TS 15066 protective separation distance (see :mod:`kbplanner.analysis.proximity`), the
minimum distance, and where it happened. Separations, S_p (with the run's own constants from
``metrics.json``) and the time below a threshold are computed by the same functions as ``metrics.json``'s
``safety`` section (:func:`kbplanner.simulation.safety.separation_samples`,
:func:`kbplanner.simulation.separation.time_below_s`), so the comparison and the run agree.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from kbplanner.analysis.proximity import (
    DEFAULT_THRESHOLD_M,
    WORKER_RADIUS_M,
    ProximityInterval,
    SsmParameters,
    intervals_below,
    point_to_rects_distance,
    robot_speed,
    time_below_s,
)
from kbplanner.core.errors import InputFileError
from kbplanner.simulation.safety import separation_samples
from kbplanner.world.footprint import Rect

FloatArray = npt.NDArray[np.float64]
_FIXED_COLUMNS = {"t_s", "x", "y", "yaw", "carried", "carry_mode", "step"}
# Carry modes in which the held element is over the base in its carry footprint; while lifting or
# placing, the element sits where the grasp/placement put it: the normal carry rectangle is used.
_MODE_RECT = {"normal": "normal", "narrow": "narrow", "lifted": "normal", "placing": "normal"}


@dataclass
class Trajectories:
    """The sampled run: robot base, held element and carry mode, and every worker's position."""

    t: FloatArray
    x: FloatArray
    y: FloatArray
    yaw: FloatArray
    carried: list[str]
    carry_mode: list[str]
    workers: dict[str, tuple[FloatArray, FloatArray]]


@dataclass(frozen=True)
class ActionDuration:
    """One executed (or failed) action of one element."""

    element: str
    global_id: str
    action: str
    skill: str
    start_s: float
    end_s: float
    duration_s: float
    outcome: str
    reason: str | None


@dataclass(frozen=True)
class ElementDuration:
    """One element of the task: from its first action's start to its last action's end."""

    element: str
    global_id: str
    start_s: float | None
    end_s: float | None
    duration_s: float
    outcome: str
    reason: str | None


@dataclass
class Durations:
    """Durations of a run (seconds)."""

    actions: list[ActionDuration]
    elements: list[ElementDuration]
    total_s: float
    installed: int

    @property
    def first_element_s(self) -> float | None:
        """Time until the first element was installed (the paper's 'frame 1')."""
        done = [e for e in self.elements if e.outcome == "installed"]
        return done[0].end_s if done else None

    @property
    def mean_per_element_s(self) -> float | None:
        """Mean time per installed element."""
        done = [e.duration_s for e in self.elements if e.outcome == "installed"]
        return float(np.mean(done)) if done else None

    def per_action_kind(self) -> dict[str, float]:
        """Mean duration of each action kind over succeeded actions."""
        out: dict[str, list[float]] = {}
        for a in self.actions:
            if a.outcome == "succeeded":
                out.setdefault(a.action, []).append(a.duration_s)
        return {k: float(np.mean(v)) for k, v in out.items()}


@dataclass
class WorkerProximity:
    """Proximity of one worker to the robot over the run."""

    worker: str
    distance_m: FloatArray
    min_distance_m: float
    t_min_s: float
    x_min_m: float
    y_min_m: float
    below_threshold: list[ProximityInterval]
    below_separation: list[ProximityInterval]

    @property
    def time_below_threshold_s(self) -> float:
        """Total time below the fixed threshold."""
        return sum(i.duration_s for i in self.below_threshold)

    @property
    def time_below_separation_s(self) -> float:
        """Total time below the ISO/TS 15066 protective separation distance."""
        return sum(i.duration_s for i in self.below_separation)


@dataclass
class ProximityResult:
    """Proximity of every worker, with the thresholds used."""

    threshold_m: float
    worker_radius_m: float
    ssm: SsmParameters
    t: FloatArray
    separation_m: FloatArray
    workers: list[WorkerProximity] = field(default_factory=list)

    @property
    def time_below_threshold_s(self) -> float:
        """Time of the run with any worker below the fixed threshold (metrics.json's ``time_below_1m_s``
        for 1 m)."""
        return time_below_s(self.t, [w.distance_m for w in self.workers], self.threshold_m)

    @property
    def time_below_separation_s(self) -> float:
        """Time of the run with any worker below S_p (metrics.json's ``time_below_protective_s``)."""
        return time_below_s(self.t, [w.distance_m for w in self.workers], self.separation_m)

    @property
    def min_distance_m(self) -> float:
        """The smallest distance between the robot and any worker."""
        return min((w.min_distance_m for w in self.workers), default=float("inf"))

    @property
    def intervals(self) -> list[ProximityInterval]:
        """Every interval below either threshold, in time order."""
        out = [i for w in self.workers for i in (*w.below_threshold, *w.below_separation)]
        return sorted(out, key=lambda i: (i.start_s, i.worker, i.threshold))


def _read(path: Path) -> str:
    if not path.is_file():
        raise InputFileError(
            "missing file of a simulation run",
            file=path,
            fix="give the directory written by 'kbplanner simulate' (or a scenario's "
            "'simulation' directory of 'kbplanner run')",
        )
    return path.read_text(encoding="utf-8")


def _rect(d: dict[str, float]) -> Rect:
    return Rect(
        float(d["cx"]), float(d["cy"]), float(d["length"]), float(d["width"]), float(d.get("yaw", 0.0))
    )


@dataclass
class RunRecord:
    """A simulation run directory, loaded."""

    directory: Path
    trajectories: Trajectories
    events: list[dict[str, Any]]
    metrics: dict[str, Any]
    footprints: dict[str, Any]
    manifest: dict[str, Any]
    timing: dict[str, Any]

    @classmethod
    def load(cls, directory: str | Path) -> RunRecord:
        """Read a run directory written by the executor."""
        d = Path(directory)
        if not d.is_dir():
            raise InputFileError(
                "run directory not found", file=d, fix="run 'kbplanner simulate PROJECT --out DIR' first"
            )
        traj = _parse_trajectories(_read(d / "trajectories.csv"), d / "trajectories.csv")
        events = [json.loads(line) for line in _read(d / "events.jsonl").splitlines() if line.strip()]
        timing_path = d / "timing.json"
        return cls(
            directory=d,
            trajectories=traj,
            events=events,
            metrics=json.loads(_read(d / "metrics.json")),
            footprints=json.loads(_read(d / "footprints.json")),
            manifest=json.loads(_read(d / "manifest.json")),
            timing=json.loads(timing_path.read_text(encoding="utf-8")) if timing_path.is_file() else {},
        )

    @property
    def scenario(self) -> str | None:
        """The scenario simulated."""
        s = self.manifest.get("scenario")
        return str(s) if s else None

    def durations(self) -> Durations:
        """Per action, per element and total durations from the run's metrics."""
        actions: list[ActionDuration] = []
        elements: list[ElementDuration] = []
        for e in self.metrics.get("per_element", []):
            for s in e.get("steps", []):
                actions.append(
                    ActionDuration(
                        element=str(e["label"]),
                        global_id=str(e["global_id"]),
                        action=str(s["action"]),
                        skill=str(s["skill"]),
                        start_s=float(s["start_s"]),
                        end_s=float(s["end_s"]),
                        duration_s=float(s["duration_s"]),
                        outcome=str(s["outcome"]),
                        reason=s.get("reason"),
                    )
                )
            elements.append(
                ElementDuration(
                    element=str(e["label"]),
                    global_id=str(e["global_id"]),
                    start_s=e.get("start_s"),
                    end_s=e.get("end_s"),
                    duration_s=float(e.get("duration_s") or 0.0),
                    outcome=str(e["outcome"]),
                    reason=e.get("reason"),
                )
            )
        totals = self.metrics.get("totals", {})
        return Durations(
            actions=actions,
            elements=elements,
            total_s=float(totals.get("sim_time_s", 0.0)),
            installed=int(totals.get("installed", 0)),
        )

    def _rect_sets(self) -> tuple[list[Rect], dict[tuple[str, str], list[Rect]]]:
        robot = [_rect(r) for r in self.footprints.get("robot", [])]
        sets: dict[tuple[str, str], list[Rect]] = {}
        for gid, modes in self.footprints.get("elements", {}).items():
            for mode, key in _MODE_RECT.items():
                if key in modes:
                    sets[(gid, mode)] = [*robot, _rect(modes[key])]
        return robot, sets

    def robot_distance(self, px: FloatArray, py: FloatArray) -> FloatArray:
        """Distance (m) from the robot's footprint incl. the carried element to points, one per sample."""
        tr = self.trajectories
        robot, sets = self._rect_sets()
        out = np.empty(len(tr.t))
        keys = [
            (c, m) if c and (c, m) in sets else ("", "")
            for c, m in zip(tr.carried, tr.carry_mode, strict=True)
        ]
        order = sorted(set(keys))
        code = {k: i for i, k in enumerate(order)}
        codes = np.fromiter((code[k] for k in keys), dtype=np.int64, count=len(keys))
        for i, key in enumerate(order):
            idx = np.flatnonzero(codes == i)
            rects = sets.get(key, robot)
            out[idx] = point_to_rects_distance(px[idx], py[idx], tr.x[idx], tr.y[idx], tr.yaw[idx], rects)
        return out

    def proximity(
        self,
        threshold_m: float = DEFAULT_THRESHOLD_M,
        *,
        ssm: SsmParameters | None = None,
        worker_radius_m: float = WORKER_RADIUS_M,
    ) -> ProximityResult:
        """Distances to every worker, the intervals below ``threshold_m`` and below ISO/TS 15066 S_p.

        ``ssm`` defaults to the run's own constants (``metrics.json``, ``safety.ssm``).
        """
        ssm = ssm or SsmParameters.from_dict(self.metrics.get("safety", {}).get("ssm"))
        tr = self.trajectories
        sep = ssm.separation_m(robot_speed(tr.t, tr.x, tr.y))
        res = ProximityResult(
            threshold_m=threshold_m, worker_radius_m=worker_radius_m, ssm=ssm, t=tr.t, separation_m=sep
        )
        # Workers walk on the site's ground; the robot works on its task's storey: the storeys apart
        # add to the distance (0 on the ground floor).
        dz = abs(float(self.manifest.get("robot_floor_z", 0.0)) - float(self.manifest.get("ground_z", 0.0)))
        seps = separation_samples(tr.x, tr.y, tr.yaw, tr.carried, tr.carry_mode, tr.workers, self.footprints,
                                  dz, radius_m=worker_radius_m)
        for name, (wx, wy) in sorted(tr.workers.items()):
            d = seps[name]
            k = int(np.argmin(d)) if len(d) else 0
            res.workers.append(
                WorkerProximity(
                    worker=name,
                    distance_m=d,
                    min_distance_m=float(d[k]) if len(d) else float("inf"),
                    t_min_s=float(tr.t[k]) if len(d) else 0.0,
                    x_min_m=float(wx[k]) if len(d) else 0.0,
                    y_min_m=float(wy[k]) if len(d) else 0.0,
                    below_threshold=intervals_below(
                        tr.t, d, threshold_m, worker=name, threshold=f"{threshold_m:g} m", wx=wx, wy=wy
                    ),
                    below_separation=intervals_below(
                        tr.t, d, sep, worker=name, threshold="ISO/TS 15066 S_p", wx=wx, wy=wy
                    ),
                )
            )
        return res

    def event_positions(self, kind: str) -> list[tuple[float, float, float]]:
        """(t, x, y) of the robot at each event of a kind (e.g. ``rotate_to_narrow``)."""
        tr = self.trajectories
        out = []
        for e in self.events:
            if e.get("kind") == kind:
                i = int(np.searchsorted(tr.t, float(e["t_s"]), side="left"))
                i = min(i, len(tr.t) - 1)
                out.append((float(e["t_s"]), float(tr.x[i]), float(tr.y[i])))
        return out


def _parse_trajectories(text: str, path: Path) -> Trajectories:
    reader = csv.reader(io.StringIO(text))
    try:
        header = next(reader)
    except StopIteration:
        raise InputFileError("empty trajectories file", file=path, fix="re-run the simulation") from None
    missing = {"t_s", "x", "y", "yaw", "carried", "carry_mode"} - set(header)
    if missing:
        raise InputFileError(
            f"trajectories.csv lacks columns {sorted(missing)}",
            file=path,
            fix="give a trajectories.csv written by 'kbplanner simulate'",
        )
    rows = list(reader)
    col = {c: i for i, c in enumerate(header)}

    def num(c: str) -> FloatArray:
        return np.array([float(r[col[c]]) for r in rows], dtype=np.float64)

    workers: dict[str, tuple[FloatArray, FloatArray]] = {}
    for c in header:
        if c.endswith("_x") and c not in _FIXED_COLUMNS and c[:-2] + "_y" in col:
            workers[c[:-2]] = (num(c), num(c[:-2] + "_y"))
    return Trajectories(
        t=num("t_s"),
        x=num("x"),
        y=num("y"),
        yaw=num("yaw"),
        carried=[r[col["carried"]] for r in rows],
        carry_mode=[r[col["carry_mode"]] for r in rows],
        workers=workers,
    )
