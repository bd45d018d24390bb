"""B5 run record: trajectories at a fixed rate, events, and the files of a run directory.

Takes the running :class:`~kbplanner.simulation.sim_env.SimEnv` and the executor's state (current step, held
element, carry mode); keeps

- ``trajectories.csv``: one row every ``1 / record_hz`` simulated seconds: ``t_s``, robot ``x``, ``y``,
  ``yaw``, arm joints ``q1`` .. ``q6``, ``carried`` (GlobalId of the held element), ``carry_mode``
  (``lifted``, ``normal``, ``narrow``, ``placing`` or empty), ``step`` (plan step number), then ``x``
  and ``y`` of every worker as ``<worker slug>_x``, ``<worker slug>_y``;
- ``events.jsonl``: one JSON object per line: ``t_s``, ``kind``, ``step``, ``element`` (GlobalId),
  ``action``, ``details``.

Numbers are written with fixed decimals (mm, mrad, 10 ms) and keys sorted, so the same run gives
the same bytes.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

from kbplanner.core.outputs import json_text
from kbplanner.simulation.sim_env import SimEnv


def _f(v: float, nd: int) -> str:
    text = f"{v:.{nd}f}"
    return "0." + "0" * nd if text.lstrip("-").strip("0.") == "" else text


_NEGATIVE_ZERO = re.compile(r"-(0\.0+)(?=,|$)")


def _fixed(text: str) -> str:
    """Comma-separated fixed-decimal numbers with a rounded-off negative zero written as zero, as
    :func:`_f` writes each cell (a cell is ``-0.0...`` only for a negative number that rounds to 0)."""
    return _NEGATIVE_ZERO.sub(r"\1", text) if "-0." in text else text


def clean(value: Any) -> Any:
    """JSON-ready value with floats rounded to 6 decimals (no -0.0)."""
    if isinstance(value, float):
        return round(value, 6) + 0.0
    if isinstance(value, dict):
        return {str(k): clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [clean(v) for v in value]
    return value


_Sample = tuple[float, float, float, float, Sequence[float], str, str, "int | None",
                list[tuple[float, float]]]


class Recorder:
    """Collects trajectory rows and events of one run (see module docstring).

    (A row's numbers are kept as they are recorded and written out as text once, by
    :meth:`trajectories_csv`: the same cells, not formatted every period.)"""

    def __init__(self, env: SimEnv, record_hz: float) -> None:
        self.env = env
        self.every = max(1, round(env.control_hz / record_hz))
        n = len(env.robot.arm_joints)
        joints = [f"q{i + 1}" for i in range(n)]
        self.header = ["t_s", "x", "y", "yaw", *joints, "carried", "carry_mode", "step"]
        for w in env.workers:
            self.header += [f"{w.slug}_x", f"{w.slug}_y"]
        self._samples: list[_Sample] = []
        self._text: tuple[int, list[str]] | None = None  # rows as text, of how many samples
        # one format per row part (the cells of _f: t in 10 ms, robot in 0.1 mm / mrad, workers in mm)
        self._robot_format = ",".join(["%.2f", *["%.4f"] * (3 + n)])
        self._worker_format = "".join(",%.3f,%.3f" for _ in env.workers)
        self.events: list[dict[str, Any]] = []
        self._last_tick = -1

    def sample(self, *, step: int | None, carried: str, carry_mode: str, force: bool = False,
               arm: Sequence[float] | None = None) -> None:
        """Record a row now if the clock is on the record grid (or ``force``), once per tick (``arm``: the
        arm joints now, when the caller has just read them)."""
        env = self.env
        if env.tick == self._last_tick or (not force and env.tick % self.every):
            return
        self._last_tick = env.tick
        x, y, yaw = env.base_pose()
        q = env.robot.arm_positions() if arm is None else arm
        self._samples.append((env.t, x, y, yaw, q, carried, carry_mode, step, env.worker_xy_list()))

    @property
    def rows(self) -> list[str]:
        """The header and one text row per sample (the trajectory table's lines)."""
        done = self._text
        if done is None or done[0] != len(self._samples):
            robot_format, worker_format = self._robot_format, self._worker_format
            rows = [",".join(self.header)]
            for t, x, y, yaw, q, carried, carry_mode, step, xy in self._samples:
                robot = _fixed(robot_format % (t, x, y, yaw, *q))
                tail = "".join([",", carried, ",", carry_mode, ",", "" if step is None else str(step)])
                workers = tuple(v for wx, wy in xy for v in (wx, wy))  # in env.workers' order
                rows.append(robot + tail + (_fixed(worker_format % workers) if workers else ""))
            done = (len(self._samples), rows)
            self._text = done
        return done[1]

    def event(self, kind: str, *, step: int | None, element: str, action: str,
              details: dict[str, Any]) -> None:
        """Record an event at the current simulated time."""
        self.events.append({"t_s": round(self.env.t, 3), "kind": kind, "step": step, "element": element,
                            "action": action, "details": clean(details)})

    def trajectories_csv(self) -> str:
        """The trajectory table as CSV text."""
        return "\n".join(self.rows) + "\n"

    def events_jsonl(self) -> str:
        """The events as JSON lines."""
        return "".join(json_text(e, name="events.jsonl", indent=None) + "\n" for e in self.events)

    def kinds(self) -> Sequence[str]:
        """Event kinds in order."""
        return [e["kind"] for e in self.events]
