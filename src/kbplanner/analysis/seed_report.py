"""Outputs of ``kbplanner compare --seeds`` (analysis): tables, plot and summary over seeds.

``write_seed_outputs(study, dir)`` writes

- ``seeds.csv``: one row per run (scenario, seed, monitoring, installed, every figure, run folder);
- ``seed_summary.csv`` / ``seed_summary.json``: per scenario the median and the worst case of each
  figure (:data:`kbplanner.analysis.seed_study.FIGURES`), the seeds that installed nothing, the
  collisions (seed, time, who, cause), the time cost of monitoring, and the scenarios side by side
  (each against the first given: duration and separation, median and worst case);
- ``figures/seeds.png``: a box and strip plot per figure, one box per scenario (and per scenario with
  monitoring off, when run);
- ``summary.md`` / ``summary.html``: all of it for a planner to read.

Nothing in them depends on the wall clock: the same project and seeds give the same files.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from kbplanner.analysis.plots import seed_strips
from kbplanner.analysis.report_doc import ReportDoc
from kbplanner.analysis.seed_study import FIGURES, Say, SeedRun, SeedStudy, run_seeds
from kbplanner.core.outputs import atomic_write_text, write_json
from kbplanner.core.tables import render

PLOTTED = ("duration_min", "min_separation_m", "time_below_protective_s", "time_below_1m_s", "time_lost_s",
           "collisions")


def _seed_list(seeds: list[int]) -> str:
    return ", ".join(str(s) for s in seeds) if seeds else "none"


def run_rows(study: SeedStudy) -> tuple[list[str], list[list[Any]]]:
    """The per-run table."""
    cols = ["scenario", "seed", "monitoring", "installed", *[f.key for f in FIGURES], "run"]
    rows = [
        [r.scenario, r.seed, r.monitoring, f"{r.installed}/{r.elements}",
         *[r.figures.get(f.key) for f in FIGURES], r.run_dir]
        for r in [*study.runs, *study.cost_runs]
    ]
    return cols, rows


def _all_less(a: list[float | None], b: list[float | None]) -> bool | None:
    """Whether every value of ``a`` is below its partner in ``b`` (None: a value is missing)."""
    pairs = [(x, y) for x, y in zip(a, b, strict=True) if x is not None and y is not None]
    return None if len(pairs) < len(a) else all(x < y for x, y in pairs)


def versus(study: SeedStudy) -> list[dict[str, Any]]:
    """Each scenario against the first: duration and minimum separation, median and worst case."""
    if len(study.scenarios) < 2:
        return []
    base = study.scenarios[0]
    b = study.statistics(base)
    out = []
    for name in study.scenarios[1:]:
        s = study.statistics(name)
        d_med, d_worst = s["duration_min"]["median"], s["duration_min"]["worst"]
        b_med, b_worst = b["duration_min"]["median"], b["duration_min"]["worst"]
        sep, b_sep = s["min_separation_m"], b["min_separation_m"]
        faster = _all_less([d_med, d_worst], [b_med, b_worst])
        safer = None if sep["worst"] is None or b_sep["worst"] is None else sep["worst"] >= b_sep["worst"]
        collisions = sum(len(r.collisions) for r in study.of(name))
        base_collisions = sum(len(r.collisions) for r in study.of(base))
        if faster is None:
            verdict = f"no duration to compare ({name} or {base} installed nothing)"
        else:
            verdict = (f"{name} is {'shorter' if faster else 'not shorter'} than {base} at the median and in "
                       f"the worst case; its worst-case minimum separation is "
                       f"{'not smaller' if safer else 'smaller' if safer is not None else 'not known'}; "
                       f"collisions {collisions} vs {base_collisions}")
        out.append({
            "scenario": name, "against": base,
            "duration_min": {"median": [d_med, b_med], "worst": [d_worst, b_worst]},
            "min_separation_m": {"median": [sep["median"], b_sep["median"]],
                                 "worst": [sep["worst"], b_sep["worst"]]},
            "shorter": faster, "separation_not_smaller": safer,
            "collisions": [collisions, base_collisions],
            "pays": bool(faster and safer and collisions <= base_collisions),
            "verdict": verdict,
        })
    return out


def _collision(run: SeedRun, c: dict[str, Any]) -> dict[str, Any]:
    return {"scenario": run.scenario, "seed": run.seed, "monitoring": run.monitoring, **c}


def summary_data(study: SeedStudy) -> dict[str, Any]:
    """The JSON summary (see module docstring)."""
    scen: dict[str, Any] = {}
    for name in study.scenarios:
        runs = study.of(name)
        entry: dict[str, Any] = {
            "runs": len(runs),
            "seeds": [r.seed for r in runs],
            "installed": {str(r.seed): f"{r.installed}/{r.elements}" for r in runs},
            "no_element_installed": [r.seed for r in runs if not r.counted],
            "figures": study.statistics(name),
        }
        cost = study.monitoring_cost(name)
        if cost is not None:
            entry["monitoring_off"] = {"seeds": [r.seed for r in study.of(name, cost=True)],
                                       "figures": study.statistics(name, cost=True)}
            entry["monitoring_cost_s"] = {"seeds_compared": cost.seeds, "per_seed": cost.delta_s,
                                          "median": cost.median_s, "worst": cost.worst_s,
                                          "collisions_without_monitoring": cost.off_collisions}
        scen[name] = entry
    return {
        "seeds": study.seeds,
        "monitoring": study.monitoring,
        "definitions": "figures from each run's metrics.json (safety, totals); median and worst case over "
                       "the runs that installed at least one element; worst: the lowest minimum "
                       "separation, the highest of the others; monitoring cost: duration with monitoring "
                       "on minus off, per seed, over seeds that installed the same elements both ways",
        "scenarios": scen,
        "collisions": [_collision(r, c) for r, c in study.collisions()],
        "collisions_without_monitoring": [_collision(r, c) for r, c in study.collisions(cost=True)],
        "versus": versus(study),
    }


def _stats_rows(study: SeedStudy) -> tuple[list[str], list[list[Any]]]:
    cols = ["scenario", "monitoring", "figure", "median", "worst"]
    rows: list[list[Any]] = []
    for name in study.scenarios:
        for cost in (False, True):
            if cost and not study.of(name, cost=True):
                continue
            stats = study.statistics(name, cost=cost)
            for f in FIGURES:
                rows.append([name, "off" if cost else study.monitoring, f.label, stats[f.key]["median"],
                             stats[f.key]["worst"]])
    return cols, rows


def plot(study: SeedStudy) -> bytes:
    """The box and strip plot of the runs."""
    labels = {f.key: f.label for f in FIGURES}
    panels = []
    for key in PLOTTED:
        groups: dict[str, list[float]] = {}
        for name in study.scenarios:
            for cost in (False, True):
                runs = study.of(name, cost=cost)
                if cost and not runs:
                    continue
                g = f"{name} (monitoring off)" if cost else name
                groups[g] = [float(v) for r in runs if r.counted and (v := r.figures.get(key)) is not None]
        panels.append((labels[key], groups))
    return seed_strips(panels, title=f"{len(study.seeds)} seeds per scenario (monitoring {study.monitoring})")


def write_seed_outputs(study: SeedStudy, out_dir: Path, *, title: str) -> dict[str, Any]:
    """Write every output of ``compare --seeds`` into ``out_dir``; returns the JSON summary."""
    cols, rows = run_rows(study)
    atomic_write_text(out_dir / "seeds.csv", render(cols, rows, "csv"))
    scols, srows = _stats_rows(study)
    atomic_write_text(out_dir / "seed_summary.csv", render(scols, srows, "csv"))
    data = summary_data(study)
    write_json(out_dir / "seed_summary.json", data)
    doc = ReportDoc(title)
    hits = data["collisions"]
    if hits:
        doc.heading("COLLISIONS")
        doc.paragraph(f"{len(hits)} collision(s) between the robot and a worker (monitoring "
                      f"{study.monitoring}); each is an event in its run's events.jsonl.")
        doc.table(["scenario", "seed", "t (s)", "worker", "cause", "robot speed (m/s)"],
                  [[c["scenario"], c["seed"], c["t_s"], c["worker"], c["cause"], c["robot_speed_mps"]]
                   for c in hits])
    doc.heading("Over seeds")
    doc.paragraph(f"Seeds {_seed_list(study.seeds)}, monitoring {study.monitoring}. Median and worst case "
                  "over the runs that installed at least one element (worst: the lowest minimum separation, "
                  "the highest of the other figures). Figures from each run's metrics.json.")
    doc.table(scols, srows, caption="median and worst case per scenario")
    for name, entry in data["scenarios"].items():
        if entry["no_element_installed"]:
            doc.note(f"{name}: seed(s) {_seed_list(entry['no_element_installed'])} installed no element "
                     "(not in the medians).")
    doc.image("seeds.png", plot(study), "each point a seed; boxes: quartiles and median")
    for v in data["versus"]:
        doc.heading(f"Does {v['scenario']} still pay against {v['against']}?")
        d, s = v["duration_min"], v["min_separation_m"]
        doc.table(["figure", v["scenario"], v["against"]], [
            ["duration, median (min)", d["median"][0], d["median"][1]],
            ["duration, worst (min)", d["worst"][0], d["worst"][1]],
            ["min separation, median (m)", s["median"][0], s["median"][1]],
            ["min separation, worst (m)", s["worst"][0], s["worst"][1]],
            ["collisions", v["collisions"][0], v["collisions"][1]],
        ])
        doc.paragraph(("Yes: " if v["pays"] else "Not on every count: ") + v["verdict"] + ".")
    costs = [(n, e["monitoring_cost_s"]) for n, e in data["scenarios"].items() if "monitoring_cost_s" in e]
    if costs:
        doc.heading("The time cost of monitoring")
        doc.paragraph("The same seeds with speed and separation monitoring off: the duration with monitoring "
                      "minus without, seed by seed (seeds that installed the same elements both ways).")
        doc.table(["scenario", "seeds compared", "median (s)", "worst (s)", "collisions without monitoring"],
                  [[n, len(c["seeds_compared"]), c["median"], c["worst"], c["collisions_without_monitoring"]]
                   for n, c in costs])
    doc.heading("Runs")
    doc.table(cols, rows)
    doc.write(out_dir, stem="summary")
    return data


def compare_seeds(
    project_dir: str | Path,
    scenarios: list[str],
    seeds: list[int],
    *,
    out_dir: str | Path,
    monitoring: str = "ssm",
    reactive_workers: bool = True,
    cost_seeds: list[int] | None = None,
    progress: Say | None = None,
    line: Say | None = None,
    max_elements: int | None = None,
    jobs_n: int = 1,
) -> tuple[SeedStudy, dict[str, Any]]:
    """Simulate each scenario for each seed and write the outputs into ``out_dir`` (atomically).

    ``cost_seeds``: seeds to run again with monitoring off (the time cost of monitoring). ``jobs_n``:
    simulations at a time, one process each (the outputs do not depend on it).

    Example:
        >>> study, summary = compare_seeds("data/case_study", ["storage-outside", "storage-inside"],
        ...                                list(range(1, 21)), out_dir="runs/seeds")  # doctest: +SKIP
    """
    from kbplanner.core.errors import KbplannerError
    from kbplanner.core.outputs import run_directory
    from kbplanner.model.project_manifest import read_manifest

    project_dir, out_dir = Path(project_dir), Path(out_dir)
    manifest = read_manifest(project_dir)
    unknown = [n for n in scenarios if n not in manifest.scenarios]
    if unknown or not scenarios or not seeds:
        raise KbplannerError(
            f"unknown scenario(s) {unknown}" if unknown else "no scenario given" if not scenarios
            else "no seed given",
            file=manifest.path,
            fix="choose from: " + ", ".join(sorted(manifest.scenarios)) if scenarios else "give --scenarios",
        )
    with run_directory(out_dir) as stage:
        study = run_seeds(project_dir, scenarios, seeds, stage, monitoring=monitoring,
                          reactive_workers=reactive_workers, cost_seeds=cost_seeds or [], progress=progress,
                          line=line, max_elements=max_elements, jobs_n=jobs_n)
        data = write_seed_outputs(study, stage, title=f"kbplanner: {manifest.name}, {len(seeds)} seeds")
    return study, data
