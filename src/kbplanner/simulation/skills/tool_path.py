"""B5 skill kind kbp:FollowToolPath: a tool drawn along a line on a surface (marking, painting, sanding).

The line is the step's ``kbp:ToolPathRole`` input, a box (``[minX, minY, minZ, maxX, maxY, maxZ]``,
site frame): its centre line along the longer horizontal side, on the box's bottom face (for a
partition wall: its axis on the slab). It runs from the end nearer to the ``kbp:PathStartRole``
input (else nearer to the robot).

Simplification (said in docs/knowledge_base.md): the tool sits under the centre of the mobile base,
so the base itself follows the line; no arm motion. The base may only be where its footprint is
free on the storey's occupancy map (a line that ends at a standing wall cannot be marked right up to
it): the part of the line the base cannot reach is reported as ``unreachable_m``, the longest free
stretch is marked. The robot drives tool-up from where it stands to the start of that stretch
(straight, at most :data:`MAX_APPROACH_M`), turns in place, lowers the tool (event ``tool_down``),
drives the stretch at the skill's ``toolSpeed`` (capped by the base's top speed), lifts the tool
(event ``tool_up`` with the marked length). Speed and separation monitoring (ISO/TS 15066, as for
navigation) slows or stops the base near people. The ``kbp:LocalisationReferenceRole`` input is
recorded as the distance from the reference to the line start (the simulated localisation is exact).

Details recorded per step: ``marked_m``, ``line_length_m``, ``unreachable_m``, ``tool_speed_mps``,
``line`` (start and end x, y), ``stops``, ``stop_time_s``, ``reference_distance_m``.
"""

from __future__ import annotations

import math

from kbplanner.core.vocab import KBP
from kbplanner.knowledge.skill_kinds import local
from kbplanner.planning.base_poses import PoseChecker
from kbplanner.planning.pose_frames import as_pose6_list
from kbplanner.robot.lidar import lidar_spec
from kbplanner.simulation.separation_monitor import SeparationMonitor
from kbplanner.simulation.skills.base import Skill, Status
from kbplanner.simulation.skills.fasten import number

DEFAULT_TOOL_SPEED = 0.2  # m/s, when the skill has no kbp:toolSpeed parameter
MAX_APPROACH_M = 1.5  # the base drives at most this far tool-up to reach the start of the line
SAMPLE_M = 0.02  # spacing of the free-footprint test along the line
TURN_RPS = 0.5  # turning in place before the tool goes down
ON_LINE_M = 0.02  # a robot this close to the line's axis drives along it to the start (forwards or backwards)

Point = tuple[float, float]


def centre_line(box: list[float]) -> tuple[Point, Point, float]:
    """The centre line of a box's footprint along its longer horizontal side, and the box's bottom z.

    Example:
        >>> centre_line([0.0, 0.0, 0.1, 3.0, 0.2, 2.5])
        ((0.0, 0.1), (3.0, 0.1), 0.1)
    """
    x0, y0, z0, x1, y1, _ = box
    if x1 - x0 >= y1 - y0:
        yc = (y0 + y1) / 2
        return (x0, yc), (x1, yc), z0
    xc = (x0 + x1) / 2
    return (xc, y0), (xc, y1), z0


def _lerp(a: Point, b: Point, u: float) -> Point:
    return a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


class ToolPathSkill(Skill):
    """kbp:FollowToolPath (see module docstring)."""

    kind = str(KBP.FollowToolPath)

    def start(self) -> None:
        call = self.step
        env = self.c.env
        box = call.by_role(local(KBP.ToolPathRole))
        if not isinstance(box, list) or len(box) != 6:
            self.fail("no tool path: the step has no box for its kbp:ToolPathRole input")
            return
        a, b, _z = centre_line([float(v) for v in box])
        x, y, _yaw = env.base_pose()
        start_hint = as_pose6_list(call.by_role(local(KBP.PathStartRole)))
        ref = (start_hint[0], start_hint[1]) if start_hint is not None else (x, y)
        if math.dist(ref, b) < math.dist(ref, a):
            a, b = b, a
        length = math.dist(a, b)
        yaw = math.atan2(b[1] - a[1], b[0] - a[0])
        fp = env.robot.spec.footprint()
        checker = PoseChecker(env.grid)
        n = max(1, math.ceil(length / SAMPLE_M))
        free = [checker.free(fp, *_lerp(a, b, k / n), yaw) for k in range(n + 1)]
        best: tuple[int, int] | None = None
        k = 0
        while k <= n:
            if free[k]:
                j = k
                while j + 1 <= n and free[j + 1]:
                    j += 1
                if best is None or j - k > best[1] - best[0]:
                    best = (k, j)
                k = j + 1
            else:
                k += 1
        self.details.update({"line_length_m": round(length, 3), "marked_m": 0.0, "stops": 0,
                             "stop_time_s": 0.0, "line": [[round(a[0], 3), round(a[1], 3)],
                                                          [round(b[0], 3), round(b[1], 3)]]})
        ref_pose = as_pose6_list(call.by_role(local(KBP.LocalisationReferenceRole)))
        if ref_pose is not None:
            self.details["reference_distance_m"] = round(math.dist((ref_pose[0], ref_pose[1]), a), 3)
        if best is None or best[1] == best[0]:
            self.fail(f"the base cannot stand anywhere on the {length:.2f} m line (its footprint hits an "
                      "obstacle on the map all along it)")
            return
        self.p0, self.p1 = _lerp(a, b, best[0] / n), _lerp(a, b, best[1] / n)
        self.yaw = yaw
        self.details["unreachable_m"] = round(length - math.dist(self.p0, self.p1), 3)
        approach = math.hypot(self.p0[0] - x, self.p0[1] - y)
        if approach > MAX_APPROACH_M:
            self.fail(f"the robot stands {approach:.2f} m from the start of the line (at most "
                      f"{MAX_APPROACH_M} m): navigate there first (bind the navigation's destination "
                      "near it)")
            return
        self.queue: list[tuple[str, float, Point]] = []
        if approach > 0.01:
            head = math.atan2(self.p0[1] - y, self.p0[0] - x)
            cross = abs(math.sin(head - yaw)) * approach
            if cross < ON_LINE_M:
                head = yaw  # on the line already: drive along it (forwards or backwards), no turning round
            m = max(1, math.ceil(approach / SAMPLE_M))
            if not all(checker.free(fp, *_lerp((x, y), self.p0, k / m), head) for k in range(m + 1)):
                self.fail(f"the straight {approach:.2f} m approach to the start of the line is blocked "
                          "on the map")
                return
            self.queue += [("turn", head, self.p0), ("drive", head, self.p0)]
        self.queue += [("turn", yaw, self.p0), ("mark", yaw, self.p1)]
        params = call.parameters
        top = env.robot.spec.base.max_speed_mps
        self.speed = min(number(params.get("toolSpeed"), DEFAULT_TOOL_SPEED), top)
        if not (math.isfinite(self.speed) and self.speed > 0):
            self.fail(f"tool speed {self.speed} m/s: it must be positive (kbp:toolSpeed)")
            return
        self.details["tool_speed_mps"] = round(self.speed, 3)
        self.stop_m = float(params.get("safetyStopDistance", self.c.settings.default_stop_distance_m))
        self.monitor = SeparationMonitor(env, lidar_spec(env.robot, self.c.settings.lidar_step_deg), params,
                                         max_speed=self.speed, enabled=self.c.settings.monitoring != "off")
        self.tool_down = False
        self.stopped_since: float | None = None

    # ---- running ---------------------------------------------------------------------------------------
    def _advance(self, here: tuple[float, float, float], goal: Point, heading: float) -> tuple[float, bool]:
        """Drive straight towards ``goal`` for one period under monitoring: (metres driven, arrived)."""
        env = self.c.env
        d = math.hypot(goal[0] - here[0], goal[1] - here[1])
        if d < 1e-6:
            return 0.0, True
        step = min(d, self.speed * env.dt)
        nxt = (here[0] + step * (goal[0] - here[0]) / d, here[1] + step * (goal[1] - here[1]) / d, heading)
        f = self._monitor(here, nxt)
        env.set_base_pose(here[0] + f * (nxt[0] - here[0]), here[1] + f * (nxt[1] - here[1]), heading)
        return f * step, f * step >= d - 1e-9

    def _monitor(self, here: tuple[float, float, float], nxt: tuple[float, float, float]) -> float:
        """Speed and separation monitoring: the fraction of the period's motion to make (0: stopped)."""
        env = self.c.env
        dec = self.monitor.decide(list(env.robot.spec.footprint().rects), here, nxt)
        if dec.stopped:
            if self.stopped_since is None:
                self.stopped_since = env.t
                self.details["stops"] += 1
                self.c.emit("stop", worker=dec.sensed.worker if dec.sensed else None,
                            separation_m=round(dec.sensed.separation_m, 3) if dec.sensed else None)
            self.details["stop_time_s"] = round(self.details["stop_time_s"] + env.dt, 3)
            return dec.fraction  # 0, or a step away from everyone seen
        if self.stopped_since is not None:
            self.c.emit("resume", waited_s=round(env.t - self.stopped_since, 3))
            self.stopped_since = None
        return dec.fraction

    def tick(self) -> Status:
        env = self.c.env
        if self.stopped_since is not None and env.t - self.stopped_since >= self.c.settings.give_up_after_s:
            return self.fail(f"blocked by a worker for {env.t - self.stopped_since:.0f} s")
        while self.queue:
            what, yaw, goal = self.queue[0]
            here = env.base_pose()
            if what == "turn":
                dyaw = _wrap(yaw - here[2])
                if abs(dyaw) < 1e-6:
                    self.queue.pop(0)
                    continue
                turn = math.copysign(min(abs(dyaw), TURN_RPS * env.dt), dyaw)
                f = self._monitor(here, (here[0], here[1], here[2] + turn))
                env.set_base_pose(here[0], here[1], here[2] + f * turn)
                return Status.RUNNING
            if what == "mark" and not self.tool_down:
                self.tool_down = True
                self.c.emit("tool_down", x=round(here[0], 3), y=round(here[1], 3))
            driven, arrived = self._advance(here, goal, yaw)
            if what == "mark":
                self.details["marked_m"] = round(self.details["marked_m"] + driven, 4)
            if arrived:
                self.queue.pop(0)
            return Status.RUNNING
        self.details["marked_m"] = round(self.details["marked_m"], 3)
        x, y, _ = env.base_pose()
        self.c.emit("tool_up", x=round(x, 3), y=round(y, 3), marked_m=self.details["marked_m"])
        return Status.SUCCESS
