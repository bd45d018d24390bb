"""B5 key frames: offscreen images of the simulation at a few events (first pick, door rotations, ...).

Takes the running :class:`~kbplanner.simulation.sim_env.SimEnv` (loaded with visual shapes) and returns PNG
bytes rendered with PyBullet's TinyRenderer (CPU, no display needed), from a camera high above and
behind the robot, looking down at it. The executor writes them as ``keyframes/NN_<event>.png``.

On Linux (headless client) the picture is taken in a forked worker process: it holds the scene as it
is at the key frame (the fork's copy of the process), renders and encodes the PNG on another core while
the simulation goes on, and hands it back through a pipe. ``render_png`` then returns a
:class:`~kbplanner.core.later_bytes.LaterBytes` that the run's writer waits for; the bytes are those the
same call renders in the process (the same client state, the same renderer). Elsewhere, with the GUI,
or when a fork fails, the image is rendered in the process as before.

Example:
    >>> data = render_png(env, (640, 480))  # doctest: +SKIP
    >>> data[:4]  # doctest: +SKIP
    b'\\x89PNG'
"""

from __future__ import annotations

import io
import math
import os
import sys
import warnings
from collections.abc import Callable

import numpy as np

from kbplanner.core.later_bytes import LaterBytes
from kbplanner.simulation.sim_env import SimEnv

CAMERA_DISTANCE_M = 7.0
CAMERA_PITCH_DEG = -70.0
CAMERA_OFFSET_DEG = 150.0  # camera azimuth relative to the robot's heading (behind, to its left)


def _upper_bodies(env: SimEnv) -> list[int]:
    """Static bodies whose elements all start 2 m or more above the robot's floor (upper storeys, roof)."""
    floor = env.world.ground_z
    storey = env.world.storey(env.world.task_storey)
    if storey is not None:
        floor = storey.elevation_m
    bodies: set[int] = set()
    sim = env.world_bodies
    for e in env.world.static:
        if e.bounds is not None and e.bounds.zmin > floor + 2.0 and e.iri in sim.element_bodies:
            bodies.add(sim.element_bodies[e.iri])
    # a merged body is hidden only if none of its elements is low (it holds whole elements)
    for e in env.world.static:
        if e.bounds is not None and e.bounds.zmin <= floor + 2.0:
            bodies.discard(sim.element_bodies.get(e.iri, -1))
    return sorted(bodies)


GROUND_DROP_M = 0.05  # the ground plane's drop while a key frame is rendered


def render_png(env: SimEnv, size: tuple[int, int] = (640, 480), *, worker: bool | None = None) -> bytes:
    """A PNG of the scene around the robot, ``size`` = (width, height) pixels.

    ``worker``: render in a forked process (a :class:`~kbplanner.core.later_bytes.LaterBytes` is
    returned), or here; None (default): in a worker where that is possible (:func:`worker_possible`)."""
    import pybullet as p

    width, height = size
    env.robot.place_pending()  # the image shows PyBullet's robot: where it was last set
    x, y, yaw = env.base_pose()
    target = [x, y, env.world.ground_z + 0.8]
    view = p.computeViewMatrixFromYawPitchRoll(
        cameraTargetPosition=target, distance=CAMERA_DISTANCE_M,
        yaw=math.degrees(yaw) + CAMERA_OFFSET_DEG - 90.0, pitch=CAMERA_PITCH_DEG, roll=0.0, upAxisIndex=2,
        physicsClientId=env.client)
    proj = p.computeProjectionMatrixFOV(fov=60.0, aspect=width / height, nearVal=0.1, farVal=80.0,
                                        physicsClientId=env.client)
    client = env.client

    def picture() -> bytes:
        _, _, rgba, _, _ = p.getCameraImage(width, height, viewMatrix=view, projectionMatrix=proj,
                                            renderer=p.ER_TINY_RENDERER, flags=p.ER_NO_SEGMENTATION_MASK,
                                            physicsClientId=client)
        return _png(rgba, width, height)

    hidden = _upper_bodies(env)
    for body in hidden:  # storeys above the robot's would hide it from a camera above
        p.resetBasePositionAndOrientation(body, [0.0, 0.0, -1000.0], [0.0, 0.0, 0.0, 1.0],
                                          physicsClientId=env.client)
    ground = env.world_bodies.ground
    # The ground plane and a slab at ground level are coplanar: the renderer's depth test streaks
    # them (z-fighting). For the picture only, the plane sits a little lower.
    p.resetBasePositionAndOrientation(ground, [0.0, 0.0, env.world.ground_z - GROUND_DROP_M],
                                      [0.0, 0.0, 0.0, 1.0], physicsClientId=env.client)
    try:  # the fork copies the scene as it is now: the worker renders it, this process goes on
        use_worker = worker_possible(env) if worker is None else worker
        return _in_worker(picture) if use_worker else picture()
    finally:
        p.resetBasePositionAndOrientation(ground, [0.0, 0.0, env.world.ground_z], [0.0, 0.0, 0.0, 1.0],
                                          physicsClientId=env.client)
        for body in hidden:
            p.resetBasePositionAndOrientation(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0],
                                              physicsClientId=env.client)


def _png(rgba: object, width: int, height: int) -> bytes:
    """The RGB PNG (PIL's defaults) of PyBullet's RGBA pixels."""
    from PIL import Image

    pixels = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="PNG")
    return buf.getvalue()


def worker_possible(env: SimEnv) -> bool:
    """Whether key frames can be rendered in a forked worker: Linux, a headless (DIRECT) client."""
    return sys.platform == "linux" and hasattr(os, "fork") and not env.gui


_PIPE_BYTES = 1 << 20  # a worker's pipe holds a whole PNG: the worker ends without waiting for a reader


def _in_worker(render: Callable[[], bytes]) -> bytes:
    """``render()`` run in a forked copy of this process; its bytes when waited for (``LaterBytes``).

    Falls back to ``render()`` here when no process can be forked."""
    from PIL import Image

    Image.preinit()  # the PNG encoder, loaded once here rather than in every worker
    read_fd, write_fd = os.pipe()
    try:
        import fcntl

        fcntl.fcntl(write_fd, getattr(fcntl, "F_SETPIPE_SZ", 1031), _PIPE_BYTES)
    except OSError:
        pass  # a smaller pipe: the worker waits for the reader, nothing else changes
    try:
        pid = os.fork()
    except OSError:
        os.close(read_fd)
        os.close(write_fd)
        return render()
    if pid == 0:  # the worker: render, write, leave without running this process's exit handlers
        code = 1
        try:
            os.close(read_fd)
            # a warning would write to stderr, whose lock another thread of the parent (a progress
            # bar's) may have held at the fork: the worker says nothing, its status tells
            warnings.simplefilter("ignore")
            data = render()
            view = memoryview(data)
            while view:
                view = view[os.write(write_fd, view):]
            code = 0
        finally:
            os._exit(code)
    os.close(write_fd)
    return LaterBytes(lambda: _collect(pid, read_fd), lambda: _discard(pid, read_fd))


_PNG_END = b"IEND\xaeB`\x82"  # the last chunk of every PNG: the worker wrote it whole


def _collect(pid: int, read_fd: int) -> bytes:
    """The worker's PNG, once it has ended."""
    with os.fdopen(read_fd, "rb") as fh:
        data = fh.read()
    try:
        code = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
    except ChildProcessError:  # reaped by someone else (SIGCHLD ignored): the image tells
        code = 0
    if code != 0 or not data.startswith(b"\x89PNG") or not data.endswith(_PNG_END):
        raise RuntimeError(f"the key frame worker (process {pid}) ended with status {code} without an image "
                           "(run again, or with --no-keyframes)")
    return data


def _discard(pid: int, read_fd: int) -> None:
    """A worker whose image nobody asked for: close its pipe and reap it."""
    try:
        os.close(read_fd)
        os.waitpid(pid, 0)
    except Exception:  # already reaped, or the interpreter is shutting down
        pass
