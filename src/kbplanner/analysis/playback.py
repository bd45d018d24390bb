"""4D playback (report): an interactive 3D view of a simulation run, offline, beside ``report.html``.

``write_playback`` writes ``playback/<scenario>.html``, one self-contained page: the world's glTF export
at the world date (:func:`kbplanner.world.exports.glb_bytes`, embedded as base64; static elements, the task
elements at the material storage, the site objects), the robot (its footprint as a box, with a heading
mark), the element it carries (its footprint in the carry mode, lifted), the workers and every path,
animated along the simulated time with a time slider, play/pause and a speed choice; elements move to
their installed pose when the run installs them; safety stops (red) and near misses (amber: a worker
closer than the threshold) are marked on the timeline and on the ground; a section cut 2.2 m above the
task storey's floor (on by default) keeps the robot visible inside the building. three.js, its GLTFLoader and
OrbitControls (MIT, bundled in ``analysis/viewer/``) are inlined as one classic script, so the page needs
no network and no module loading and opens from ``file://``. ``#t=SECONDS`` in the address sets the time;
the page keeps its state (time, robot pose, carried element, errors) on ``#state`` for tests.
"""

from __future__ import annotations

import base64
import gzip
import html
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from kbplanner.analysis.report_doc import ReportDoc
from kbplanner.analysis.run_record import RunRecord
from kbplanner.core.outputs import atomic_write_bytes, atomic_write_text
from kbplanner.model.project_data import ProjectData
from kbplanner.world.build import build_world
from kbplanner.world.exports import Y_UP, glb_bytes
from kbplanner.world.world_types import World, pose_matrix

if TYPE_CHECKING:
    from kbplanner.world.tables import WorldTables

VIEWER = Path(__file__).resolve().parent / "viewer"
FOLDER = "playback"
BUNDLE = "three-bundle.min.js.gz"
ROBOT_HEIGHT_M = 0.5
CUT_ABOVE_FLOOR_M = 2.2  # the section cut of the view: above workers (1.75 m), below ceilings


def _num(v: float, nd: int) -> float | None:
    return round(float(v), nd) if math.isfinite(v) else None


def _gl_matrix(m: np.ndarray[Any, Any]) -> list[float]:
    """A site-frame 4x4 transform as three.js's column-major array in the y-up frame."""
    return [round(float(v), 6) for v in (Y_UP @ m).T.flatten()]


def playback_data(rec: RunRecord, world: World, *, threshold_m: float = 1.0) -> dict[str, Any]:
    """The timeline of a run for the viewer (plain JSON-able values)."""
    tr = rec.trajectories
    installed: dict[str, float] = {}
    for e in rec.events:
        if e.get("kind") == "element_installed":
            gid = str((e.get("details") or {}).get("element") or e.get("element") or "")
            if gid:
                installed[gid] = float(e["t_s"])
    elements: dict[str, Any] = {}
    fps = rec.footprints.get("elements", {})
    for el in world.task_elements:
        if el.pose is None or el.installed_pose is None:
            continue
        elements[el.global_id] = {
            "label": el.label, "storage": _gl_matrix(pose_matrix(el.pose)),
            "installed": _gl_matrix(pose_matrix(el.installed_pose)),
            "installed_t": installed.get(el.global_id), "footprints": fps.get(el.global_id, {}),
        }
    marks = [{"kind": "stop", "t": round(t, 2), "x": round(x, 3), "y": round(y, 3), "text": "safety stop"}
             for t, x, y in rec.event_positions("stop")]
    for iv in rec.proximity(threshold_m=threshold_m).intervals:
        marks.append({"kind": "near", "t": round(iv.start_s, 2), "x": round(iv.x_m, 3), "y": round(iv.y_m, 3),
                      "text": f"{iv.worker} below {iv.threshold} ({iv.min_distance_m:.2f} m)"})
    marks.sort(key=lambda m: (m["t"], m["kind"]))
    wxy = list(tr.workers.values())
    xs = [float(v) for v in tr.x] + [float(v) for xy in wxy for v in xy[0] if math.isfinite(v)]
    ys = [float(v) for v in tr.y] + [float(v) for xy in wxy for v in xy[1] if math.isfinite(v)]
    if world.site_extent is not None:
        b = world.site_extent
        extent = [b.xmin, b.ymin, b.xmax, b.ymax]
    else:
        extent = [min(xs) - 5.0, min(ys) - 5.0, max(xs) + 5.0, max(ys) + 5.0]
    storey = world.storey(world.task_storey)
    cut_z = round(storey.elevation_m + CUT_ABOVE_FLOOR_M, 3) if storey is not None else None
    return {
        "cut_z": cut_z,
        "scenario": rec.scenario, "task": rec.manifest.get("task"), "robot_id": rec.manifest.get("robot"),
        "world_date": world.at.isoformat(), "ground_z": round(world.ground_z, 3),
        "extent": [round(v, 3) for v in extent],
        "t": [round(float(t), 2) for t in tr.t],
        "robot": {"x": [_num(v, 3) for v in tr.x], "y": [_num(v, 3) for v in tr.y],
                  "yaw": [_num(v, 4) for v in tr.yaw], "rects": rec.footprints.get("robot", []),
                  "height": ROBOT_HEIGHT_M},
        "carried": list(tr.carried), "carry_mode": list(tr.carry_mode),
        "workers": [{"name": name, "x": [_num(v, 3) for v in xy[0]], "y": [_num(v, 3) for v in xy[1]]}
                    for name, xy in sorted(tr.workers.items())],
        "elements": elements, "marks": marks,
    }


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>
html, body {{ margin: 0; height: 100%; font: 14px system-ui, sans-serif; }}
body {{ display: flex; flex-direction: column; }}
#view {{ flex: 1; width: 100%; min-height: 0; display: block; }}
#bar {{ display: flex; gap: 8px; align-items: center; padding: 6px 10px; background: #eee; }}
#track {{ position: relative; flex: 1; }}
#time {{ width: 100%; }}
#marks {{ position: absolute; left: 0; right: 0; top: -6px; height: 6px; }}
.mark {{ position: absolute; width: 3px; height: 8px; cursor: pointer; }}
.mark.stop {{ background: #d02020; }} .mark.near {{ background: #e0a000; }}
#legend {{ padding: 2px 10px 6px; color: #444; background: #eee; font-size: 12px; }}
</style></head><body>
<canvas id="view"></canvas>
<div id="bar"><button id="play">play</button>
<select id="speed" title="playback speed"><option value="1">1x</option><option value="5">5x</option>
<option value="20" selected>20x</option><option value="60">60x</option></select>
<div id="track"><div id="marks"></div><input id="time" type="range" min="0" value="0" aria-label="time"></div>
<span id="clock"></span>
<label title="hide everything higher than 2.2 m above the task storey's floor"><input id="cut" type="checkbox"
checked> cut above the storey</label></div>
<div id="legend">{legend}</div>
<output id="state" hidden></output>
<script id="world-glb" type="application/octet-stream">{glb}</script>
<script>window.KBP_PLAYBACK = {data};</script>
<script>{three}</script>
<script>{viewer}</script>
</body></html>
"""


def three_bundle() -> str:
    """The vendored three.js bundle (``viewer/three-bundle.min.js.gz``: kept gzipped, built as the viewer's
    README says), as the script text the page embeds."""
    return gzip.decompress((VIEWER / BUNDLE).read_bytes()).decode("utf-8")


def playback_html(data: dict[str, Any], glb: bytes, title: str) -> str:
    """The self-contained playback page."""
    legend = (f"{html.escape(title)}: world at {html.escape(str(data['world_date']))}. Magenta: the robot "
              "(footprint); teal: the element it carries (footprint in the carry mode); blue: workers and "
              "their paths; black: the robot's path; timeline and ground marks: red safety stops, amber near "
              "misses. Drag to orbit, scroll to zoom.")
    three = three_bundle()
    viewer = (VIEWER / "playback.js").read_text(encoding="utf-8")
    payload = json.dumps(data, separators=(",", ":"), sort_keys=True).replace("</", "<\\/")
    return _PAGE.format(title=html.escape(title), legend=legend, glb=base64.b64encode(glb).decode("ascii"),
                        data=payload, three=three.replace("</script", "<\\/script"),
                        viewer=viewer.replace("</script", "<\\/script"))


def write_playback(out_dir: Path, name: str, rec: RunRecord, world: World, *,
                   threshold_m: float = 1.0) -> Path:
    """Write ``out_dir/playback/<name>.html`` (and three.js's license beside it); returns the page."""
    page = out_dir / FOLDER / f"{name}.html"
    data = playback_data(rec, world, threshold_m=threshold_m)
    atomic_write_text(page, playback_html(data, glb_bytes(world), f"{name}: 4D playback"))
    atomic_write_bytes(out_dir / FOLDER / "LICENSE-three.txt", (VIEWER / "LICENSE-three.txt").read_bytes())
    return page


def add_playbacks(doc: ReportDoc, runs: dict[str, RunRecord], project_dir: Path, out_dir: Path, *,
                  threshold_m: float = 1.0,
                  loaded: Mapping[str | None, tuple[ProjectData, WorldTables | None]] | None = None,
                  ) -> list[Path]:
    """Write a playback page per run and put them into the report right after its summary.

    ``loaded`` (per scenario: the loaded project and its world tables, or None) saves loading a
    scenario again and reading its building (the same world is built)."""
    pages: list[Path] = []
    part = ReportDoc("")
    part.heading("4D playback")
    part.paragraph("The simulated run in the world at its date: drag the time slider or press play; "
                   "installed elements move from the storage to their place. The page works offline "
                   f"(three.js bundled, {FOLDER}/LICENSE-three.txt).")
    for name, rec in runs.items():
        task = str(rec.manifest.get("task") or "") or None
        kept = (loaded or {}).get(rec.scenario)
        project, tables = kept or (ProjectData.load(project_dir, scenario=rec.scenario), None)
        world = build_world(project, project.world_date(task), task, tables=tables)
        page = write_playback(out_dir, name, rec, world, threshold_m=threshold_m)
        pages.append(page)
        part.frame(f"{FOLDER}/{page.name}", f"{name}: 4D playback of the run")
    h2 = [i for i, b in enumerate(doc.blocks) if b.kind == "h2"]
    at = h2[1] if len(h2) > 1 else len(doc.blocks)
    doc.blocks[at:at] = part.blocks
    return pages
