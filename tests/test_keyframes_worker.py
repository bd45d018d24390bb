"""B5 key frames rendered in a forked worker: the same PNG bytes as in the process, of the scene as it was
when the key frame was asked for, written by the run's writer; a failed or dropped worker."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from kbplanner.core.later_bytes import LaterBytes, resolved
from kbplanner.core.outputs import atomic_write_bytes
from kbplanner.planning.manipulation import robot_name
from kbplanner.simulation import keyframes
from kbplanner.simulation.keyframes import render_png, worker_possible
from kbplanner.simulation.sim_env import SimEnv
from sim_project_factory import load_sim_case

SIZE = (160, 120)

linux_only = pytest.mark.skipif(not hasattr(os, "fork"), reason="forked workers need os.fork")


@pytest.fixture(scope="module")
def env(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SimEnv]:
    case = load_sim_case(tmp_path_factory.mktemp("kfproj"), seed=3)
    sim = SimEnv(case.world, robot_name(case.refined), grid=case.grid, visuals=True)
    sim.reset(seed=3)
    yield sim
    sim.close()


@linux_only
def test_a_worker_renders_the_same_png_bytes_as_the_process(env: SimEnv) -> None:
    assert worker_possible(env)
    here = render_png(env, SIZE, worker=False)
    later = render_png(env, SIZE, worker=True)
    assert isinstance(later, LaterBytes) and not isinstance(here, LaterBytes)
    assert here.startswith(b"\x89PNG")
    assert resolved(later) == here
    assert render_png(env, SIZE) == b"" and isinstance(render_png(env, SIZE), LaterBytes)  # the default


@linux_only
def test_the_worker_renders_the_scene_of_the_key_frame_while_the_simulation_goes_on(env: SimEnv,
                                                                                    tmp_path: Path) -> None:
    import pybullet as p

    before = render_png(env, SIZE, worker=False)
    later = render_png(env, SIZE, worker=True)
    pos, orn = p.getBasePositionAndOrientation(env.robot.body, physicsClientId=env.client)
    p.resetBasePositionAndOrientation(env.robot.body, [pos[0] + 1.5, pos[1], pos[2]], orn,
                                      physicsClientId=env.client)
    try:
        moved = render_png(env, SIZE, worker=False)
        assert moved != before  # the robot moved in view
        atomic_write_bytes(tmp_path / "frame.png", later)  # the writer waits for the worker
        assert (tmp_path / "frame.png").read_bytes() == before
    finally:
        p.resetBasePositionAndOrientation(env.robot.body, pos, orn, physicsClientId=env.client)
    assert render_png(env, SIZE, worker=False) == before  # the process's scene is as it was


@linux_only
def test_a_key_frame_leaves_every_body_where_it_was(env: SimEnv) -> None:
    import pybullet as p

    def poses() -> list[tuple[tuple[float, ...], tuple[float, ...]]]:
        return [p.getBasePositionAndOrientation(p.getBodyUniqueId(i, physicsClientId=env.client),
                                                physicsClientId=env.client)
                for i in range(p.getNumBodies(physicsClientId=env.client))]

    start = poses()
    resolved(render_png(env, SIZE, worker=True))
    assert poses() == start


@linux_only
def test_a_failed_worker_is_an_error_when_its_image_is_asked_for(tmp_path: Path) -> None:
    def broken() -> bytes:
        raise ValueError("no picture")

    later = keyframes._in_worker(broken)
    with pytest.raises(RuntimeError, match=r"key frame worker .* without an image"):
        atomic_write_bytes(tmp_path / "frame.png", later)
    assert list(tmp_path.iterdir()) == []  # nothing half-written
    cut = keyframes._in_worker(lambda: b"\x89PNG\r\n\x1a\n" + bytes(100))  # no IEND: not a whole image
    with pytest.raises(RuntimeError, match=r"key frame worker .* status 0 without an image"):
        resolved(cut)


def test_with_the_gui_key_frames_are_rendered_in_the_process(env: SimEnv,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(env, "gui", True)
    assert not worker_possible(env)
    png = render_png(env, SIZE)
    assert not isinstance(png, LaterBytes) and png.startswith(b"\x89PNG")


@linux_only
def test_a_worker_nobody_waits_for_is_reaped_when_dropped(monkeypatch: pytest.MonkeyPatch) -> None:
    forked: list[int] = []
    fork = os.fork

    def recorded_fork() -> int:
        pid = fork()
        if pid:
            forked.append(pid)
        return pid

    monkeypatch.setattr(os, "fork", recorded_fork)
    later = keyframes._in_worker(lambda: b"\x89PNG" + bytes(200_000))
    assert isinstance(later, LaterBytes) and len(forked) == 1
    del later
    # this worker is no child any more: it was reaped (other tests of this process may have children)
    with pytest.raises(ChildProcessError):
        os.waitpid(forked[0], os.WNOHANG)


def test_later_bytes_wait_once_and_copy_as_their_content() -> None:
    import copy
    import pickle

    calls: list[int] = []

    def wait() -> bytes:
        calls.append(1)
        return b"content"

    later = LaterBytes(wait)
    assert later == b""  # a stand-in: its own bytes are empty
    assert resolved(later) == b"content" and later.result() == b"content" and calls == [1]
    assert pickle.loads(pickle.dumps(later)) == b"content" and copy.copy(later) == b"content"
    assert resolved(b"now") == b"now"


def test_versions_are_read_once_and_each_caller_gets_its_own_dict() -> None:
    from kbplanner.core.outputs import versions

    first = versions()
    assert first["python"] and "pybullet" in first
    first["python"] = "changed by a caller"
    assert versions()["python"] != "changed by a caller" and versions() == versions()
