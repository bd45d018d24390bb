"""Helpers shared by the benchmark scripts (``benchmarks/bench_*.py``, ``_stages.py``, ``run.py``).

Not a pipeline step: measurement plumbing only. Wall time (:class:`Timer`, :func:`timed`), peak
resident memory of this process (:func:`peak_rss_mb`, ``ru_maxrss``: run a case in a fresh process,
:func:`run_child_json`, for a per-case figure), a command's wall time, peak memory and CPU time with its
worker processes (:func:`run_measured`, ``os.wait4``), CPU seconds of this process and its children
(:func:`cpu_seconds`), the machine description recorded with every result (:func:`machine_info`),
the JSON results file (:func:`write_json`), and the RDF pose/box nodes of the synthetic models
(imported lazily, so that a script's measured memory does not include rdflib unless it uses it).
The scripts import it as ``from _common import ...`` (their own folder is first on ``sys.path``).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import platform
import resource
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from rdflib import Graph, URIRef

REPO = Path(__file__).resolve().parents[1]
RESULTS_DIR = REPO / "benchmarks" / "results"

T = TypeVar("T")


# ---- time ----------------------------------------------------------------------------------------


class Timer:
    """Wall time of a ``with`` block (``time.perf_counter``): ``with Timer() as t: ...`` then ``t.seconds``.

    Inside the block :meth:`elapsed` gives the time so far.
    """

    def __init__(self) -> None:
        self.started = time.perf_counter()
        self.seconds = 0.0

    def __enter__(self) -> Timer:
        self.started = time.perf_counter()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.seconds = time.perf_counter() - self.started

    def elapsed(self) -> float:
        """Seconds since the block (or the object) started."""
        return time.perf_counter() - self.started

    def lap(self) -> float:
        """Seconds since the start or the previous lap (consecutive parts of one measurement)."""
        now = time.perf_counter()
        seconds, self.started = now - self.started, now
        return seconds


def timed(fn: Callable[[], T]) -> tuple[T, float]:
    """``fn()`` and the wall seconds it took."""
    t0 = time.perf_counter()
    value = fn()
    return value, time.perf_counter() - t0


def cpu_seconds() -> float:
    """User + system CPU seconds of this process and its finished children (e.g. worker processes)."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


# ---- memory --------------------------------------------------------------------------------------


def maxrss_mb(ru_maxrss: float) -> float:
    """A ``ru_maxrss`` figure in MiB (it is KiB on Linux, bytes on macOS)."""
    return ru_maxrss / 1024.0 if sys.platform != "darwin" else ru_maxrss / (1024.0 * 1024.0)


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far (MiB)."""
    return maxrss_mb(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)


def run_child_json(cmd: Sequence[str]) -> dict[str, Any]:
    """Run ``cmd`` (a benchmark script in its one-case mode, so its peak memory is its own) and return
    the JSON object on the last line of its standard output; a failing child raises
    ``subprocess.CalledProcessError``."""
    done = subprocess.run(list(cmd), check=True, capture_output=True, text=True)
    figures: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return figures


def run_measured(cmd: Sequence[str], *, log: Path, timeout_s: float,
                 env: dict[str, str] | None = None) -> dict[str, Any]:
    """Run ``cmd`` (output to the file ``log``) and measure it: wall seconds, exit code, the peak resident
    memory of the largest process of its tree (MiB) and the CPU seconds of the tree.

    ``os.wait4`` gives the child's own resource usage with that of the processes it waited for (its
    worker processes), whatever ran before in this process. The command runs in its own session; past
    ``timeout_s`` that process group is killed (exit code -9).
    """
    with log.open("wb") as out:
        t0 = time.perf_counter()
        proc = subprocess.Popen(list(cmd), stdout=out, stderr=subprocess.STDOUT, env=env,
                                start_new_session=True)

        def kill() -> None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)

        watchdog = threading.Timer(timeout_s, kill)
        watchdog.start()
        try:
            _pid, status, usage = os.wait4(proc.pid, 0)
        finally:
            watchdog.cancel()
        seconds = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here: Popen must not wait again
    return {"seconds": round(seconds, 3), "exit": proc.returncode,
            "peak_rss_mb": round(maxrss_mb(usage.ru_maxrss), 1),
            "cpu_s": round(usage.ru_utime + usage.ru_stime, 1)}


# ---- results -------------------------------------------------------------------------------------

_MACHINE: dict[str, Callable[[], Any]] = {
    "python": platform.python_version,
    "platform": platform.platform,
    "machine": platform.machine,
    "cpus": os.cpu_count,
}


def loop_s(n: int = 1_000_000, repeat: int = 3) -> float:
    """The machine's speed: the CPU seconds of a fixed pure-Python loop (``n`` times ``s += i * i``), the
    best of ``repeat``. Machines of one kind differ by 2x and more from session to session; a figure of
    seconds is comparable across sessions only beside this one."""
    best = math.inf
    for _ in range(repeat):
        t0 = time.process_time()
        s = 0
        for i in range(n):
            s += i * i
        best = min(best, time.process_time() - t0)
    return round(best, 4)


def machine_info(keys: Sequence[str] = ("python", "platform", "cpus")) -> dict[str, Any]:
    """The machine a result was measured on, with the fields ``keys`` in that order (any of python,
    platform, machine, cpus), and always its speed when measured (:func:`loop_s`, ``python_loop_1e6_s``)."""
    return {**{k: _MACHINE[k]() for k in keys}, "python_loop_1e6_s": loop_s()}


def write_scenarios(path: Path, before: str, rows: list[dict[str, Any]]) -> None:
    """Write a before/after benchmark's per-scenario ``rows`` with the machine and the load average at the
    end to ``path``, and say so."""
    load = os.getloadavg()
    write_json(path, {"machine": machine_info(), "before": before, "scenarios": rows,
                      "load_average_end": [round(x, 2) for x in load]})
    print(f"load average {load[0]:.2f}; wrote {path}")


def write_json(path: Path, data: Any, *, indent: int = 2, sort_keys: bool = False) -> None:
    """Write ``data`` as JSON (with a final newline) to ``path``, creating its folder."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=indent, sort_keys=sort_keys) + "\n", encoding="utf-8")


# ---- synthetic models ----------------------------------------------------------------------------


def rdf_pose(g: Graph, node: URIRef, x: float, y: float, z: float = 0.0) -> URIRef:
    """Add a ``kbp:Pose`` at (x, y, z), no rotation, as ``node`` to graph ``g``; returns ``node``."""
    from rdflib import RDF, Literal

    from kbplanner.core.vocab import KBP

    g.add((node, RDF.type, KBP.Pose))
    for p, v in ((KBP.x, x), (KBP.y, y), (KBP.z, z), (KBP.roll, 0.0), (KBP.pitch, 0.0), (KBP.yaw, 0.0)):
        g.add((node, p, Literal(float(v))))
    return node


def rdf_box(g: Graph, node: URIRef, lo: tuple[float, ...], hi: tuple[float, ...]) -> URIRef:
    """Add a ``kbp:Box`` from ``lo`` to ``hi`` as ``node`` to graph ``g``; returns ``node``."""
    from rdflib import RDF, Literal

    from kbplanner.core.vocab import KBP

    g.add((node, RDF.type, KBP.Box))
    for p, v in zip((KBP.minX, KBP.minY, KBP.minZ, KBP.maxX, KBP.maxY, KBP.maxZ), (*lo, *hi), strict=True):
        g.add((node, p, Literal(float(v))))
    return node
