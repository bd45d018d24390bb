"""B5 speed and separation monitoring (ISO/TS 15066) for the navigation skills NV-1 and NV-2.

Each control period while the base drives, the monitor measures the separation between the robot's
hazard footprint (base plus carried element, :mod:`kbplanner.simulation.separation`) and the people
its 2D lidar sees, and scales the robot's speed so that the protective separation distance
S_p(v) fits the measured separation:

- **Sensing, honestly.** Only the lidar's own hits count: its field of view (270 degrees), minimum
  and maximum range (0.5-20 m), angular step, scan plane, and occlusion (each ray reports its first
  hit: the robot's own body, the carried element, a wall or another person hide what is behind). A
  person's separation is the smallest distance from their hit points to the hazard footprint. The
  scan is skipped while every worker is farther from the footprint than S_p at full speed, where it
  could not change the outcome, and while the workers are on another floor than the robot
  (:attr:`kbplanner.simulation.sim_env.SimEnv.workers_on_robot_floor`).
- **Human speed.** A person seen in consecutive scans is tracked (the centroid of their hits): v_h is
  their measured speed towards the robot, at least the skill's ``trackedApproachSpeed`` (knowledge base
  default 0.3 m/s, ``TRACKED_SPEED_FLOOR_MPS`` when a skill lacks it); a person seen for the
  first time approaches at ``humanApproachSpeed`` (ISO 13855's 1.6 m/s), as ISO/TS 15066 prescribes
  for an operator whose speed is not monitored.
- **Speed.** The speed that matters is the fastest point of the footprint: translation plus yaw rate
  times the footprint's reach from the base centre (a turning 2.4 m frame sweeps at its ends). The
  allowed speed is the largest v with S_p(v) <= separation (:meth:`SsmParameters.allowed_speed`);
  the trajectory is slowed by ``allowed / nominal``. Below the skill's ``minSpeed``, or with the
  separation at or under ``max(safetyStopDistance, S_p(0) of a tracked person)``, the robot stops
  (protective stop).
- **Moving away is allowed.** Stopped, the robot may still make a step (at ``minSpeed``) that takes
  the footprint farther from every sensed point, never closer.
- **Resume with hysteresis.** After a protective stop the robot resumes only once every person it sees
  is farther than the stop distance plus ``resumeMargin`` and has stayed so for ``resumeHoldTime``
  (knowledge base defaults 0 and 0, i.e. off, see docs/safety.md; ``RESUME_MARGIN_M``,
  ``RESUME_HOLD_S`` when a skill lacks them). With a margin and a hold time, a person standing at the
  stop distance, swaying by centimetres, no longer makes the robot stop and go every control period.
  Until then it stays in the protective stop, in which it may make a step (at ``minSpeed``) away
  from everyone it sees (the decision says stopped, with that fraction). Held so for
  ``HYSTERESIS_MAX_S`` since the separation was last at the stop distance (the navigation has
  replanned and asked the person to make way meanwhile), it goes on at the speed S_p allows.

The parameters are the step's effective skill parameters (knowledge base defaults, jobsite
overrides): ``maxSpeed``, ``minSpeed``, ``safetyStopDistance``, ``humanApproachSpeed``,
``reactionTime``, ``brakingDeceleration``, ``intrusionDistance``, ``positionUncertainty``,
``trackedApproachSpeed``, ``resumeMargin``, ``resumeHoldTime``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from kbplanner.robot.lidar import LidarSpec, scan
from kbplanner.simulation.separation import WORKER_RADIUS_M, SsmParameters, reach_m, rects_distance
from kbplanner.simulation.sim_env import SimEnv
from kbplanner.world.footprint import Rect

Pose2D = tuple[float, float, float]
TRACKED_SPEED_FLOOR_MPS = 0.3  # fallback of kbp:trackedApproachSpeed (ontology/kb/skills.ttl, NV-1/NV-2)
RESUME_MARGIN_M = 0.0  # fallback of kbp:resumeMargin (ontology/kb/skills.ttl, NV-1/NV-2)
RESUME_HOLD_S = 0.0  # fallback of kbp:resumeHoldTime (ontology/kb/skills.ttl, NV-1/NV-2)
HYSTERESIS_MAX_S = 15.0  # held beyond the stop distance this long (past replan and make-way), it goes on


def _non_negative(value: object, default: float) -> float:
    """A finite non-negative number from a skill parameter, else ``default``."""
    if isinstance(value, (int, float)) and math.isfinite(float(value)) and float(value) >= 0:
        return float(value)
    return default


@dataclass(frozen=True)
class Sensed:
    """The nearest person the lidar sees: who, separation (m), and their hit points (site x, y)."""

    worker: str
    separation_m: float
    points: np.ndarray
    approach_mps: float = 1.6  # v_h used for this person


@dataclass(frozen=True)
class Decision:
    """What the monitor allows for one control period."""

    fraction: float  # of the nominal trajectory speed: 1 full, 0 stopped
    sensed: Sensed | None
    protective_m: float  # S_p at the nominal speed
    stopped: bool


class SeparationMonitor:
    """Speed and separation monitoring of one navigation step (see module docstring)."""

    def __init__(
        self,
        env: SimEnv,
        lidar: LidarSpec,
        params: Mapping[str, object],
        *,
        max_speed: float,
        enabled: bool = True,
    ) -> None:
        self.env = env
        self.lidar = lidar
        self.ssm = SsmParameters.from_parameters(params)
        self.enabled = enabled
        self.max_speed = max_speed
        stop = params.get("safetyStopDistance", 0.5)
        lo = params.get("minSpeed", 0.05)
        floor = params.get("trackedApproachSpeed", TRACKED_SPEED_FLOOR_MPS)
        self.tracked_floor = (
            float(floor)
            if isinstance(floor, (int, float)) and math.isfinite(float(floor)) and float(floor) > 0
            else TRACKED_SPEED_FLOOR_MPS
        )
        self.stop_m = max(
            float(stop) if isinstance(stop, (int, float)) else 0.5,
            float(replace(self.ssm, human_speed_mps=self.tracked_floor).separation_m(0.0)),
        )
        self.min_speed = float(lo) if isinstance(lo, (int, float)) else 0.05
        self.resume_margin_m = _non_negative(params.get("resumeMargin"), RESUME_MARGIN_M)
        self.resume_hold_s = _non_negative(params.get("resumeHoldTime"), RESUME_HOLD_S)
        self._tracks: dict[str, tuple[float, np.ndarray]] = {}
        self._stopped = False  # in a protective stop (until the hysteresis lets the robot resume)
        self._clear_since: float | None = None  # since when everyone seen is beyond stop + margin
        self._last_t: float | None = None
        self._stopped_by: Sensed | None = None  # who caused the protective stop
        self._stopped_at: float | None = None  # when the separation was last at or under the stop distance

    def sense(self, rects: Sequence[Rect], *, horizon_m: float) -> list[Sensed]:
        """The people the lidar sees, with separation and approach speed (none beyond ``horizon_m``)."""
        env = self.env
        if not env.workers or not env.workers_on_robot_floor:
            return []  # nobody, or everybody on another floor (out of the robot's hazard scope)
        pose = env.base_pose()
        # everyone certainly beyond (centre distance less the footprint's reach): no distance query
        far = horizon_m + 0.25 + reach_m(rects) + 1e-6
        if env.nearest_centre_m(pose[0], pose[1]) > far:  # (all of them farther than far)
            self._tracks.clear()
            return []
        xy = env.worker_xy()
        true_d, _, _ = rects_distance(xy[:, 0], xy[:, 1], pose, rects)
        if float(np.min(true_d)) - 0.25 > horizon_m:
            self._tracks.clear()
            return []  # nobody could be seen within the horizon: the scan would change nothing
        ignore = [env.held.body] if env.held is not None else []
        env.sync()  # the workers' and the held element's bodies where they are now
        # only the rays that can reach a person (their hits are those of a whole scan)
        s = scan(env.robot, self.lidar, ignore=ignore, near=xy, near_radius_m=WORKER_RADIUS_M + 0.25)
        assert s.points is not None
        out: list[Sensed] = []
        tracks: dict[str, tuple[float, np.ndarray]] = {}
        for w in env.workers:
            mask = s.bodies == w.body
            if not mask.any():
                continue
            pts = s.points[mask]
            d, ux, uy = rects_distance(pts[:, 0], pts[:, 1], pose, rects)
            k = int(np.argmin(d))
            centroid = pts.mean(axis=0)
            v_h = self.ssm.human_speed_mps
            last = self._tracks.get(w.slug)
            if last is not None and 0 < env.t - last[0] <= 0.25:
                vel = (centroid - last[1]) / (env.t - last[0])
                v_h = max(self.tracked_floor, -float(vel[0] * ux[k] + vel[1] * uy[k]))
            tracks[w.slug] = (env.t, centroid)
            out.append(Sensed(w.slug, float(d[k]), pts, v_h))
        self._tracks = tracks
        return out

    def decide(self, rects: Sequence[Rect], here: Pose2D, nxt: Pose2D, *, sweep_mps: float = 0.0) -> Decision:
        """How much of the step from ``here`` to ``nxt`` (one control period at full speed) to make;
        ``sweep_mps``: the speed of the footprint's fastest point from what moves besides the base (the
        arm turning the carried load, the base standing still)."""
        hz = self.env.control_hz
        lin = math.hypot(nxt[0] - here[0], nxt[1] - here[1]) * hz
        turn = abs(math.atan2(math.sin(nxt[2] - here[2]), math.cos(nxt[2] - here[2]))) * hz
        v_nom = lin + turn * reach_m(rects) + sweep_mps
        protective = self.ssm.separation_at(v_nom)
        if not self.enabled or v_nom <= 1e-9:
            return Decision(1.0, None, protective, False)
        horizon = self.ssm.separation_at(max(v_nom, self.max_speed)) + 0.5
        seen = self.sense(rects, horizon_m=horizon)
        if not seen:
            return self._hysteresis(Decision(1.0, None, protective, False), math.inf)  # nobody: no step back
        allowed, sensed = min(
            (
                (replace(self.ssm, human_speed_mps=s.approach_mps).allowed_speed(s.separation_m), s)
                for s in seen
            ),
            key=lambda a: (a[0], a[1].separation_m),
        )
        protective = replace(self.ssm, human_speed_mps=sensed.approach_mps).separation_at(v_nom)
        nearest = min(s.separation_m for s in seen)
        if allowed >= v_nom or (sensed.separation_m > self.stop_m and allowed >= min(self.min_speed, v_nom)):
            go = Decision(min(1.0, allowed / v_nom), sensed, protective, False)
            held = self._hysteresis(go, nearest)
            if held is go:
                return go
            # held after a stop: only a step away from everyone seen (a stop all the same)
            away = self._away(rects, here, nxt, np.concatenate([s.points for s in seen]), v_nom)
            return replace(held, fraction=away)
        # protective stop, unless the step takes the footprint away from every point of everyone seen
        # (turning in place, one end of the load may come away from one person and towards another)
        self._stopped, self._clear_since, self._stopped_by = True, None, sensed
        self._last_t = self._stopped_at = self.env.t
        f = self._away(rects, here, nxt, np.concatenate([s.points for s in seen]), v_nom)
        if f > 0:
            return Decision(f, sensed, protective, False)
        return Decision(0.0, sensed, protective, True)

    def _away(self, rects: Sequence[Rect], here: Pose2D, nxt: Pose2D, pts: np.ndarray, v_nom: float) -> float:
        """The fraction of the step (at ``minSpeed``) if it takes the footprint farther from every point
        of ``pts``, else 0."""
        f = min(1.0, self.min_speed / v_nom)
        step = (
            here[0] + f * (nxt[0] - here[0]),
            here[1] + f * (nxt[1] - here[1]),
            here[2] + f * math.atan2(math.sin(nxt[2] - here[2]), math.cos(nxt[2] - here[2])),
        )
        d0, _, _ = rects_distance(pts[:, 0], pts[:, 1], here, rects)
        d1, _, _ = rects_distance(pts[:, 0], pts[:, 1], step, rects)
        return f if bool(np.all(d1 > d0 + 1e-6)) else 0.0

    def _hysteresis(self, d: Decision, nearest_m: float) -> Decision:
        """After a protective stop, ``d`` (a go) holds until everyone seen has been beyond the stop
        distance plus ``resume_margin_m`` for ``resume_hold_s`` (nobody seen counts as beyond)."""
        t = self.env.t
        last, self._last_t = self._last_t, t
        if not self._stopped:
            return d
        if nearest_m <= self.stop_m + self.resume_margin_m:
            self._clear_since = None
        elif self._clear_since is None or last is None or t - last > 1.5 * self.env.dt + 1e-9:
            self._clear_since = t  # clear from now (or again after a pause in monitoring)
        if self._clear_since is not None and t - self._clear_since >= self.resume_hold_s - 1e-9:
            self._stopped, self._clear_since = False, None
            return d
        if self._stopped_at is not None and t - self._stopped_at >= HYSTERESIS_MAX_S - 1e-9:
            # held this long beyond the stop distance (asked to make way meanwhile): go on as without
            # hysteresis, at the speed S_p allows, rather than wait for a person standing still
            self._stopped, self._clear_since = False, None
            return d
        return Decision(0.0, d.sensed or self._stopped_by, d.protective_m, True)
