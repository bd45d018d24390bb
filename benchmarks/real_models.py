"""Real IFC models, imported and mapped: what each holds, what the import kept, and every storey's map.

For each model (the Duplex of the case study and ``../shared/data/ifc/public/*.ifc`` when present):
counts per IFC class in the file (walls, doors, windows, slabs, members, ...) against the elements
in the graph and the skipped ones, the notes, then a project with the import and the occupancy map
of every storey (occupied %, levels at other heights, meshes not used fully), with ``map_<storey>.png``
written next to the JSON. Prints a table and writes ``benchmarks/results/real_models.json``. With
``--doc docs/own_building.md`` the tables between ``<!-- real-models:begin -->`` and
``<!-- real-models:end -->`` (section 3) are rendered from the JSON (``--render-only``: without importing).

    .venv/bin/python benchmarks/real_models.py [--out DIR] [--doc DOC] [--render-only] [IFC ...]
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, Timer, write_json

RESULTS = RESULTS_DIR / "real_models.json"
BEGIN, END = "<!-- real-models:begin -->", "<!-- real-models:end -->"
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
    apps = sorted({str(a.ApplicationFullName or a.ApplicationIdentifier or "").strip()
                   for a in f.by_type("IfcApplication")})
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
                         "levels": [r.text() for r in m.levels], "level_roles": [r.role for r in m.levels],
                         "notes": list(m.notes), "png": png.name})
    return {
        "file": ifc.name, "applications": [a for a in apps if a], "schema": result.schema,
        "import_seconds": round(timer.seconds, 2),
        "units": {"length": result.units.length_name if result.units else "", "mass":
                  result.units.mass_name if result.units else ""},
        "classes": classes, "counts": result.counts,
        "skipped": [f"{s.ifc_class} {s.name!r}: {s.reason}" for s in result.skipped],
        "blocking": len(result.blocking), "notes": len(result.notes),
        "note_kinds": sorted({n.kind for n in result.notes}), "maps": maps,
    }


SHOWN = {"IfcWall": "walls", "IfcDoor": "doors", "IfcWindow": "windows", "IfcSlab": "slabs"}


def _count(c: dict[str, int] | None) -> str:
    if c is None:
        return "-"
    return f"{c['in_graph']}/{c['in_file']}"


def _roles(roles: list[str]) -> str:
    counts: dict[str, int] = {}
    for r in roles:
        counts[r] = counts.get(r, 0) + 1
    return ", ".join(f"{n} {role}" for role, n in sorted(counts.items()))


def render(rows: list[dict[str, Any]]) -> str:
    """Section 3's two tables (imports, maps) from the JSON rows."""
    out = ["Generated by `benchmarks/real_models.py` from `benchmarks/results/real_models.json` (do not edit "
           "by hand). Counts are elements in the graph / products of that class in the file (ifcopenshell's "
           "`by_type`, subclasses included); \"lost\" = neither in the graph nor listed as skipped.", "",
           "| model | application | schema, units | walls | doors | windows | slabs | other classes "
           "(in the graph / in the file) | skipped | lost | notes |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        cls = r["classes"]
        others = ", ".join(f"{_count(c)} {name.removeprefix('Ifc')}" for name, c in cls.items()
                           if name not in SHOWN)
        lost = sum(c["lost"] for c in cls.values())
        units = ", ".join(u for u in (r["units"]["length"], r["units"]["mass"]) if u)
        notes = f"{r['notes']} ({', '.join(r['note_kinds'])})" if r["notes"] else "0"
        app = "; ".join(a.strip() for a in r.get("applications", [])) or "-"
        out.append(f"| {r['file']} | {app} | {r['schema']}, {units} | "
                   + " | ".join(_count(cls.get(k)) for k in SHOWN)
                   + f" | {others or '-'} | {len(r['skipped'])} | {lost} | {notes} |")
    out += ["", "| model | storey | elevation | occupied | at other heights than the floor | map notes "
            "| map |",
            "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        for m in r["maps"]:
            notes = "; ".join(n.split(":", 1)[0][:60] for n in m["notes"]) or "-"
            out.append(f"| {r['file']} | {m['storey']} | {m['elevation_m']:.2f} m | "
                       f"{m['occupied_percent']:.1f} % | {_roles(m.get('level_roles', [])) or '-'} | {notes} "
                       f"| `{m['png']}` |")
    return "\n".join(out)


def update_doc(doc: Path, rows: list[dict[str, Any]]) -> None:
    text = doc.read_text(encoding="utf-8")
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{doc}: no {BEGIN} ... {END} block to replace")
    head, rest = text.split(BEGIN, 1)
    tail = rest.split(END, 1)[1]
    doc.write_text(f"{head}{BEGIN}\n{render(rows)}\n{END}{tail}", encoding="utf-8")
    print(f"rendered {doc}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("ifc", nargs="*", type=Path)
    parser.add_argument("--out", type=Path, default=RESULTS_DIR / "real_models")
    parser.add_argument("--doc", type=Path, help="render section 3's tables into this document")
    parser.add_argument("--render-only", action="store_true", help="only render --doc from the JSON")
    args = parser.parse_args()
    if args.render_only:
        if args.doc is None:
            parser.error("--render-only needs --doc")
        update_doc(args.doc, json.loads(RESULTS.read_text(encoding="utf-8"))["models"])
        return 0
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
    if args.doc is not None:
        update_doc(args.doc, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
