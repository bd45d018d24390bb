"""B5 key frames: offscreen images of the simulation at a few events (first pick, door rotations, ...).

Takes the running :class:`~kbplanner.simulation.sim_env.SimEnv` (loaded with visual shapes) and returns PNG
bytes rendered with PyBullet's TinyRenderer (CPU, no display needed), from a camera high above and
behind the robot, looking down at it. The executor writes them as ``keyframes/NN_<event>.png``.

Example:
    >>> data = render_png(env, (640, 480))  # doctest: +SKIP
    >>> data[:4]  # doctest: +SKIP
    b'\\x89PNG'
"""

from __future__ import annotations

import io
import math

import numpy as np

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


def render_png(env: SimEnv, size: tuple[int, int] = (640, 480)) -> bytes:
    """A PNG of the scene around the robot, ``size`` = (width, height) pixels."""
    import pybullet as p
    from PIL import Image

    width, height = size
    x, y, yaw = env.base_pose()
    target = [x, y, env.world.ground_z + 0.8]
    view = p.computeViewMatrixFromYawPitchRoll(
        cameraTargetPosition=target, distance=CAMERA_DISTANCE_M,
        yaw=math.degrees(yaw) + CAMERA_OFFSET_DEG - 90.0, pitch=CAMERA_PITCH_DEG, roll=0.0, upAxisIndex=2,
        physicsClientId=env.client)
    proj = p.computeProjectionMatrixFOV(fov=60.0, aspect=width / height, nearVal=0.1, farVal=80.0,
                                        physicsClientId=env.client)
    hidden = _upper_bodies(env)
    for body in hidden:  # storeys above the robot's would hide it from a camera above
        p.resetBasePositionAndOrientation(body, [0.0, 0.0, -1000.0], [0.0, 0.0, 0.0, 1.0],
                                          physicsClientId=env.client)
    ground = env.world_bodies.ground
    # The ground plane and a slab at ground level are coplanar: the renderer's depth test streaks
    # them (z-fighting). For the picture only, the plane sits a little lower.
    p.resetBasePositionAndOrientation(ground, [0.0, 0.0, env.world.ground_z - GROUND_DROP_M],
                                      [0.0, 0.0, 0.0, 1.0], physicsClientId=env.client)
    try:
        _, _, rgba, _, _ = p.getCameraImage(width, height, viewMatrix=view, projectionMatrix=proj,
                                            renderer=p.ER_TINY_RENDERER, flags=p.ER_NO_SEGMENTATION_MASK,
                                            physicsClientId=env.client)
    finally:
        p.resetBasePositionAndOrientation(ground, [0.0, 0.0, env.world.ground_z], [0.0, 0.0, 0.0, 1.0],
                                          physicsClientId=env.client)
        for body in hidden:
            p.resetBasePositionAndOrientation(body, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0],
                                              physicsClientId=env.client)
    pixels = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="PNG")
    return buf.getvalue()
