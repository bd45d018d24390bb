"""4D playback (issue 13): the report's interactive 3D view of a run, offline beside report.html, built on
the world's glTF and the bundled three.js; shown by headless Chromium at two times with the robot at two
places, no console error, the slider's time and the robot pose in the page state."""

from __future__ import annotations

import csv
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from kbplanner.analysis.playback import playback_data, three_bundle
from kbplanner.analysis.run_record import RunRecord
from kbplanner.project import Project
from kbplanner.world.build import build_world
from sim_project_factory import make_sim_project

CHROMIUM = shutil.which("chromium")
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium (Debian) not installed")


def kbplanner(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "kbplanner", *args], capture_output=True, text=True,
                          timeout=600)


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("playback")
    sp = make_sim_project(d / "proj", high_panel=False)
    sim = kbplanner("simulate", str(sp.directory), "--scenario", "stored", "--out", str(d / "run"),
                    "--no-keyframes")
    assert sim.returncode == 0, sim.stderr[-2000:]
    rep = kbplanner("report", str(d / "run"), "--out", str(d / "rep"))
    assert rep.returncode == 0, rep.stderr[-2000:]
    return d


def chromium(url: str, profile: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    assert CHROMIUM is not None
    return subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
         "--disable-background-networking",
         "--disable-component-update", "--no-first-run", "--disable-sync", "--disable-quic",
         f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0", "--virtual-time-budget=10000",
         "--window-size=1000,700", *extra, url],
        capture_output=True, text=True, timeout=120)


def console_messages(stderr: str) -> list[str]:
    """The page's console messages, but SwiftShader's notes on reading back the WebGL canvas (headless
    Chromium composites in software: 'GL Driver Message (OpenGL, Performance, ...)')."""
    return [ln for ln in stderr.splitlines()
            if ":CONSOLE" in ln and "GL Driver Message (OpenGL, Performance" not in ln]


def robot_at(run: Path, t: float) -> tuple[float, float]:
    rows = list(csv.DictReader((run / "trajectories.csv").open(encoding="utf-8")))
    last = [r for r in rows if float(r["t_s"]) <= t + 1e-9][-1]
    return float(last["x"]), float(last["y"])


def magenta_centre(png: Path) -> tuple[float, float, int]:
    with Image.open(png) as im:
        rgb = im.convert("RGB")
        px = rgb.load()
        assert px is not None
        pts = [(x, y) for x in range(rgb.width) for y in range(rgb.height)
               if px[x, y][0] > 230 and px[x, y][1] < 40 and px[x, y][2] > 230]
    assert pts, "the robot (magenta) is not drawn"
    return sum(p[0] for p in pts) / len(pts), sum(p[1] for p in pts) / len(pts), len(pts)


def test_the_report_embeds_an_offline_playback_page_with_three_js_and_the_world_gltf(report: Path) -> None:
    page = report / "rep" / "report.html"
    assert '<iframe src="playback/stored.html"' in page.read_text(encoding="utf-8")
    play = (report / "rep" / "playback" / "stored.html").read_text(encoding="utf-8")
    assert (report / "rep" / "playback" / "LICENSE-three.txt").read_text().startswith("The MIT License")
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", play)  # nothing fetched at view time
    assert three_bundle()[:200] in play
    assert re.search(r'<script id="world-glb" type="application/octet-stream">Z2xURg', play)  # "glTF" magic


def test_the_timeline_follows_the_run(report: Path) -> None:
    rec = RunRecord.load(report / "run")
    project = Project.load(report / "proj", scenario="stored")
    world = build_world(project, project.world_date(), None)
    data = playback_data(rec, world)
    assert len(data["t"]) == len(data["robot"]["x"]) == len(rec.trajectories.t)
    installed = {e["details"]["element"]: e["t_s"] for e in rec.events if e["kind"] == "element_installed"}
    assert {g: e["installed_t"] for g, e in data["elements"].items()} == installed and len(installed) == 2
    assert [m["t"] for m in data["marks"] if m["kind"] == "stop"] == [
        round(e["t_s"], 2) for e in rec.events if e["kind"] == "stop"]
    assert [w["name"] for w in data["workers"]] == ["carpenter"]


@needs_chromium
def test_headless_chromium_shows_the_robot_at_two_places_at_two_times(report: Path, tmp_path: Path) -> None:
    url = (report / "rep" / "playback" / "stored.html").as_uri()
    centres = []
    for t in (5.0, 60.0):
        dom = chromium(f"{url}#t={t}", tmp_path / "profile", "--dump-dom")
        assert dom.returncode == 0, dom.stderr[-2000:]
        state = re.search(r"<output id=\"state\"[^>]*>", dom.stdout)
        assert state is not None, dom.stdout[-2000:]
        attrs = dict(re.findall(r'data-([a-z]+)="([^"]*)"', state.group(0)))
        assert attrs["ready"] == "1" and "error" not in attrs, attrs
        assert float(attrs["t"]) == pytest.approx(t)  # the slider took the time ...
        x, y, _yaw = (float(v) for v in attrs["robot"].split(","))
        assert (x, y) == pytest.approx(robot_at(report / "run", t), abs=0.006)  # ... and moved the robot
        shot = tmp_path / f"t{t:g}.png"
        proc = chromium(f"{url}#t={t}", tmp_path / "profile", f"--screenshot={shot}")
        assert proc.returncode == 0, proc.stderr[-2000:]
        assert "Uncaught" not in proc.stderr and "Failed to load resource" not in proc.stderr
        assert console_messages(proc.stderr) == []
        with Image.open(shot) as im:
            colours = im.convert("RGB").getcolors(maxcolors=1 << 20)
            assert colours is not None and len(colours) > 100  # the canvas draws the world
        centres.append(magenta_centre(shot))
    (x0, y0, _), (x1, y1, _) = centres
    assert ((x1 - x0) ** 2 + (y1 - y0) ** 2) ** 0.5 > 50  # pixels: the robot is elsewhere


@needs_chromium
def test_the_report_with_its_playback_opens_without_errors(report: Path, tmp_path: Path) -> None:
    proc = chromium((report / "rep" / "report.html").as_uri(), tmp_path / "profile",
                    f"--screenshot={tmp_path / 'report.png'}")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Uncaught" not in proc.stderr and "Failed to load resource" not in proc.stderr
    assert console_messages(proc.stderr) == []
