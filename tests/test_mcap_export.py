"""MCAP out (issue 13): ``kbplanner simulate --mcap`` and ``kbplanner export-mcap`` write a run with
Foxglove's schemas; read back with the mcap libraries, the message counts match the run directory."""

from __future__ import annotations

import csv
import math
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from kbplanner.analysis.mcap_export import read_mcap_counts
from sim_project_factory import make_sim_project


def kbplanner(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "kbplanner", *args], capture_output=True, text=True,
                          timeout=600)


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("mcap")
    sp = make_sim_project(d / "proj", high_panel=False)
    proc = kbplanner("simulate", str(sp.directory), "--scenario", "stored", "--out", str(d / "run"),
                     "--no-keyframes", "--mcap", str(d / "run.mcap"))
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "wrote MCAP" in proc.stderr
    return d


def test_the_message_counts_match_the_run(run: Path) -> None:
    rows = list(csv.DictReader((run / "run" / "trajectories.csv").open(encoding="utf-8")))
    events = [ln for ln in (run / "run" / "events.jsonl").read_text(encoding="utf-8").splitlines() if ln]
    t_end = float(rows[-1]["t_s"])
    counts = read_mcap_counts(run / "run.mcap")
    assert counts == {"/map": 1, "/tf": len(rows), "/lidar": math.floor(t_end / 0.5) + 1,
                      "/events": len(events)}


def test_poses_scans_and_schemas_are_foxglove_ones(run: Path) -> None:
    rows = list(csv.DictReader((run / "run" / "trajectories.csv").open(encoding="utf-8")))
    seen: dict[str, object] = {}
    tf = []
    with (run / "run.mcap").open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for schema, channel, _msg, proto in reader.iter_decoded_messages():
            seen.setdefault(channel.topic, schema.name)
            if channel.topic == "/tf":
                tf.append(proto)
            if channel.topic == "/lidar" and "scan" not in seen:
                seen["scan"] = proto
    assert seen["/tf"] == "foxglove.FrameTransforms" and seen["/map"] == "foxglove.Grid"
    assert seen["/lidar"] == "foxglove.LaserScan" and seen["/events"] == "foxglove.Log"
    i = len(rows) // 2
    base = tf[i].transforms[0]
    assert base.child_frame_id == "base_link"
    assert base.translation.x == pytest.approx(float(rows[i]["x"])) and base.translation.y == pytest.approx(
        float(rows[i]["y"]))
    assert math.atan2(2 * base.rotation.w * base.rotation.z, 1 - 2 * base.rotation.z ** 2) == pytest.approx(
        float(rows[i]["yaw"]), abs=1e-6)
    assert [t.child_frame_id for t in tf[i].transforms[1:]] == ["worker/carpenter"]
    scan = seen["scan"]
    ranges = list(scan.ranges)  # type: ignore[attr-defined]
    assert len(ranges) == 541  # 270 degrees at 0.5 degrees, as the robot table's scanner
    assert any(math.isfinite(r) for r in ranges)  # the building's walls are seen from the start


def test_export_mcap_of_the_run_directory_gives_the_same_file(run: Path) -> None:
    proc = kbplanner("export-mcap", str(run / "run"), "--out", str(run / "again.mcap"))
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert (run / "again.mcap").read_bytes() == (run / "run.mcap").read_bytes()
    bad = kbplanner("export-mcap", str(run / "nowhere"), "--out", str(run / "x.mcap"))
    assert bad.returncode == 2 and "run directory not found" in bad.stderr and not (run / "x.mcap").exists()
    rate = kbplanner("export-mcap", str(run / "run"), "--out", str(run / "x.mcap"), "--scan-hz", "nan")
    assert rate.returncode == 2 and "--scan-hz" in rate.stderr and not (run / "x.mcap").exists()


def test_a_scan_in_a_room_sees_the_wall_and_a_worker_at_their_distances() -> None:
    import numpy as np

    from kbplanner.analysis.mcap_export import grid_scan
    from kbplanner.robot.lidar import LidarSpec
    from kbplanner.world.occupancy import OccupancyGrid

    occ = np.zeros((200, 200), dtype=bool)  # 10 x 10 m at 5 cm, walls 10 cm thick on each side
    occ[:2, :] = occ[-2:, :] = occ[:, :2] = occ[:, -2:] = True
    grid = OccupancyGrid(occ, (0.0, 0.0), 0.05)
    spec = LidarSpec(fov_rad=math.radians(270), step_rad=math.radians(0.5), range_min_m=0.1, range_max_m=20.0)
    ranges = grid_scan(grid, 3.0, 5.0, 0.0, spec, [(3.0, 7.0)])  # facing +x; a worker 2 m to the left
    angles = spec.angles()
    ahead = ranges[np.argmin(np.abs(angles))]
    left = ranges[np.argmin(np.abs(angles - math.pi / 2))]
    right = ranges[np.argmin(np.abs(angles + math.pi / 2))]
    assert ahead == pytest.approx(9.9 - 3.0, abs=0.05)  # the east wall's inner face at x = 9.9
    assert left == pytest.approx(2.0 - 0.25, abs=1e-6)  # the worker's body, before the north wall
    assert right == pytest.approx(5.0 - 0.1, abs=0.05)  # the south wall's inner face at y = 0.1
    assert np.isfinite(ranges).all()  # a closed room: every ray returns
