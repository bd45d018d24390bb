"""Real IFC models, imported and mapped: what each holds, what the import kept, and every storey's map.

For each model (the Duplex of the case study and ``../shared/data/ifc/public/*.ifc`` when present):
counts per IFC class in the file (walls, doors, windows, slabs, members, ...) against the elements
in the graph and the skipped ones, the notes, then a project with the import and the occupancy map
of every storey (occupied %, levels at other heights, meshes not used fully), with ``map_<storey>.png``
written next to the JSON. Prints a table and writes ``benchmarks/results/real_models.json``.

    .venv/bin/python benchmarks/real_models.py [--out DIR] [IFC ...]
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, Timer, write_json

RESULTS = RESULTS_DIR / "real_models.json"
DUPLEX = REPO / "data" / "case_study" / "model" / "Duplex_A_20110907.ifc"
PUBLIC = REPO.parent / "shared" / "data" / "ifc" / "public"
CLASSES = ("IfcWall", "IfcDoor", "IfcWindow", "IfcSlab", "IfcRoof", "IfcStair", "IfcStairFlight", "IfcMember",
           "IfcPlate", "IfcColumn", "IfcBeam", "IfcCovering", "IfcSpace", "IfcBuildingElementProxy")


def measure(ifc: Path, out_dir: Path) -> dict[str, Any]:
    """Import ``ifc`` and map every storey; returns the figures."""
    import ifcopenshell
    from PIL import Image

    from kbplanner.core.iris import base_iri
    from kbplanner.core.vocab import KBP
    from kbplanner.model.dates import parse_date
    from kbplanner.model.ifc_import import import_ifc
    from kbplanner.project import Project
    from kbplanner.world.build import build_world
    from kbplanner.world.maps import storey_map

    f = ifcopenshell.open(str(ifc))
    with tempfile.TemporaryDirectory() as tmp:
        project = Path(tmp)
        with Timer() as timer:
            result = import_ifc(ifc, project, base=base_iri(ifc.stem))
        in_graph = {str(v) for v in result.graph.objects(None, KBP.globalId)}
        skipped = {s.global_id for s in result.skipped if not s.in_graph}
        classes: dict[str, dict[str, int]] = {}
        for cls in CLASSES:
            ids = {str(p.GlobalId) for p in f.by_type(cls)}
            if ids:
                classes[cls] = {"in_file": len(ids), "in_graph": len(ids & in_graph),
                                "skipped": len(ids & skipped), "lost": len(ids - in_graph - skipped)}
        (project / "project.toml").write_text(
            f'[project]\nname = "{ifc.stem}"\n[model]\nifc = "{ifc.resolve().as_posix()}"\n',
            encoding="utf-8")
        world = build_world(Project.load(project), parse_date("2100-01-01"), None)
        maps = []
        for storey in world.storeys:
            m = storey_map(world, storey.iri)
            slug = re.sub(r"[^A-Za-z0-9]+", "_", storey.label).strip("_") or storey.iri.rsplit("/", 1)[-1]
            png = out_dir / f"{ifc.stem}_map_{slug}.png"
            pixels = (~m.grid.occupied[::-1, :]).astype("uint8") * 254
            Image.fromarray(pixels).save(png)
            maps.append({"storey": storey.label, "elevation_m": storey.elevation_m,
                         "occupied_percent": round(100 * (1 - m.grid.free_fraction), 1),
                         "levels": [r.text() for r in m.levels], "notes": list(m.notes), "png": png.name})
    return {
        "file": ifc.name, "schema": result.schema, "import_seconds": round(timer.seconds, 2),
        "units": {"length": result.units.length_name if result.units else "", "mass":
                  result.units.mass_name if result.units else ""},
        "classes": classes, "counts": result.counts,
        "skipped": [f"{s.ifc_class} {s.name!r}: {s.reason}" for s in result.skipped],
        "blocking": len(result.blocking), "notes": len(result.notes),
        "note_kinds": sorted({n.kind for n in result.notes}), "maps": maps,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("ifc", nargs="*", type=Path)
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "real_models")
    args = parser.parse_args()
    files = args.ifc or [DUPLEX, *sorted(PUBLIC.glob("*.ifc"))]
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for ifc in files:
        if not ifc.is_file():
            print(f"{ifc}: not present, skipped", file=sys.stderr)
            continue
        row = measure(ifc, args.out)
        rows.append(row)
        print(f"{row['file']} ({row['schema']}, {row['units']['length']}, {row['units']['mass']}): "
              f"import {row['import_seconds']} s, {len(row['skipped'])} skipped "
              f"({row['blocking']} blocking), "
              f"{row['notes']} notes {row['note_kinds']}")
        for cls, c in row["classes"].items():
            print(f"  {cls:<24} file {c['in_file']:>4}  graph {c['in_graph']:>4}  skipped {c['skipped']:>3}"
                  f"  lost {c['lost']}")
        for m in row["maps"]:
            print(f"  map {m['storey']:<24} {m['elevation_m']:>7.2f} m  "
                  f"{m['occupied_percent']:>5.1f} % occupied"
                  f"  levels {len(m['levels'])}  notes {len(m['notes'])}")
    write_json(RESULTS, {"models": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
