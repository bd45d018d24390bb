"""The report: built from run records, written as HTML + Markdown, and shown by a real browser."""

from __future__ import annotations

import base64
import io
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from PIL import Image

from kbplanner.analysis.report import build_report
from kbplanner.analysis.run_record import RunRecord
from run_factory import write_run


@pytest.fixture()
def report_dir(tmp_path: Path) -> Path:
    write_run(tmp_path / "run")
    rec = RunRecord.load(tmp_path / "run")
    doc = build_report({"test": rec}, title="Test report")
    doc.write(tmp_path / "out")
    return tmp_path / "out"


def test_the_report_has_every_section_and_its_images_are_real_pngs(report_dir: Path) -> None:
    page = (report_dir / "report.html").read_text()
    for section in ("Summary", "Scenario test", "Durations"):
        assert f"<h2>{section}</h2>" in page
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', page)
    assert len(images) >= 4  # layout, distance, Gantt, per-frame bars
    for data in images:
        with Image.open(io.BytesIO(base64.b64decode(data))) as im:
            assert im.size[0] > 300 and im.size[1] > 200
    md = (report_dir / "report.md").read_text()
    assert md.count("](figures/") == len(images)
    assert "| test | 1/1 |" in md


@pytest.mark.skipif(shutil.which("chromium") is None, reason="headless Chromium (Debian) not installed")
def test_the_report_opens_in_headless_chromium_without_errors(report_dir: Path, tmp_path: Path) -> None:
    shot = tmp_path / "shot.png"
    proc = subprocess.run(
        ["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         f"--user-data-dir={tmp_path / 'profile'}", "--enable-logging=stderr", "--v=0",
         "--window-size=1200,2400", f"--screenshot={shot}", (report_dir / "report.html").as_uri()],
        capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Failed to load resource" not in proc.stderr
    assert "Uncaught" not in proc.stderr
    with Image.open(shot) as im:
        assert im.size == (1200, 2400)
        colours = im.convert("RGB").getcolors(maxcolors=1 << 20)
        assert colours is not None and len(colours) > 50  # text, tables and plots, not a blank page
