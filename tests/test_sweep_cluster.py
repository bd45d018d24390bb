"""Scenario sweeps on real clusters on 127.0.0.1 (a Dask LocalCluster, a Ray head started with
``ray start``): the same table, byte for byte, as a serial sweep.

The Dask test needs ``dask[distributed]`` (in the ``dev`` extra, so CI runs it); the Ray test needs
``ray[client]`` (the ``ray`` extra, not in ``dev``: it is large) and is skipped where it is not installed.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from kbplanner.scale.sweep import SweepSpec, run_sweep
from kbplanner.scale.sweep_axes import parse_vary
from kbplanner.scale.sweep_pareto import SweepResult
from sim_project_factory import make_sim_project

RAY_START_TIMEOUT_S = 180.0
RAY_STOP_TIMEOUT_S = 30.0


def _spec(tmp_path: Path) -> SweepSpec:
    project = tmp_path / "p"
    make_sim_project(project, high_panel=False)
    return SweepSpec(project, scenario="stored", max_elements=1, axes=parse_vary(["storage=2.5,-4.5"]))


def _assert_same_table(tmp_path: Path, serial: SweepResult, other: SweepResult, other_dir: str,
                       seen: list[str]) -> None:
    assert seen == [r.variant for r in serial.rows]
    assert other.rows == serial.rows and serial.rows[0].installed == 1
    for name in ("sweep.csv", "sweep.json", "pareto.csv"):
        assert (tmp_path / "serial" / name).read_bytes() == (tmp_path / other_dir / name).read_bytes()


@pytest.mark.slow  # about 22 s (starts a local dask cluster): `make test-slow`, run by .ci/run
def test_a_sweep_on_a_local_dask_cluster_gives_the_serial_table(tmp_path: Path) -> None:
    distributed = pytest.importorskip("dask.distributed", reason="pip install 'kbplanner[cluster]'")
    spec = _spec(tmp_path)
    serial = run_sweep(spec, out_dir=tmp_path / "serial", workers=1)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        address = cluster.scheduler_address.removeprefix("tcp://")
        seen: list[str] = []
        on_dask = run_sweep(spec, out_dir=tmp_path / "dask", cluster=f"dask://{address}",
                            progress=lambda _d, _t, v: seen.append(v))
    _assert_same_table(tmp_path, serial, on_dask, "dask", seen)


# ---- Ray ----------------------------------------------------------------------------------------


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def _listening(port: int) -> bool:
    with socket.socket() as s:
        s.settimeout(0.5)
        return s.connect_ex(("127.0.0.1", port)) == 0


def _stop_group(proc: subprocess.Popen[bytes]) -> None:
    """SIGTERM to the process group of ``ray start --block`` (every Ray process it started), then SIGKILL."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        deadline = time.monotonic() + RAY_STOP_TIMEOUT_S
        while time.monotonic() < deadline:
            if proc.poll() is not None:
                try:
                    os.killpg(proc.pid, 0)
                except ProcessLookupError:
                    return
            time.sleep(0.2)
    proc.wait(timeout=RAY_STOP_TIMEOUT_S)


@pytest.fixture
def ray_head(monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    """A one-CPU Ray head on 127.0.0.1 (its own temp dir and process group); yields ``ray://...``."""
    pytest.importorskip("ray", reason="pip install 'kbplanner[ray]' (ray[client]; not in the dev extra)")
    exe = Path(sys.executable).with_name("ray")
    if not exe.is_file():
        pytest.skip("the ray command is not next to this Python")
    # Every Ray process binds and talks on the loopback address only (by default Ray uses the
    # machine's network address even when --node-ip-address is 127.0.0.1).
    monkeypatch.setenv("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
    monkeypatch.setenv("RAY_USAGE_STATS_ENABLED", "0")
    temp = Path(tempfile.mkdtemp(prefix="kbp-ray-"))  # short: Ray's socket paths must fit 107 bytes
    client_port = _free_port()
    cmd = [str(exe), "start", "--head", "--block", "--node-ip-address", "127.0.0.1",
           "--port", str(_free_port()), "--ray-client-server-port", str(client_port), "--num-cpus", "1",
           "--include-dashboard", "false", "--temp-dir", str(temp), "--disable-usage-stats"]
    log = (temp / "ray-start.log").open("wb")
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        deadline = time.monotonic() + RAY_START_TIMEOUT_S
        started = temp / "ray-start.log"
        # ready: every process up (ray start prints this after starting them) and the client port open
        while b"Ray runtime started" not in started.read_bytes() or not _listening(client_port):
            if proc.poll() is not None or time.monotonic() > deadline:
                log.flush()
                tail = started.read_text(errors="replace")[-3000:]
                pytest.fail(f"a local Ray head did not start (exit {proc.poll()}):\n{tail}")
            time.sleep(0.5)
        yield f"ray://127.0.0.1:{client_port}"
    finally:
        _stop_group(proc)
        log.close()
        shutil.rmtree(temp, ignore_errors=True)


def test_a_sweep_on_a_local_ray_cluster_gives_the_serial_table(tmp_path: Path, ray_head: str) -> None:
    spec = _spec(tmp_path)
    serial = run_sweep(spec, out_dir=tmp_path / "serial", workers=1)
    seen: list[str] = []
    on_ray = run_sweep(spec, out_dir=tmp_path / "ray", cluster=ray_head,
                       progress=lambda _d, _t, v: seen.append(v))
    _assert_same_table(tmp_path, serial, on_ray, "ray", seen)
    # the sweep closed its own connection: a second one connects afresh and gives the same table
    again = run_sweep(spec, out_dir=tmp_path / "ray2", cluster=ray_head)
    assert again.rows == serial.rows
