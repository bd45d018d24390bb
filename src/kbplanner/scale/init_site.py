"""``kbplanner init`` (issue 10), step 3: the site, schedule and scenario files of an initialised project.

Plain Turtle and CSV the user can edit, written with the generator's helpers
(:mod:`kbplanner.scale.building_site`): the site layout (extent, robot start outside the entrance door,
a robot arrival on an upper task storey, site office, the carpenters' lumber storage and the entrance
area), two workers whose routes follow the tasks in progress at the framing date (a carpenter between
the lumber storage and the entrance, the supervisor's round), the jobsite parameters, the work sequence
and grasp points of the panels, a schedule scaffold (``schedule.csv``) and one scenario per storage
proposal (frame storages with pickup locations, ``kbp:storedIn`` / ``kbp:stackIndex``).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import date, timedelta
from urllib.parse import quote

from kbplanner.scale.building_schedule import SCHEDULE_COLUMNS
from kbplanner.scale.building_site import (
    _PREFIXES,
    Route,
    _jobsite_ttl,
    _num,
    _pose_ttl,
    _site_object,
    _workers_ttl,
)
from kbplanner.scale.init_ifc import FrameRecord

START_DATE = date(2024, 3, 4)  # a Monday: the scaffold's week 0
FRAME_TASK = "T-FRAME"
STORAGE_SIZE = (2.6, 0.8, 0.1)
DOOR_CLEARANCE = 0.1  # m free on each side of the robot in a door (jobsite.ttl)


@dataclass(frozen=True)
class PlacedObject:
    """A site object the proposal put somewhere (site frame, metres, radians)."""

    key: str
    cls: str
    label: str
    obstructs: bool
    size: tuple[float, float, float]
    x: float
    y: float
    z: float
    yaw: float


@dataclass(frozen=True)
class Storage:
    """A frame storage, its pickup location and the panels stacked on it (bottom first)."""

    key: str
    label: str
    x: float
    y: float
    z: float
    yaw: float
    pickup: tuple[float, float, float, float]  # x, y, z, yaw (facing the stack)
    panels: tuple[FrameRecord, ...]


@dataclass(frozen=True)
class SitePlan:
    """Where the robot starts (and arrives on the task storey) and the site objects."""

    extent: tuple[float, float, float, float, float, float]
    start: tuple[float, float, float, float]
    start_note: str
    arrival: tuple[float, float, float, float] | None
    objects: tuple[PlacedObject, ...]


def element(base: str, gid: str) -> str:
    return f"<{base}element/{quote(gid, safe='')}>"


def site_layout(base: str, plan: SitePlan) -> str:
    x0, y0, z0, x1, y1, z1 = plan.extent
    sx, sy, sz, syaw = plan.start
    out = [
        _PREFIXES,
        "# Site layout proposed by `kbplanner init` (site frame = the IFC's site frame, metres, radians).",
        f"# {plan.start_note}",
        "# Edit freely: move the objects, add no-go zones (kbp:NoGoZone), then `kbplanner validate`.",
        "",
        f"<{base}site/layout> a kbp:SiteLayout ;",
        '    rdfs:label "Site layout (kbplanner init)" ;',
        f"    kbp:siteExtent <{base}site/layout-extent> ;",
    ]
    if plan.arrival is not None:
        out.append(f"    kbp:robotArrival <{base}pose/robot-arrival> ;")
    out += [
        f"    kbp:robotStart <{base}pose/robot-start> .",
        f"<{base}site/layout-extent> a kbp:Box ;",
        '    rdfs:label "site boundary (building + 15 m)" ;',
        f"    kbp:minX {_num(x0)} ; kbp:minY {_num(y0)} ; kbp:minZ {_num(z0)} ;",
        f"    kbp:maxX {_num(x1)} ; kbp:maxY {_num(y1)} ; kbp:maxZ {_num(z1)} .",
        *_pose_ttl(f"{base}pose/robot-start", sx, sy, sz, syaw, "robot start"),
    ]
    if plan.arrival is not None:
        ax, ay, az, ayaw = plan.arrival
        out += _pose_ttl(
            f"{base}pose/robot-arrival",
            ax,
            ay,
            az,
            ayaw,
            "robot arrival on the task storey (e.g. the lift landing): move it where the robot is set down",
        )
    out.append("")
    for o in plan.objects:
        lines = _site_object(base, o.key, o.cls, o.label, o.obstructs, o.size, o.x, o.y, o.yaw)
        if o.z:
            lines = [ln.replace("kbp:z 0.0e0", f"kbp:z {_num(o.z)}") for ln in lines]
        out += lines
    return "\n".join(out)


def workers(base: str, plan: SitePlan) -> str:
    keys = {o.key for o in plan.objects}
    routes: list[Route] = [
        ("carpenter-1", "Carpenter 1", "carpenter", 1.2, [("lumber-storage", 30.0), ("entrance-area", 60.0)]),
        (
            "supervisor",
            "Site supervisor",
            "supervisor",
            1.0,
            [("office", 120.0), ("entrance-area", 30.0), ("lumber-storage", 20.0)],
        ),
    ]
    out = [
        _PREFIXES,
        "# Workers proposed by `kbplanner init`, from the tasks in progress at the framing date: the",
        "# carpenters of the partitions carry lumber from their storage to the entrance (across the",
        "# robot's way in), the supervisor makes a round. Speeds m/s, dwell times s.",
        "",
    ]
    kept = [(key, label, role, speed, [(loc, dwell) for loc, dwell in stops if loc in keys])
            for key, label, role, speed, stops in routes]
    out += _workers_ttl(base, [r for r in kept if len(r[4]) >= 2])
    return "\n".join(out)


def jobsite(base: str) -> str:
    return _jobsite_ttl(
        base,
        ["# Jobsite parameters (A5) proposed by `kbplanner init`, as in the case study: a robot",
         "# passes 0.9 m doors with 0.1 m free on each side; speeds m/s, distances m, mass kg."],
        "Jobsite parameters (kbplanner init)",
        DOOR_CLEARANCE,
    )


def grasp_points(base: str, frames: Sequence[FrameRecord]) -> str:
    out = [
        _PREFIXES,
        "# Augmentation (MM-G-1 'pick frame'): a grasp point per panel, its centre of mass in the panel's",
        "# own frame (origin at the middle of the bottom plate on the wall axis, x along it). Also in the",
        "# IFC copy's Kbplanner_StudFramePanel.GraspPointX/Y/Z.",
        "",
    ]
    for r in frames:
        x, y, z = r.centre_of_mass_local
        pose = f"{base}pose/{r.panel_id}-grasp"
        out += [
            f"{element(base, r.global_id)} kbp:graspPoint <{pose}> .",
            *_pose_ttl(pose, x, y, z, 0.0, f"grasp point of {r.panel_id} (local, centre of mass)"),
            "",
        ]
    return "\n".join(out)


def scenario(base: str, name: str, label: str, storages: Sequence[Storage],
             sequence: Sequence[str] | None = None, note: str = "") -> str:
    """The scenario's Turtle: storages, pickup locations, stacks (``Storage.panels``: the first installed
    on top) and the work sequence: ``sequence`` (GlobalIds, first installed first), by default storage by
    storage in stack order; an empty ``sequence`` writes none (B4 then orders, as init's check does).
    ``note``: comment lines on how the proposal was checked."""
    out = [
        _PREFIXES,
        f"# Scenario '{name}' proposed by `kbplanner init`: {label}. Frame storages (bearers "
        f"{STORAGE_SIZE[0]} x {STORAGE_SIZE[1]} m)",
        "# with the robot's pickup location beside each, checked free and reachable from the robot start on",
        "# the task storey's map; kbp:stackIndex 0 = bottom (the first installed lies on top).",
        "",
        f"<{base}scenario/{name}> a kbp:Scenario ;",
        f'    kbp:scenarioName "{name}" ;',
        f'    rdfs:label "{label}" .',
        "",
    ]
    if note:
        out += [f"# {line}" for line in note.splitlines()] + [""]
    if sequence is None:
        sequence = [r.global_id for s in storages for r in s.panels]
        lines = [
            "# Work sequence of " + FRAME_TASK + ": stack by stack"
            " (the walls farthest from the entrance first),",
            "# in a stack the panel farthest from its pickup first (the first installed lies on top).",
        ]
    else:
        lines = [
            "# Work sequence of " + FRAME_TASK + ": the order `kbplanner plan` (B4)"
            " found for these stacks; in a",
            "# stack the first installed lies on top.",
        ]
    labels = {r.global_id: r.panel_id for s in storages for r in s.panels}
    if sequence:
        lines += [
            f"{element(base, gid)} kbp:workSequence {i + 1} .  # {labels.get(gid, gid)}"
            for i, gid in enumerate(sequence)
        ]
    else:
        lines = []
    for s in storages:
        iri, pose, pickup = f"{base}site/{s.key}", f"{base}site/{s.key}-pose", f"{base}pose/{s.key}-pickup"
        out += [
            f"<{iri}> a kbp:MaterialStorage ;",
            f'    rdfs:label "{s.label}" ;',
            "    kbp:obstructs true ;",
            f"    kbp:sizeX {_num(STORAGE_SIZE[0])} ; kbp:sizeY {_num(STORAGE_SIZE[1])} ; "
            f"kbp:sizeZ {_num(STORAGE_SIZE[2])} ;",
            f"    kbp:installedPose <{pose}> ;",
            f"    kbp:pickupLocation <{pickup}> .",
            *_pose_ttl(pose, s.x, s.y, s.z, s.yaw),
            *_pose_ttl(pickup, *s.pickup, "robot pickup location beside the stack, facing it"),
        ]
        n = len(s.panels)
        for i, r in enumerate(s.panels):
            out.append(
                f"{element(base, r.global_id)} kbp:storedIn <{iri}> ; kbp:stackIndex {n - 1 - i} .  "
                f"# {r.panel_id}"
            )
        out.append("")
    return "\n".join([*out, *lines, ""])


def schedule_rows(storey: str, walls: Sequence[str], doors: Sequence[str]) -> list[dict[str, str]]:
    """The scaffold: mobilisation, shell (all that no later task builds counts as built), framing
    (robotized), the chosen partitions (board and finish) and their doors."""

    def d(week: int, day: int = 0) -> str:
        return (START_DATE + timedelta(days=7 * week + day)).isoformat()

    rows = [
        ("T-MOB", "Site mobilisation", d(0), d(0, 4), "", "", "false", ""),
        (
            FRAME_TASK,
            f"Frame interior wood partitions {storey}",
            d(1),
            d(2, 4),
            "T-MOB",
            f"class=IfcMember;storey={storey};name=Stud frame panel*",
            "true",
            "I-W-F-#1",
        ),
        (
            "T-PART",
            f"Interior partitions {storey} (board, tape and finish)",
            d(3),
            d(4, 4),
            FRAME_TASK,
            "|".join(walls),
            "false",
            "",
        ),
    ]
    if doors:
        rows.append(
            (
                "T-DOOR",
                f"Doors in the partitions {storey}",
                d(5),
                d(5, 4),
                "T-PART",
                "|".join(doors),
                "false",
                "",
            )
        )
    return [dict(zip(SCHEDULE_COLUMNS, r, strict=True)) for r in rows]


def schedule_csv(rows: Sequence[dict[str, str]], spec: str) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({**r, "task_specification": spec if r["robotized"] == "true" else ""})
    return buf.getvalue()


def yaw_facing(frm: tuple[float, float], to: tuple[float, float]) -> float:
    return round(math.atan2(to[1] - frm[1], to[0] - frm[0]), 9)
