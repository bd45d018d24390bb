"""B4 ahead of B5 (issue 14, a user's first run): B4 in a second process, its elements handed over to B5
as they are refined, so that ``kbplanner simulate`` simulates element k while B4 refines k+1...

B5 (:func:`kbplanner.simulation.executor.simulate`) reads of the refined plan, for element k, only element
k's steps (its skills; the held element's carry rectangles), and besides them the plan's elements and the
number of its steps, which B4 does not change: element k can be simulated once B4 refined it, with the
elements before it installed. :func:`start` forks a process that runs B4 with the very call of the
sequential path (:func:`kbplanner.planning.refine_cache.refine_kept`: the refined plan is kept as before)
and sends through a pipe B4's progress, each element's refined steps once B4's first pass has refined it
(``refine_plan``'s ``stop`` hook, which never stops), and at the end the whole refined plan.
:attr:`RefineAhead.plan` is the plan B5 runs: B1-B3's, whose element steps are replaced as they come;
the executor calls :meth:`RefineAhead.ready` before each element, which waits for that element only.

- Outputs: the same as the sequential path's by construction. The steps are sent pickled: every value
  and type as B4 made them. B4's order feedback (:mod:`kbplanner.planning.install_order`) may refine the
  elements again in another order after its first pass; so before B5's last element the final plan is
  compared with what B5 used (element by element, the pickles of their steps, in B5's order): when all
  agree the plan B5 runs becomes the final plan (its notes and order rule: ``plan.json``, the metrics);
  when one differs :class:`AheadDiffers` (with the final plan) ends B5, which the command runs again
  from the start with the final plan (nothing written before: the run folder is written at the end).
- Errors: when the B4 process fails (an error raised by B4, the process killed, its pipe closed before the
  final plan), :class:`AheadFailed` ends B5; the command then runs B4 itself, as the sequential path
  does, so that an error reaches the user with the same message and exit code. An error of B5 is
  reported as it is when B4 ended well (:meth:`RefineAhead.b4_failed`), else B4's, as the sequential
  path reports it.
- Not started (:func:`start` returns None; the command runs B4 then B5): no ``fork`` (not Linux),
  ``KBPLANNER_B4_AHEAD=0``, a plan without robot or elements, a refined plan kept by an earlier command
  (nothing to overlap).
- :meth:`RefineAhead.close` ends the process if it still runs (an error in B5, Ctrl-C) and waits for it
  (its CPU is then counted with the command's).

Example:
    >>> ahead = start(plan, world, seed=7, grid=grid, cache_dir=entry, folder=kept)  # doctest: +SKIP
    >>> try:
    ...     result = simulate(project, ahead.plan, seed=7, out_dir=out, ready=ahead.ready)  # doctest: +SKIP
    ... finally:
    ...     ahead.close()  # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import copy
import logging
import os
import pickle
import select
import signal
import struct
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.planning.plan_model import Plan
from kbplanner.planning.refine_cache import kept_plan, refine_kept
from kbplanner.planning.step_kinds import elements_in_order

if TYPE_CHECKING:
    from kbplanner.world.occupancy import OccupancyGrid
    from kbplanner.world.world_types import World

log = logging.getLogger(__name__)

ProgressFn = Callable[[str, int, int], None]
_HEADER = struct.Struct("<Q")  # a message: its length, then its pickle
PIPE_BYTES = 1 << 20  # the pipe's buffer (Linux): B4 never waits for B5 to read (a plan's steps: ~100 kB)
POLL_S = 1.0  # how often a wait looks whether the B4 process still runs


class AheadFailed(Exception):
    """The B4 process failed (the command runs B4 itself: its error is reported as the sequential path's)."""


class AheadDiffers(Exception):
    """B4's final plan differs from the steps B5 used (the order feedback): simulate ``plan`` again."""

    def __init__(self, plan: Plan, why: str) -> None:
        super().__init__(why)
        self.plan = plan


def possible() -> bool:
    """Whether B4 can run in a second process: ``fork`` (Linux), and not turned off with
    ``KBPLANNER_B4_AHEAD=0`` (B4 then B5, as before: a before/after on one tree)."""
    return sys.platform == "linux" and hasattr(os, "fork") \
        and os.environ.get("KBPLANNER_B4_AHEAD", "").strip() != "0"


def start(plan: Plan, world: World, *, seed: int, grid: OccupancyGrid, cache_dir: Path | None,
          folder: Path | None) -> RefineAhead | None:
    """Fork the process that refines ``plan`` (B4, kept in ``cache_dir`` as :func:`refine_kept` keeps it;
    B4's configuration spaces kept in ``folder``, :func:`kbplanner.world.cspace_store.folder_for`);
    None where it is not started (see module docstring). Call before any thread is started (a progress
    bar's): the fork copies this process."""
    if not possible() or not plan.robot_id or not elements_in_order(plan):
        return None
    if kept_plan(plan, world, seed=seed, cache_dir=cache_dir, grid=grid) is not None:
        return None  # (refine_kept reads it again: a few hundredths of a second)
    read, write = os.pipe()
    with contextlib.suppress(AttributeError, OSError):  # a larger buffer where the system allows it
        import fcntl

        fcntl.fcntl(write, fcntl.F_SETPIPE_SZ, PIPE_BYTES)
    try:
        pid = os.fork()
    except OSError as exc:
        os.close(read)
        os.close(write)
        log.info("B4 not ahead of B5 (%s): B4 then B5", exc)
        return None
    if pid == 0:  # the B4 process
        code = 1
        try:
            os.close(read)
            _refine(plan, world, seed, grid, cache_dir, folder, write)
            code = 0
        finally:
            os._exit(code)
    os.close(write)
    log.info("B4 in process %d, ahead of B5", pid)
    return RefineAhead(plan, pid, read)


def _refine(plan: Plan, world: World, seed: int, grid: OccupancyGrid, cache_dir: Path | None,
            folder: Path | None, fd: int) -> None:
    """The B4 process: B4 as the sequential path runs it, its progress, elements and plan sent to ``fd``."""
    from kbplanner.world.cspace_store import kept_in

    def send(message: tuple[object, ...]) -> None:
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        view = memoryview(_HEADER.pack(len(data)) + data)
        while view:
            view = view[os.write(fd, view):]

    order = elements_in_order(plan)
    sent: list[str] = []

    def progress(label: str, done: int, total: int) -> None:
        send(("progress", label, done, total))

    def element_done(refined: Plan) -> bool:  # after each element of B4's first pass, in the plan's order
        iri = order[len(sent)]
        sent.append(iri)
        send(("element", iri, pickle.dumps(refined.steps_for(iri), protocol=pickle.HIGHEST_PROTOCOL)))
        return False

    try:
        with kept_in(folder):
            out = refine_kept(plan, world, seed=seed, grid=grid, progress=progress, cache_dir=cache_dir,
                              stop=element_done)
        steps = {iri: pickle.dumps(out.steps_for(iri), protocol=pickle.HIGHEST_PROTOCOL)
                 for iri in elements_in_order(out)}
        send(("final", pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL), steps))
    except Exception as exc:  # told to the first process, which runs B4 itself and reports it
        with contextlib.suppress(OSError):
            send(("failed", f"{type(exc).__name__}: {exc}"))
        raise


class RefineAhead:
    """The B4 process seen from the first process: :attr:`plan` (what B5 runs), :meth:`ready`,
    :meth:`poll`, :meth:`close`; ``progress`` receives B4's progress (set it before B5 starts)."""

    def __init__(self, plan: Plan, pid: int, fd: int) -> None:
        self.plan = copy.deepcopy(plan)  # B1-B3's plan; each element's steps replaced by B4's
        self.order = elements_in_order(plan)
        self.pid: int | None = pid
        self.status: int | None = None  # the B4 process's exit status once it ended
        self.progress: ProgressFn | None = None
        self._fd: int | None = fd
        self._buffer = bytearray()
        self._got: dict[str, bytes] = {}  # element -> its refined steps (pickled), from B4's first pass
        self._used: dict[str, bytes] = {}  # what B5 ran, in its order
        self._final: tuple[bytes, dict[str, bytes]] | None = None
        self._failed: str | None = None
        self._eof = False
        self.final: Plan | None = None  # the refined plan once it replaced :attr:`plan`'s contents

    # ---- what B5 calls ---------------------------------------------------------------------------
    def ready(self, iri: str) -> None:
        """Return once :attr:`plan` holds element ``iri``'s refined steps (before B5 simulates it); before
        the last element, once it is the final refined plan. Raises :class:`AheadFailed` (the B4 process
        failed) or :class:`AheadDiffers` (the final plan is not what B5 ran)."""
        if self.final is not None:
            return
        while iri not in self._got and self._final is None:
            self._wait()
        if self._final is None:
            self._use(iri)
        if self._final is not None or iri == self.order[-1]:
            while self._final is None:
                self._wait()
            self._take_final()

    def b4_failed(self) -> str | None:
        """Wait for the B4 process's plan: None when it came, else why it did not (B5 failed first: the
        sequential path would have reported B4's error before B5 ran)."""
        try:
            while self._final is None:
                self._wait()
        except AheadFailed as exc:
            return str(exc)
        return None

    def poll(self) -> None:
        """Read what the B4 process sent (its progress), without waiting."""
        if self._fd is not None and not self._eof:
            self._read(0.0)

    def close(self) -> int | None:
        """End the B4 process if it still runs, wait for it; its exit status (0: B4 ended well)."""
        if self.pid is not None and self.status is None:
            if self._final is None:  # (an error or Ctrl-C: B4's result is not wanted)
                with contextlib.suppress(OSError):
                    os.kill(self.pid, signal.SIGKILL)
            try:
                self.status = os.waitstatus_to_exitcode(os.waitpid(self.pid, 0)[1])
            except ChildProcessError:  # reaped by someone else (SIGCHLD ignored)
                self.status = 0
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        return self.status

    # ---- the pipe --------------------------------------------------------------------------------
    def _use(self, iri: str) -> None:
        data = self._got[iri]
        steps = pickle.loads(data)
        at = [i for i, s in enumerate(self.plan.steps) if s.element == iri]
        if len(at) != len(steps):
            raise AheadFailed(f"B4 gave {len(steps)} steps for element {iri}, the plan has {len(at)}")
        for i, step in zip(at, steps, strict=True):
            self.plan.steps[i] = step
        self._used[iri] = data

    def _take_final(self) -> None:
        assert self._final is not None
        data, steps = self._final
        final: Plan = pickle.loads(data)
        if elements_in_order(final) != self.order or len(final.steps) != len(self.plan.steps):
            raise AheadDiffers(final, "B4's order feedback changed the element order")  # (B5 runs B3's)
        changed = [iri for iri, used in self._used.items() if steps.get(iri) != used]
        if changed:
            raise AheadDiffers(final, f"B4's order feedback refined {len(changed)} element(s) again")
        vars(self.plan).update(vars(final))
        self.final = final

    def _wait(self) -> None:
        if self._eof:
            raise AheadFailed(self._failed or "the B4 process ended without its refined plan")
        if not self._read(POLL_S) and self.pid is not None:
            try:
                done, status = os.waitpid(self.pid, os.WNOHANG)
            except ChildProcessError:
                done, status = self.pid, 0
            if done:  # ended: what it wrote is read, then no more comes (whoever else holds the pipe)
                self.status = os.waitstatus_to_exitcode(status)
                self.pid = None
                while not self._eof and self._read(0.0):
                    pass
                self._eof = True

    def _read(self, timeout: float) -> bool:
        """Read what is in the pipe (waiting up to ``timeout`` s for something); whether anything came."""
        assert self._fd is not None
        ready, _, _ = select.select([self._fd], [], [], timeout)
        if not ready:
            return False
        data = os.read(self._fd, PIPE_BYTES)
        if not data:
            self._eof = True
            return True
        self._buffer += data
        while len(self._buffer) >= _HEADER.size:
            (n,) = _HEADER.unpack_from(self._buffer)
            if len(self._buffer) < _HEADER.size + n:
                break
            message = pickle.loads(bytes(self._buffer[_HEADER.size:_HEADER.size + n]))
            del self._buffer[:_HEADER.size + n]
            self._take(message)
        return True

    def _take(self, message: tuple[object, ...]) -> None:
        kind = message[0]
        if kind == "progress":
            if self.progress is not None:
                self.progress(str(message[1]), int(message[2]), int(message[3]))  # type: ignore[call-overload]
        elif kind == "element":
            self._got[str(message[1])] = message[2]  # type: ignore[assignment]
        elif kind == "final":
            self._final = (message[1], message[2])  # type: ignore[assignment]
        elif kind == "failed":
            self._failed = str(message[1])
