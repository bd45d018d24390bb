"""Stages of the scale benchmark (benchmarks/run.py), run in one process per building size.

Not a pipeline step: measurement of the pipeline. ``measure_size(storeys, units, workdir, endpoint=...)``
generates a building (kbplanner.scale.building_generator), then times every pipeline stage that exists on it,
in order, and returns JSON-ready records: wall time, the process's peak resident memory after the stage
and how much the stage raised it (``ru_maxrss``, so a fresh process per size), and what the stage
produced. Stages: generate, import (IFC -> graph and meshes, cache cleared first), load (bare model),
requirements (A3), load of the scenario, validation (A4), named queries (every ``.rq`` once, unbound,
on rdflib), world (A6, the simulation task), occupancy map (its storey), plan (B1-B3, the simulation
task), plan of every robotized task (one per storey, ``planning.plan_tasks``: world tables read once),
then, when the simulation task has at most ``simulate_max_frames`` frames (one storey's framing):

- refine (B4): arm and base poses of the simulation task's plan;
- simulation (B5): the executor, key frames off, into ``workdir/sim-SxU/run``; the record has the
  simulated time, installed / elements, and the real-time factor (simulated s / wall s) of B5 alone
  and of B4 + B5;
- analysis: the run read back (``RunRecord.load``), its durations and the proximity of every worker
  (1 m threshold and ISO/TS 15066 separation);
- report: ``comparison.write_outputs`` for that run (comparison table, durations written back to the
  4D model, report.html) into ``workdir/sim-SxU/report``;

and last the same named queries on pyoxigraph and on a SPARQL endpoint (per-query times, rows compared).
The simulation stages also record ``frames`` (the simulated task's elements): ``run.py`` fits their
growth against it rather than against the building's elements.
"""

from __future__ import annotations

import logging
import shutil
import sys
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _common import Timer, peak_rss_mb

from kbplanner.core.named_queries import catalogue, run_text
from kbplanner.core.stores import result_json
from kbplanner.project import Project, import_cached, read_manifest
from kbplanner.scale.building_generator import generate_building
from kbplanner.scale.building_plan import SCENARIO

log = logging.getLogger(__name__)


class Recorder:
    """Times stages; a stage that raises is recorded as failed (with the error) and the run goes on."""

    def __init__(self) -> None:
        self.stages: list[dict[str, Any]] = []

    def run(self, name: str, fn: Callable[[], Any], **info: Any) -> Any:
        before = peak_rss_mb()
        timer = Timer()
        record: dict[str, Any] = {"stage": name}
        try:
            value = fn()
            record["ok"] = True
        except Exception as exc:  # a broken stage is a finding, not the end of the benchmark
            value = None
            record["ok"] = False
            record["error"] = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
            record["where"] = traceback.format_exc(limit=-3).strip().splitlines()[-3:]
        record["seconds"] = round(timer.elapsed(), 4)
        after = peak_rss_mb()
        record["peak_rss_mb"] = round(after, 1)
        record["peak_rss_raise_mb"] = round(after - before, 1)
        record.update(info)
        self.stages.append(record)
        sys.stderr.write(f"  {name:<22} {record['seconds']:9.2f} s  peak {after:7.0f} MB"
                         f"{'' if record['ok'] else '  FAILED ' + record['error']}\n")
        sys.stderr.flush()
        return value


def _query_times(project: Project, repeats: int) -> dict[str, dict[str, Any]]:
    """Best-of-``repeats`` time and canonical rows of every named query (unbound) on the project graph."""
    out: dict[str, dict[str, Any]] = {}
    for name, q in sorted(catalogue().items()):
        best = float("inf")
        rows = ""
        for _ in range(repeats):
            with Timer() as timer:
                rows = result_json(run_text(project.graph, q.text, {}))
            best = min(best, timer.seconds)
        out[name] = {"seconds": round(best, 5), "rows": rows}
    return out


def _simulation_stages(rec: Recorder, project: Project, plan: Any, world: Any, grid: Any, sim_dir: Path,
                       requirements: Any) -> dict[str, Any]:
    """B4, B5 (key frames off), analysis and report of the simulation task; a summary of what they gave.

    When the executor is not installed, one failed record says why. Every record has ``frames`` (the
    plan's elements), the x of its growth exponent.
    """
    try:
        from kbplanner.analysis.comparison import ScenarioRun, write_outputs
        from kbplanner.analysis.plots import LayoutObject
        from kbplanner.analysis.run_record import RunRecord
        from kbplanner.planning.manipulation import refine_plan
        from kbplanner.simulation.executor import INSTALLED, simulate
        from kbplanner.simulation.skills import ExecSettings
    except ImportError as exc:
        rec.stages.append({"stage": "simulation (B5)", "ok": False, "seconds": None,
                           "error": f"not available: {exc}"})
        return {}
    frames = len(plan.elements)
    seed = project.manifest.seed
    run_dir, report_dir = sim_dir / "run", sim_dir / "report"
    refined = rec.run("refine (B4)", lambda: refine_plan(plan, world, seed=seed, grid=grid), frames=frames)
    if refined is None:
        return {}
    b4_s = float(rec.stages[-1]["seconds"])
    result = rec.run("simulation (B5)",
                     lambda: simulate(project, refined, seed=seed, out_dir=run_dir, world=world, grid=grid,
                                      settings=ExecSettings(keyframes=False)), frames=frames)
    if result is None:
        return {}
    b5 = rec.stages[-1]
    sim_s = float(result.sim_time_s)
    installed = sum(1 for e in result.elements if e.outcome == INSTALLED)
    b5["sim_time_s"] = round(sim_s, 1)
    b5["installed"] = installed
    b5["elements"] = len(result.elements)
    b5["real_time_factor"] = round(sim_s / max(float(b5["seconds"]), 1e-9), 1)
    b5["real_time_factor_b4_b5"] = round(sim_s / max(float(b5["seconds"]) + b4_s, 1e-9), 1)
    summary: dict[str, Any] = {"frames": frames, "installed": installed, "elements": len(result.elements),
                               "sim_time_s": b5["sim_time_s"], "real_time_factor": b5["real_time_factor"],
                               "real_time_factor_b4_b5": b5["real_time_factor_b4_b5"]}

    def analysis() -> dict[str, Any]:
        record = RunRecord.load(run_dir)
        durations = record.durations()
        proximity = record.proximity(threshold_m=1.0)
        return {"total_s": round(durations.total_s, 1), "installed": durations.installed,
                "first_element_s": (round(durations.first_element_s, 1)
                                    if durations.first_element_s is not None else None),
                "min_separation_m": (round(proximity.min_distance_m, 2)
                                     if proximity.workers else None),
                "time_below_1m_s": round(sum(w.time_below_threshold_s for w in proximity.workers), 1),
                "workers": len(proximity.workers)}

    figures = rec.run("analysis", analysis, frames=frames)
    if figures is not None:
        rec.stages[-1].update(figures)
        summary["analysis"] = figures
    layout = [LayoutObject(o.label, o.kind, o.pose.x, o.pose.y, o.size[0], o.size[1], o.pose.yaw)
              for o in world.site_objects]
    srun = ScenarioRun(scenario=project.scenario or "bare", run_dir=run_dir, installed=installed,
                       elements=len(result.elements), grid=grid, layout=layout)
    comp = rec.run("report",
                   lambda: write_outputs(project.path, [srun], report_dir, requirements=requirements,
                                         project=project),
                   frames=frames)
    if comp is not None:
        rec.stages[-1]["report_html"] = (report_dir / "report.html").is_file()
        summary["report_html"] = rec.stages[-1]["report_html"]
    return summary


def measure_size(storeys: int, units: int, workdir: Path, *, endpoint: str | None = None, repeats: int = 2,
                 simulate_max_frames: int = 0) -> dict[str, Any]:
    """Every stage on a generated ``storeys`` x ``units`` building (see the module docstring)."""
    from kbplanner.planning.planner import plan_task, plan_tasks
    from kbplanner.world.maps import storey_map

    rec = Recorder()
    directory = workdir / f"building-{storeys}x{units}"
    gen = rec.run("generate", lambda: generate_building(directory, storeys=storeys, units_per_storey=units,
                                                         force=True))
    shutil.rmtree(directory / ".kbplanner-cache", ignore_errors=True)
    rec.run("import", lambda: import_cached(read_manifest(directory)))
    bare = rec.run("load (bare)", lambda: Project.load(directory))
    req = rec.run("requirements", lambda: bare.requirements())
    project = rec.run("load (scenario)", lambda: Project.load(directory, scenario=SCENARIO))
    val = rec.run("validation", lambda: project.validate())
    mem = rec.run("named queries", lambda: _query_times(project, 1))
    world = rec.run("world", lambda: project.world())
    smap = plan = None
    if world is not None:
        smap = rec.run("occupancy map", lambda: storey_map(world))
        plan = rec.run("plan (one storey)", lambda: plan_task(project, world=world))
    tasks = [r[1] for r in project.query("tasks_and_elements").rows if r[5]]
    plans = rec.run("plan (every storey)", lambda: plan_tasks(project, tasks))
    simulation: dict[str, Any] = {}
    if plan is not None and smap is not None and 0 < len(plan.elements) <= simulate_max_frames:
        simulation = _simulation_stages(rec, project, plan, world, smap.grid,
                                        workdir / f"sim-{storeys}x{units}", req)
    stores: dict[str, Any] = {}
    if mem is not None:
        stores["memory"] = {k: v["seconds"] for k, v in mem.items()}
        ox = rec.run("load (oxigraph)", lambda: Project.load(directory, scenario=SCENARIO, store="oxigraph"))
        if ox is not None:
            oxq = rec.run("named queries (oxigraph)", lambda: _query_times(ox, repeats))
            if oxq is not None:
                stores["oxigraph"] = {k: v["seconds"] for k, v in oxq.items()}
                stores["oxigraph_different_rows"] = sorted(k for k in oxq
                                                           if oxq[k]["rows"] != mem[k]["rows"])
        if endpoint:
            ep = rec.run("load (endpoint)",
                         lambda: Project.load(directory, scenario=SCENARIO, store=endpoint))
            if ep is not None:
                epq = rec.run("named queries (endpoint)", lambda: _query_times(ep, repeats))
                if epq is not None:
                    stores["endpoint"] = {k: v["seconds"] for k, v in epq.items()}
                    stores["endpoint_different_rows"] = sorted(k for k in epq
                                                               if epq[k]["rows"] != mem[k]["rows"])
    return {
        "storeys": storeys,
        "units_per_storey": units,
        "elements": gen.elements if gen else None,
        "frames": gen.frames if gen else None,
        "triples": len(project.model) if project is not None else None,
        "requirements": len(req.requirements) if req is not None else None,
        "conforms": val.conforms if val is not None else None,
        "plan_steps": len(plan.steps) if plan is not None else None,
        "plan_feasible": plan.feasible if plan is not None else None,
        "plans_every_storey_steps": sum(len(p.steps) for p in plans) if plans else None,
        "map_cells": list(smap.grid.shape) if smap is not None else None,
        "simulation": simulation,
        "stages": rec.stages,
        "queries": stores,
    }
