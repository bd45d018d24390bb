"""Benchmark of the exchange outputs (docs/exchange.md) on the case study: IDS, augmented IFC, BCF,
MCAP and the 4D playback page.

Simulates the case study's ``storage-inside`` scenario once (seed of project.toml, no key frames) into a
temporary run directory, then times each export and records its size: the IDS of the bare model
(ifctester), the IFC augmented from ``storage-outside`` (ifcopenshell.api), the BCF of the bare model's
validation (bcf-client), the run as MCAP (Foxglove schemas) and the playback page (world glTF + three.js).
Prints a table and writes ``benchmarks/results/exchange.json``.

    .venv/bin/python benchmarks/bench_exchange.py
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from _common import REPO, RESULTS_DIR, Timer, machine_info, write_json

from kbplanner.analysis.bcf_export import validation_issues, write_bcf
from kbplanner.analysis.mcap_export import export_mcap
from kbplanner.analysis.playback import write_playback
from kbplanner.analysis.run_record import RunRecord
from kbplanner.cli.export_mcap import scanner
from kbplanner.knowledge.ids_export import ids_export
from kbplanner.knowledge.validation import validate_model
from kbplanner.model.ifc_augment import write_augmented_ifc
from kbplanner.planning.manipulation import refine_plan
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project
from kbplanner.simulation.executor import simulate
from kbplanner.simulation.skills import ExecSettings
from kbplanner.world.build import build_world
from kbplanner.world.maps import storey_map

CASE = REPO / "data" / "case_study"
RESULTS = RESULTS_DIR / "exchange.json"


def main() -> int:
    rows: list[dict[str, object]] = []
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        bare = Project.load(CASE)
        req = bare.requirements()
        with Timer() as t:
            export = ids_export(req)
            export.write(tmp / "req.ids")
        rows.append({"output": "IDS (bare model)", "seconds": t.seconds,
                     "bytes": (tmp / "req.ids").stat().st_size, "items": len(export.specs)})
        outside = Project.load(CASE, scenario="storage-outside")
        with Timer() as t:
            res = write_augmented_ifc(bare.manifest.ifc, tmp / "aug.ifc", export, outside.model)
        rows.append({"output": "augmented IFC", "seconds": t.seconds,
                     "bytes": (tmp / "aug.ifc").stat().st_size, "items": res.properties})
        report = validate_model(bare.model, bare.kb).report_graph
        with Timer() as t:
            issues, _ = validation_issues(report, bare.model)
            bcf = write_bcf(issues, tmp / "issues.bcfzip", ifc_path=bare.manifest.ifc, project_name=bare.name,
                            created=bare.world_date())
        rows.append({"output": "BCF (validation)", "seconds": t.seconds,
                     "bytes": (tmp / "issues.bcfzip").stat().st_size, "items": bcf.topics})

        project = Project.load(CASE, scenario="storage-inside")
        world = build_world(project, project.world_date(), None)
        grid = storey_map(world).grid
        plan = refine_plan(plan_task(project, None, None, world=world), world, seed=project.manifest.seed,
                           grid=grid)
        simulate(project, plan, seed=project.manifest.seed, out_dir=tmp / "run", world=world, grid=grid,
                 settings=ExecSettings(keyframes=False))
        rec = RunRecord.load(tmp / "run")
        with Timer() as t:
            m = export_mcap(rec, tmp / "run.mcap", grid=grid, start=project.world_date(),
                            lidar=scanner(str(rec.manifest["robot"])))
        rows.append({"output": "MCAP (run)", "seconds": t.seconds,
                     "bytes": (tmp / "run.mcap").stat().st_size, "items": sum(m.counts.values())})
        with Timer() as t:
            page = write_playback(tmp, "storage-inside", rec, world)
        rows.append({"output": "playback page", "seconds": t.seconds, "bytes": page.stat().st_size,
                     "items": len(rec.trajectories.t)})
    print(f"{'output':<20} {'seconds':>8} {'bytes':>10} {'items':>7}")
    for r in rows:
        print(f"{r['output']!s:<20} {r['seconds']:8.2f} {r['bytes']:>10} {r['items']:>7}")
    write_json(RESULTS, {"machine": machine_info(), "rows": rows})
    print(f"wrote {RESULTS}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
