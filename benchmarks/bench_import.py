"""Benchmark of the IFC import: time and peak memory for the Duplex and generated buildings.

Each case runs in a fresh subprocess so that its peak resident memory (``ru_maxrss``) is its own.
Prints a table and writes ``benchmarks/results/import.json``.

    .venv/bin/python benchmarks/bench_import.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

from _common import REPO, RESULTS_DIR, Timer, machine_info, peak_rss_mb, run_child_json, write_json

RESULTS = RESULTS_DIR / "import.json"
DUPLEX = Path("/work/shared/data/ifc/Duplex_A_20110907.ifc")
CASE_STUDY_DUPLEX = REPO / "data" / "case_study" / "model" / "Duplex_A_20110907.ifc"

# name -> write_test_building arguments
GENERATED = {
    "generated-10-storeys": {"storeys": 10, "bays": 8, "furniture_per_space": 2},
    "generated-20-storeys": {"storeys": 20, "bays": 16, "furniture_per_space": 3},
}


def run_case(ifc: Path, processes: int) -> dict[str, object]:
    """Import one file in this process; returns the figures."""
    from kbplanner.core.iris import base_iri
    from kbplanner.model.ifc_import import import_ifc

    with tempfile.TemporaryDirectory() as out:
        with Timer() as timer:
            result = import_ifc(ifc, Path(out), base=base_iri("bench"), processes=processes)
        seconds = timer.seconds
        ttl_bytes = (Path(out) / "model.ttl").stat().st_size
        mesh_bytes = sum(p.stat().st_size for p in (Path(out) / "meshes").iterdir())
    elements = sum(n for k, n in result.counts.items() if k.startswith("kbp:"))
    return {
        "file": ifc.name,
        "file_mb": round(ifc.stat().st_size / 1e6, 2),
        "schema": result.schema,
        "processes": processes,
        "seconds": round(seconds, 2),
        "peak_rss_mb": round(peak_rss_mb(), 1),
        "elements": elements,
        "meshes": len(result.meshes),
        "triples": len(result.graph),
        "skipped": len(result.skipped),
        "model_ttl_mb": round(ttl_bytes / 1e6, 2),
        "meshes_mb": round(mesh_bytes / 1e6, 2),
    }


def in_subprocess(ifc: Path, processes: int) -> dict[str, object]:
    return run_child_json([sys.executable, __file__, "--one", str(ifc), "--processes", str(processes)])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="only the Duplex and the 10-storey building")
    parser.add_argument("--one", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--processes", type=int, default=1, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(run_case(args.one, args.processes)))
        return 0

    sys.path.insert(0, str(REPO / "tests"))
    from ifc_factory import write_test_building

    cases: list[tuple[str, Path]] = []
    duplex = CASE_STUDY_DUPLEX if CASE_STUDY_DUPLEX.is_file() else DUPLEX
    if duplex.is_file():
        cases.append(("duplex", duplex))
    work = Path(tempfile.mkdtemp(prefix="kbplanner-bench-"))
    for name, kwargs in GENERATED.items():
        if args.quick and name != "generated-10-storeys":
            continue
        timer = Timer()
        path = work / f"{name}.ifc"
        write_test_building(path, schema="IFC4", unit_mm=True, **kwargs)  # type: ignore[arg-type]
        print(f"wrote {path.name} ({path.stat().st_size / 1e6:.1f} MB) in "
              f"{timer.elapsed():.1f} s", file=sys.stderr)
        cases.append((name, path))

    rows = []
    for name, path in cases:
        for processes in (1, 2):
            figures = {"case": name, **in_subprocess(path, processes)}
            rows.append(figures)
            print(f"{name:<22} {figures['file_mb']:>6} MB  processes={processes}  "
                  f"{figures['seconds']:>6} s  peak {figures['peak_rss_mb']:>7} MB  "
                  f"{figures['elements']} elements, {figures['meshes']} meshes, "
                  f"{figures['triples']} triples")
    write_json(RESULTS, {"machine": machine_info(), "cases": rows})
    print(f"wrote {RESULTS.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
