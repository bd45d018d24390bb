"""``kbplanner init`` (issue 10): one command from an IFC file to a complete, runnable project.

:func:`init_project` reads any IFC that ifcopenshell opens and writes a project directory shaped like
``data/case_study`` (docs/projects.md) through the output rule (:mod:`kbplanner.core.output_dirs`):

1. the walls of the task storey that qualify for the framing task and their stud-frame panels
   (:mod:`.init_walls`), every other wall with its reason;
2. ``model/<name>_frames.ifc``: a copy of the IFC with the panels (:mod:`.init_ifc`); the input file is
   never written;
3. the site layout (robot start outside the entrance door), workers, jobsite, a schedule scaffold,
   the work sequence and grasp points (:mod:`.init_site`);
4. the scenarios ``storage-outside`` and ``storage-inside``: frame storages with pickup locations placed
   on the real occupancy map of the task storey (:mod:`.init_storage`) and checked with
   :func:`kbplanner.world.site_checks.check_pickup_locations` before the folder is installed.

Bad input (the IFC, ``--task``, ``--storey``, ``--walls``, the output folder) raises
:class:`~kbplanner.scale.init_walls.InitError` (exit 2); when no wall qualifies the result has no
frames and nothing is written (exit 1, with the reason per wall).
"""

from __future__ import annotations

import logging
import math
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from shapely.geometry import Polygon

from kbplanner.core.output_dirs import check_output_dir, output_options, run_directory
from kbplanner.knowledge.robot_selection import SPACE_MARGIN_M, WALL_TOLERANCE_M
from kbplanner.model.ifc_geometry import build_meshes, model_frame
from kbplanner.model.ifc_open import open_ifc, unit_scales
from kbplanner.model.project_data import ProjectData
from kbplanner.scale import init_layout as L
from kbplanner.scale import init_site as site
from kbplanner.scale.init_ifc import FrameRecord, write_frames
from kbplanner.scale.init_plan_check import ScenarioCheck
from kbplanner.scale.init_proposals import MAX_STACK, Place, propose
from kbplanner.scale.init_tasks import task_specification
from kbplanner.scale.init_walls import (
    InitError,
    PanelSpot,
    StoreyRef,
    WallChoice,
    axis_reason,
    body_from_parts,
    door_reason,
    footprint,
    opening_products,
    panel_spots,
    property_reason,
    room_doors,
    storey_of,
    storeys,
    wall_axis,
)
from kbplanner.world.build import world_of
from kbplanner.world.maps import storey_map

Say = Callable[[str], None]


@dataclass
class InitResult:
    """What :func:`init_project` found and wrote (``written`` false: no wall qualified, nothing written)."""

    source: Path
    directory: Path
    task: str
    specification: str
    storey: str
    walls: list[WallChoice]
    frames: list[FrameRecord] = field(default_factory=list)
    entrance: str = ""
    scenarios: dict[str, int] = field(default_factory=dict)  # name -> storages
    checks: dict[str, ScenarioCheck] = field(default_factory=dict)  # name -> its plan (B1-B4)
    notes: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    written: bool = False
    seconds: float = 0.0

    @property
    def chosen(self) -> list[WallChoice]:
        return [w for w in self.walls if w.chosen]


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") or "project"


def _select(f: Any, tokens: Sequence[str], path: Path) -> set[str]:
    walls = f.by_type("IfcWall")
    by_gid = {str(w.GlobalId): w for w in walls}
    out: set[str] = set()
    for t in tokens:
        hits = [str(w.GlobalId) for w in walls if t == str(w.GlobalId) or t == str(w.Name or "")]
        if not hits:
            names = sorted({str(w.Name) for w in walls if w.Name})[:8]
            raise InitError(
                f"--walls {t!r} is neither the GlobalId nor the Name of a wall",
                file=path,
                element=t,
                fix="give wall GlobalIds or names separated by commas, e.g. "
                + (", ".join(names) if names else next(iter(by_gid), "...")),
            )
        out.update(hits)
    return out


@dataclass
class _Storey:
    ref: StoreyRef
    entity: Any
    walls: list[Any]
    doors: list[Any]


def init_project(
    ifc_path: Path,
    out: Path,
    *,
    task: str = "frame-interior-walls",
    storey: str | None = None,
    walls: Sequence[str] = (),
    max_walls: int = 8,
    seed: int = 0,
    force: bool = False,
    check_plan: bool = True,
    progress: Say | None = None,
) -> InitResult:
    """Write a complete project for ``ifc_path`` into ``out`` (see the module docstring).

    ``check_plan``: plan each storage proposal as ``kbplanner plan`` does and keep the best of up to
    :data:`~kbplanner.scale.init_proposals.PROPOSALS` (False: the first placement, unchecked; faster).
    """
    t0 = time.perf_counter()
    say = progress or (lambda _m: None)
    if not 1 <= max_walls <= 1000:
        raise InitError(
            f"--max-walls must be from 1 to 1000, not {max_walls}",
            element="--max-walls",
            fix="give e.g. --max-walls 8",
        )
    spec = task_specification(task)
    with output_options(force=force):
        check_output_dir(out)
    path = Path(ifc_path)
    f = open_ifc(path)
    units = unit_scales(f, path)
    site_m = model_frame(f, units.length_m)
    to_site = np.linalg.inv(site_m)
    refs = {s.global_id: s for s in storeys(f, site_m, units.length_m)}
    if not refs:
        raise InitError(
            "the model has no IfcBuildingStorey",
            file=path,
            element="IfcBuildingStorey",
            fix="export the model with its storeys (levels)",
        )
    selected = _select(f, walls, path) if walls else None
    by_storey: dict[str, _Storey] = {g: _Storey(r, f.by_guid(g), [], []) for g, r in refs.items()}
    choices: dict[str, WallChoice] = {}
    overridden: list[str] = []  # walls named in --walls that Pset_WallCommon would rule out
    for w in sorted(f.by_type("IfcWall"), key=lambda e: str(e.GlobalId)):
        st = storey_of(w)
        gid = str(w.GlobalId)
        c = WallChoice(
            gid, str(w.Name or ""), str(st.Name or st.GlobalId) if st is not None else "", w.is_a()
        )
        choices[gid] = c
        if st is None or str(st.GlobalId) not in by_storey:
            c.reason = "not contained in a storey"
            continue
        by_storey[str(st.GlobalId)].walls.append(w)
        if selected is not None and gid not in selected:
            c.reason = "not named in --walls"
        elif selected is not None:  # named by the user: Pset_WallCommon does not rule it out
            if rule := property_reason(w):
                overridden.append(f"{c.name or gid} ({gid}): named in --walls although {rule}")
        else:
            c.reason = property_reason(w)
    for d in f.by_type("IfcDoor"):
        st = storey_of(d)
        if st is not None and str(st.GlobalId) in by_storey:
            by_storey[str(st.GlobalId)].doors.append(d)
    order = sorted(by_storey.values(), key=lambda s: (s.ref.elevation, s.ref.name, s.ref.global_id))
    if storey is not None:
        task_st = next((s for s in order if storey in (s.ref.name, s.ref.global_id)), None)
        if task_st is None:
            raise InitError(
                f"--storey {storey!r} is not a storey of the model",
                file=path,
                element=storey,
                fix="give one of: " + ", ".join(s.ref.name for s in order),
            )
    else:
        open_storeys = [s for s in order if any(not choices[str(w.GlobalId)].reason for w in s.walls)]
        with_doors = [s for s in open_storeys if s.doors]
        task_st = (with_doors or open_storeys or order)[0]
    for s in order:
        if s is not task_st:
            for w in s.walls:
                if not choices[str(w.GlobalId)].reason:
                    choices[str(w.GlobalId)].reason = (
                        f"on storey {s.ref.name}, not the task storey "
                        f"{task_st.ref.name} (choose it with --storey)"
                    )
    result = InitResult(path, Path(out), task, spec, task_st.ref.name, list(choices.values()))
    result.notes += overridden
    say(
        f"{path.name}: {len(choices)} walls, task storey {task_st.ref.name} "
        f"({task_st.ref.elevation:.2f} m); triangulating its elements"
    )
    # ---- geometry of the task storey -------------------------------------------------------------
    products = [e for e in f.by_type("IfcElement")
                if not e.is_a("IfcFeatureElement") and _same(storey_of(e), task_st.entity)]
    openings: dict[str, list[Any]] = {str(w.GlobalId): opening_products(w) for w in task_st.walls}
    extra = [o for os_ in openings.values() for o in os_ if o.is_a("IfcOpeningElement")]
    spaces = [s for s in f.by_type("IfcSpace") if _same(storey_of(s), task_st.entity)]
    bodies = [p for p in (*products, *extra, *spaces) if p.Representation]  # parts give the others theirs
    meshes = build_meshes(f, bodies, world_to_site=to_site).meshes
    space_meshes = [meshes.pop(str(s.GlobalId)) for s in spaces if str(s.GlobalId) in meshes]
    for w in task_st.walls:  # a wall exported as parts (layers): the parts are its body
        choices[str(w.GlobalId)].parts = body_from_parts(w, meshes)
    rooms = room_doors(
        space_meshes,
        [
            (
                meshes[str(d.GlobalId)],
                L.door_width(d, meshes, units.length_m),
                f"{d.Name or d.GlobalId} ({d.GlobalId})",
            )
            for d in task_st.doors
            if str(d.GlobalId) in meshes
        ],
        WALL_TOLERANCE_M,
    )
    need, robot = L.door_need()
    wall_meshes = [meshes[str(w.GlobalId)] for w in task_st.walls if str(w.GlobalId) in meshes]
    if not wall_meshes:
        result.notes.append(f"storey {task_st.ref.name} has no wall with geometry")
        for w in task_st.walls:
            c = choices[str(w.GlobalId)]
            c.reason = c.reason or "no body geometry (ifcopenshell could not triangulate it)"
        return result
    hull = footprint(_merge(wall_meshes))
    entrance = L.entrance_door(task_st.doors, meshes, hull)
    near = entrance[0] if entrance else (hull.centroid.x, hull.centroid.y)
    # ---- walls and panels --------------------------------------------------------------------------
    candidates = []
    for w in task_st.walls:
        c = choices[str(w.GlobalId)]
        if c.reason:
            continue
        mesh = meshes.get(c.global_id)
        if mesh is None:
            c.reason = "no body geometry (ifcopenshell could not triangulate it)"
            continue
        c.axis = wall_axis(mesh, task_st.ref.elevation)
        c.reason = axis_reason(c.axis)
        if not c.reason:
            mid = c.axis.point(c.axis.length / 2)
            candidates.append((round(math.hypot(mid[0] - near[0], mid[1] - near[1]), 4), c.global_id, c))
    candidates.sort(key=lambda t: (t[0], t[1]))
    chosen: list[tuple[float, WallChoice]] = []
    placed: list[PanelSpot] = []
    for dist, gid, c in candidates:
        if len(chosen) >= max_walls:
            c.reason = f"beyond --max-walls {max_walls} (farther from the entrance)"
            continue
        skip = {gid, *(g for _d, cc in chosen for g in [cc.global_id])}
        skip |= {str(o.GlobalId) for g in skip for o in openings.get(g, [])}
        obstacles = [m for k, m in meshes.items() if k not in skip]
        own = [meshes[str(o.GlobalId)] for o in openings.get(gid, []) if str(o.GlobalId) in meshes]
        panel_spots(c, own, obstacles, placed)
        if c.panels and (why := door_reason(c, rooms, need, SPACE_MARGIN_M, robot)):
            c.reason, c.panels = why, []
        if c.panels:
            chosen.append((dist, c))
            placed += c.panels
    if not chosen:
        return result
    # install order: farthest wall first, each from its end farthest from the entrance
    spots = []
    for _dist, c in sorted(chosen, key=lambda t: (-t[0], t[1].global_id)):
        ps = sorted(c.panels, key=lambda p: -math.hypot(p.x - near[0], p.y - near[1]))
        spots += [(p, task_st.entity) for p in ps]
    say(f"{len(chosen)} walls chosen, {len(spots)} panels; writing the IFC copy")
    tasks = len(f.by_type("IfcTask")) if f.by_type("IfcWorkSchedule") else 0
    if tasks:
        result.notes.append(
            f"the IFC has a work schedule ({tasks} IfcTask): schedule.csv is a scaffold beside it; to use "
            'the IFC\'s, set schedule = "ifc" in project.toml and add a robotized task that builds the panels'
        )
    frames = write_frames(f, spots, site=site_m, length_m=units.length_m, mass_kg=units.mass_kg)
    result.frames = frames
    result.entrance = entrance[2] if entrance else ""
    ground = next((s.ref.elevation for s in order if s.doors), task_st.ref.elevation)
    _write(
        result,
        f,
        path,
        Path(out),
        task_st,
        hull,
        entrance,
        min(ground, task_st.ref.elevation),
        seed,
        force,
        check_plan,
        say,
    )
    result.seconds = round(time.perf_counter() - t0, 2)
    return result


def _same(a: Any, b: Any) -> bool:
    return a is not None and b is not None and a.id() == b.id()


def _merge(meshes: Sequence[Any]) -> Any:
    import trimesh

    return trimesh.util.concatenate(list(meshes))


def _write(
    result: InitResult,
    f: Any,
    path: Path,
    out: Path,
    st: _Storey,
    hull: Polygon,
    entrance: tuple[tuple[float, float], tuple[float, float], str] | None,
    ground: float,
    seed: int,
    force: bool,
    check_plan: bool,
    say: Say,
) -> None:
    stem = _slug(path.stem)
    base = f"https://w3id.org/kbplanner/data/{stem}/"
    ifc_rel = f"model/{stem}_frames.ifc"
    frames = result.frames
    walls = [w.global_id for w in result.chosen]
    walls += [p for w in result.chosen for p in w.parts]  # built with their wall, after the frames
    doors = sorted(
        {
            str(o.GlobalId)
            for w in st.walls
            if str(w.GlobalId) in walls
            for o in opening_products(w)
            if o.is_a("IfcDoor")
        }
    )
    rows = site.schedule_rows(st.ref.name, walls, doors)
    sim_date = f"{rows[1]['start']}T07:00:00"
    upper = st.ref.elevation > ground + L.UPPER_STOREY_M  # the robot arrives there (lift): no outside storage
    plan = L.site_plan(hull, st.ref.elevation, entrance, ground)
    name = f"{path.stem}: robotized interior wall framing"
    texts = {
        "schedule.csv": site.schedule_csv(rows, result.specification),
        "site/workers.ttl": site.workers(base, plan),
        "site/jobsite.ttl": site.jobsite(base),
        "augmentation/grasp_points.ttl": site.grasp_points(base, frames),
        ".gitignore": ".kbplanner-cache/\n",
    }
    with output_options(force=force), run_directory(out) as stage:
        (stage / "model").mkdir()
        f.write(str(stage / ifc_rel))
        for rel, text in texts.items():
            p = stage / rel
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_text(text, encoding="utf-8")
        (stage / "site" / "site_layout.ttl").write_text(site.site_layout(base, plan), encoding="utf-8")
        (stage / "project.toml").write_text(
            L.project_toml(name, base, ifc_rel, seed, sim_date, path, {}), encoding="utf-8"
        )
        say(f"importing {ifc_rel} and building the map of {st.ref.name}")
        data = ProjectData.load(stage)
        quiet = logging.getLogger("kbplanner.world.build")
        level = quiet.level
        quiet.setLevel(logging.ERROR)  # the bare world has no storage yet: its warning is expected here
        try:
            world = world_of(data, task_id=site.FRAME_TASK)
        finally:
            quiet.setLevel(level)
        grid = storey_map(world).grid
        start = world.robot_start
        start_xy = (start.x, start.y) if start is not None else (plan.start[0], plan.start[1])
        if upper or grid.is_occupied(*start_xy) or not L.reaches_inside(grid, start_xy, hull):
            plan = L.inside_start(plan, grid, hull, st.ref.elevation, result.notes, arrival=upper)
            (stage / "site" / "site_layout.ttl").write_text(site.site_layout(base, plan), encoding="utf-8")
            start_xy = (plan.arrival or plan.start)[:2]
        stacks = math.ceil(len(frames) / MAX_STACK)
        panels_xy = [(r.spot.x, r.spot.y) for r in frames]
        centroid = (float(np.mean([p[0] for p in panels_xy])), float(np.mean([p[1] for p in panels_xy])))
        door_xy = entrance[0] if entrance else centroid
        proposals = {
            "storage-inside": ("frame storage inside the building, near the walls to frame", True, centroid),
            "storage-outside": ("frame storage outside the building, near the entrance", False, door_xy),
        }
        if upper:
            del proposals["storage-outside"]
            result.notes.append(
                f"{st.ref.name} is above the ground ({ground:.2f} m): the robot arrives there "
                "(kbp:robotArrival, e.g. by lift); no storage-outside scenario"
            )
        scenarios: dict[str, tuple[str, str]] = {}

        def listed(key: str, rel: str) -> None:
            label = dict((k, v[0]) for k, v in proposals.items())[key]
            scenarios[key] = (label[0].upper() + label[1:], rel)
            (stage / "project.toml").write_text(
                L.project_toml(name, base, ifc_rel, seed, sim_date, path, scenarios), encoding="utf-8"
            )

        for key, (label, inside, near) in proposals.items():
            say(f"placing the frame storages of {key}")
            place = Place(key, label, inside, near, None if inside or not entrance else door_xy)
            got = propose(
                stage, base, place, grid=grid, stacks=stacks, start=start_xy, panels=panels_xy, hull=hull,
                frames=frames, z=st.ref.elevation, seed=seed, check=check_plan, write_toml=listed, say=say,
                notes=result.notes,
            )
            if got is None:
                scenarios.pop(key, None)
                continue
            result.scenarios[key] = len(got.storages)
            if got.check is not None:
                result.checks[key] = got.check
        (stage / "project.toml").write_text(
            L.project_toml(name, base, ifc_rel, seed, sim_date, path, scenarios), encoding="utf-8"
        )
        result.files = sorted(
            str(p.relative_to(stage))
            for p in stage.rglob("*")
            if p.is_file() and ".kbplanner-cache" not in p.parts
        )
    result.written = True
