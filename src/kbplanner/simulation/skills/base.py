"""B5 skill lifecycle: what every executable skill implements, and what it is given to run.

A skill is set up with a :class:`RunContext` (the simulation environment, the plan, the run's
settings and its event log: "the simulator injected", as in py_trees' behaviours), initialised with
one :class:`~kbplanner.planning.plan_model.SkillCall`, updated once per control period until it returns
:attr:`Status.SUCCESS` or :attr:`Status.FAILURE`, then terminated. Each update moves the robot by at
most one control period; the executor then advances the clock
(:meth:`kbplanner.simulation.sim_env.SimEnv.step`).
A failure is a result with a reason, never an exception.

:class:`JointPath` interpolates the arm linearly in joint space through named waypoints at a joint
speed (the same speed for every joint, capped by each joint's velocity limit), one sample per tick.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from kbplanner.planning.plan_model import Plan, SkillCall
from kbplanner.simulation.sim_env import SimEnv


class Status(enum.Enum):
    """What an update returns."""

    RUNNING = "running"
    SUCCESS = "success"
    FAILURE = "failure"


@dataclass(frozen=True)
class ExecSettings:
    """How the executor runs (simulated seconds, metres, radians)."""

    control_hz: float = 10.0
    record_hz: float = 10.0
    joint_speed_rps: float = 0.6
    replan_after_s: float = 10.0  # blocked this long by a worker: plan around them
    give_up_after_s: float = 300.0  # blocked this long in one step: the step fails
    monitoring: str = "ssm"  # ISO/TS 15066 speed and separation monitoring; "off": none (what-if)
    reactive_workers: bool = True  # workers yield (social force); False: scripted walks through
    # monitor the arm's turns of a carried load at a standstill (off: a worker who cannot make way holds
    # the turn until the step gives up, test project seed 2; docs/safety.md)
    monitor_load_turns: bool = False
    nav_time_limit_s: float = 120.0  # safety cap per OMPL query; the work budget (motion checks) decides
    window_margins_m: tuple[float | None, ...] = (4.0, 10.0, None)  # planning windows; None: the whole map
    carry_margin_m: float = 0.5  # narrow carry kept this far before and after where the normal one is blocked
    # A leg that is a detour (skills/navigation.py DETOUR_RATIO) is planned again with other seeds; False: not
    # when it ended on the cell path, which no seed changes (a behaviour change, off by default: only another
    # seed's RRTConnect path, rarely found where the first try used its whole budget, could be kept;
    # docs/scale.md "Session 9: boardfast")
    detour_retry_cell_paths: bool = True
    # NV-2: a leg whose normal carry must pass a narrow passage takes the cell route without trying
    # RRTConnect first (NavSettings.carry_cells_first; docs/scale.md "Session 9: carryroute")
    carry_cells_first: bool = True
    default_stop_distance_m: float = 0.5
    lidar_step_deg: float | None = None  # None: the scanner's own resolution
    place_tol_m: float = 0.02
    place_tol_deg: float = 2.0
    pose_tol_m: float = 0.05  # the base must be this close to a manipulation's base pose
    keyframes: bool = True
    keyframe_size: tuple[int, int] = (640, 480)


Emit = Callable[..., None]


@dataclass
class RunContext:
    """What a skill is given: the environment, the plan, settings, the event log and run state."""

    env: SimEnv
    plan: Plan
    settings: ExecSettings
    emit: Emit  # emit(kind, **details): an event at the current time, for the current step
    seed: int
    step: SkillCall | None = None
    carry_mode: str = ""
    stats: dict[str, Any] = field(default_factory=dict)

    def gid(self, element_iri: str) -> str:
        """The GlobalId of a plan element (or the IRI when unknown)."""
        for e in self.plan.elements:
            if e.iri == element_iri:
                return e.global_id
        return element_iri


class Skill:
    """Base class: the lifecycle (see module docstring). Subclasses set ``kind`` and implement
    :meth:`start` (called by :meth:`initialise`) and :meth:`tick` (called by :meth:`update`)."""

    kind: str = ""

    def __init__(self) -> None:
        self.ctx: RunContext | None = None
        self.call: SkillCall | None = None
        self.status = Status.RUNNING
        self.reason: str | None = None
        self.details: dict[str, Any] = {}

    @property
    def c(self) -> RunContext:
        """The run context (after :meth:`setup`)."""
        assert self.ctx is not None, "setup() first"
        return self.ctx

    @property
    def step(self) -> SkillCall:
        """The skill call being run (after :meth:`initialise`)."""
        assert self.call is not None, "initialise() first"
        return self.call

    def setup(self, ctx: RunContext) -> None:
        """Receive the simulator and the run's context."""
        self.ctx = ctx

    def initialise(self, call: SkillCall) -> None:
        """Start running ``call``; a problem found here sets :attr:`status` to FAILURE with a reason."""
        self.call = call
        self.status = Status.RUNNING
        self.reason = None
        self.details = {}
        self.start()

    def update(self) -> Status:
        """Advance by one control period."""
        if self.status is Status.RUNNING:
            self.status = self.tick()
        return self.status

    def terminate(self, status: Status) -> None:
        """Clean up after SUCCESS or FAILURE (default: nothing)."""
        del status

    def fail(self, reason: str) -> Status:
        """Set the failure reason and return FAILURE."""
        self.reason = reason
        self.status = Status.FAILURE
        return Status.FAILURE

    def start(self) -> None:
        """Subclass hook: prepare (plan a path, check poses)."""

    def tick(self) -> Status:
        """Subclass hook: one control period."""
        return Status.SUCCESS


class JointPath:
    """Arm samples (one per tick) from ``start`` through named waypoints at a joint speed."""

    def __init__(
        self,
        start: Sequence[float],
        waypoints: Sequence[tuple[str, Sequence[float]]],
        speed_rps: float,
        hz: float,
        velocity_limits: Sequence[float] | None = None,
    ) -> None:
        self.samples: list[tuple[tuple[float, ...], str | None]] = []
        self.duration_s = 0.0
        q0 = [float(v) for v in start]
        for name, target in waypoints:
            q1 = [float(v) for v in target]
            t = 0.0
            for i, (a, b) in enumerate(zip(q0, q1, strict=True)):
                v = speed_rps if velocity_limits is None else min(speed_rps, velocity_limits[i])
                t = max(t, abs(b - a) / v)
            n = max(1, math.ceil(t * hz - 1e-9))
            for k in range(1, n + 1):
                u = k / n
                q = tuple(a + u * (b - a) for a, b in zip(q0, q1, strict=True))
                self.samples.append((q, name if k == n else None))
            self.duration_s += n / hz
            q0 = q1
        self._i = 0

    def next(self) -> tuple[tuple[float, ...], str | None] | None:
        """The next sample (joints, waypoint reached or None), or None when done."""
        if self._i >= len(self.samples):
            return None
        s = self.samples[self._i]
        self._i += 1
        return s

    @property
    def done(self) -> bool:
        """Whether every sample was taken."""
        return self._i >= len(self.samples)
