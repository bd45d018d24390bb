"""Robot selection (B3 preview): which robots of the knowledge base can do a robotized task, and why not.

``select_robots(model, kb, task_id)`` assesses every robot of the knowledge base against the task's
specification and the jobsite, and returns each robot, fit or not, with every reason:

* capabilities: every capability required by a skill of the task specification (``missing capability
  X required by skill Y``);
* payload: when the specification grasps elements (a skill requiring ``kbp:Gripping``), the arm
  payload against the heaviest element of the task (its GlobalId named);
* doors: the robot's width plus the jobsite door clearance on each side against the narrowest door it
  must pass. Which doors: for each element, the spaces whose bounds come within ``SPACE_MARGIN_M`` of
  its install location (a partition lies between two rooms; the robot may work from either); the robot
  uses the widest door of such a space (a door belongs to a space when their boxes overlap with the
  wall thickness allowed), and of the spaces next to an element the best one; the limiting door is
  the narrowest of these over all elements. When the storage of an element lies outside every space,
  the robot also passes the widest exterior door (``kbp:isExternal true``). Doors inside the route
  (a hallway between the entrance and a room) are left to the navigation planner (B5);
* site limits: the jobsite's allowable robot width, length, height and mass (A5).

Robot profiles missing a required figure raise :class:`~kbplanner.core.errors.KnowledgeBaseError` naming
the knowledge-base file and robot.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from rdflib import RDF, RDFS, Graph, Literal, URIRef
from rdflib.term import Node

from kbplanner.core.errors import KbplannerError, KnowledgeBaseError
from kbplanner.core.literals import literal_float as _f
from kbplanner.core.vocab import BOT, KBP
from kbplanner.knowledge.jobsite import JobsiteParameters, jobsite_parameters
from kbplanner.knowledge.knowledge_base import curie, label, select, source_of
from kbplanner.knowledge.task_specs import (
    ElementRef,
    RobotizedTask,
    TaskSpecification,
    robotized_tasks,
    task_specification,
)

log = logging.getLogger(__name__)

SPACE_MARGIN_M = 0.5
WALL_TOLERANCE_M = 0.4

CAPABILITY = "capability"
PAYLOAD = "payload"
DOOR = "door"
SITE = "site limit"


@dataclass(frozen=True)
class RobotProfile:
    """A robot of the knowledge base with its public-spec figures (m, kg, m/s)."""

    iri: URIRef
    label: str
    length_m: float
    width_m: float
    height_m: float
    base_mass_kg: float
    arm_mass_kg: float
    payload_kg: float | None
    base_payload_kg: float | None
    reach_m: float | None
    max_speed_mps: float
    urdf: str
    arm_model: str | None
    capabilities: tuple[URIRef, ...]
    sensors: tuple[str, ...]
    sources: tuple[str, ...]

    @property
    def mass_kg(self) -> float:
        """Total mass: base plus arm."""
        return self.base_mass_kg + self.arm_mass_kg


_REQUIRED = (("length", "kbp:footprintLength (m)"), ("width", "kbp:footprintWidth (m)"),
             ("height", "kbp:height (m)"), ("baseMass", "kbp:baseMass (kg)"),
             ("maxSpeed", "kbp:maxSpeed (m/s)"), ("urdf", "kbp:urdf (file name under sim/robots/)"))
_ARM_REQUIRED = (("armMass", "kbp:armMass (kg)"), ("payload", "kbp:payload (kg)"), ("reach", "kbp:reach (m)"),
                 ("armModel", "kbp:armModel (e.g. UR5)"))


def load_robots(kb: Graph) -> list[RobotProfile]:
    """Every robot profile of the knowledge base, sorted by label.

    Example:
        >>> from kbplanner.knowledge.knowledge_base import load_kb
        >>> [r.label for r in load_robots(load_kb())][:1]
        ['Clearpath Husky A200 + UR16e']
    """
    caps: dict[Node, list[URIRef]] = {}
    for r in select(kb, "robot_capabilities"):
        robot, cap = r["robot"], r["capability"]
        if isinstance(robot, URIRef) and isinstance(cap, URIRef):
            caps.setdefault(robot, []).append(cap)
    out = []
    for r in select(kb, "robots"):
        robot = r["robot"]
        if not isinstance(robot, URIRef):
            continue
        has_arm = KBP.Manipulation6DoF in caps.get(robot, [])
        needed = _REQUIRED + (_ARM_REQUIRED if has_arm else ())
        missing = [what for key, what in needed
                   if r[key] is None or (key not in ("urdf", "armModel") and _f(r[key]) is None)]
        if missing:
            raise KnowledgeBaseError(
                f"robot {curie(kb, robot)} lacks required figures: {', '.join(missing)}",
                file=source_of(kb, robot), element=curie(kb, robot),
                fix="add the figures from the vendor's datasheet (and cite it with dcterms:source)")
        out.append(RobotProfile(
            iri=robot, label=str(r["label"] or curie(kb, robot)),
            length_m=_f(r["length"]) or 0.0, width_m=_f(r["width"]) or 0.0, height_m=_f(r["height"]) or 0.0,
            base_mass_kg=_f(r["baseMass"]) or 0.0, arm_mass_kg=_f(r["armMass"]) or 0.0,
            payload_kg=_f(r["payload"]), base_payload_kg=_f(r["basePayload"]), reach_m=_f(r["reach"]),
            max_speed_mps=_f(r["maxSpeed"]) or 0.0, urdf=str(r["urdf"]),
            arm_model=str(r["armModel"]) if r["armModel"] is not None else None,
            capabilities=tuple(sorted(caps.get(robot, []), key=str)),
            sensors=tuple(sorted(str(s) for s in kb.objects(robot, KBP.sensor))),
            sources=tuple(sorted(str(s) for s in kb.objects(robot, URIRef("http://purl.org/dc/terms/source")))),
        ))
    return sorted(out, key=lambda p: (p.label, str(p.iri)))


@dataclass(frozen=True)
class Reason:
    """One check of a robot against the task: what, whether it passed, and why in words."""

    check: str
    ok: bool
    message: str


@dataclass(frozen=True)
class RobotAssessment:
    """A robot and every check; ``fit`` when all passed."""

    robot: RobotProfile
    checks: tuple[Reason, ...]

    @property
    def fit(self) -> bool:
        """True when the robot passes every check."""
        return all(c.ok for c in self.checks)

    @property
    def reasons(self) -> tuple[Reason, ...]:
        """The failed checks."""
        return tuple(c for c in self.checks if not c.ok)


@dataclass(frozen=True)
class DoorPassage:
    """A door the robot must pass and why."""

    door: ElementRef
    width_m: float
    why: str


@dataclass
class RobotSelection:
    """The outcome of :func:`select_robots` for one task."""

    task: RobotizedTask
    spec: TaskSpecification
    required: dict[URIRef, tuple[str, ...]]
    capability_labels: dict[URIRef, str]
    heaviest: tuple[float, ElementRef] | None
    door: DoorPassage | None
    jobsite: JobsiteParameters
    assessments: list[RobotAssessment]
    notes: list[str] = field(default_factory=list)

    @property
    def fit(self) -> list[RobotAssessment]:
        """The robots that pass every check."""
        return [a for a in self.assessments if a.fit]

    def text(self) -> str:
        """A readable report: what the task needs, then every robot with its reasons."""
        t, s = self.task, self.spec
        lines = [f"Task {t.task_id} '{t.label}' ({len(t.elements)} elements), specification {s.spec_id}"]
        caps = "; ".join(f"{self.capability_labels.get(c, str(c))} (for {', '.join(sk)})"
                         for c, sk in self.required.items())
        lines.append(f"  needs: {caps}")
        if self.heaviest is not None:
            m, e = self.heaviest
            lines.append(f"  heaviest element: {m:.2f} kg ({e.describe()})")
        if self.door is not None:
            lines.append(f"  narrowest door to pass: {self.door.width_m:.3f} m ({self.door.door.describe()}; "
                         f"{self.door.why})")
        lines.extend(f"  note: {n}" for n in self.notes)
        for a in self.assessments:
            r = a.robot
            verdict = "FIT" if a.fit else "NOT FIT"
            payload = f", payload {r.payload_kg:g} kg" if r.payload_kg else ""
            lines.append(f"- {r.label}: {verdict}  ({r.length_m:.3f} x {r.width_m:.3f} x {r.height_m:.2f} m, "
                         f"{r.mass_kg:.1f} kg{payload})")
            for c in a.checks:
                lines.append(f"    [{'ok' if c.ok else 'X '}] {c.check}: {c.message}")
        return "\n".join(lines) + "\n"

    def rows(self) -> list[tuple[str, str, str, str]]:
        """One row per (robot, check): robot, fit, check, message (failed checks first)."""
        out = []
        for a in self.assessments:
            for c in sorted(a.checks, key=lambda c: c.ok):
                out.append((a.robot.label, "fit" if a.fit else "not fit", c.check,
                            ("ok: " if c.ok else "") + c.message))
        return out


@dataclass(frozen=True)
class _Box:
    x0: float
    y0: float
    z0: float
    x1: float
    y1: float
    z1: float

    def near(self, x: float, y: float, z: float, margin: float) -> bool:
        return (self.x0 - margin <= x <= self.x1 + margin and self.y0 - margin <= y <= self.y1 + margin
                and self.z0 - margin <= z <= self.z1 + margin)

    def overlaps(self, o: _Box, tol: float) -> bool:
        return (self.x0 - tol <= o.x1 and o.x0 <= self.x1 + tol and self.y0 - tol <= o.y1
                and o.y0 <= self.y1 + tol and self.z0 - tol <= o.z1 and o.z0 <= self.z1 + tol)


def _box(model: Graph, node: Node) -> _Box | None:
    b = model.value(node, KBP.bounds)
    if b is None:
        return None
    vals = [_f(model.value(b, p)) for p in (KBP.minX, KBP.minY, KBP.minZ, KBP.maxX, KBP.maxY, KBP.maxZ)]
    if any(v is None for v in vals):
        return None
    x0, y0, z0, x1, y1, z1 = (float(v) for v in vals if v is not None)
    return _Box(x0, y0, z0, x1, y1, z1)


def _xyz(model: Graph, pose: Node | None) -> tuple[float, float, float] | None:
    if pose is None:
        return None
    vals = [_f(model.value(pose, p)) for p in (KBP.x, KBP.y, KBP.z)]
    if any(v is None for v in vals):
        return None
    return (float(vals[0] or 0.0), float(vals[1] or 0.0), float(vals[2] or 0.0))


def _ref(model: Graph, node: URIRef) -> ElementRef:
    return ElementRef(iri=node, global_id=str(model.value(node, KBP.globalId) or curie(model, node)),
                      label=str(model.value(node, RDFS.label) or ""))


def _doors(model: Graph, task: RobotizedTask, notes: list[str]) -> DoorPassage | None:
    spaces = {s: b for s in sorted(model.subjects(RDF.type, BOT.Space), key=str)
              if (b := _box(model, s)) is not None}
    doors: dict[URIRef, tuple[float, _Box]] = {}
    for d in sorted(model.subjects(RDF.type, KBP.Door), key=str):
        w, b = _f(model.value(d, KBP.overallWidth)), _box(model, d)
        if isinstance(d, URIRef) and w is not None and b is not None:
            doors[d] = (w, b)
    if not spaces or not doors:
        notes.append("door check skipped: the model has no spaces with bounds or no doors with width "
                     "and bounds")
        return None
    space_door: dict[Node, tuple[float, URIRef]] = {}
    for s, sb in spaces.items():
        best = max(((w, d) for d, (w, db) in doors.items() if sb.overlaps(db, WALL_TOLERANCE_M)),
                   default=None, key=lambda wd: (wd[0], str(wd[1])))
        if best is not None:
            space_door[s] = best
    limiting: DoorPassage | None = None
    unplaced = 0
    for el in task.elements:
        eb = _box(model, el.iri)
        loc = (((eb.x0 + eb.x1) / 2, (eb.y0 + eb.y1) / 2, eb.z0) if eb is not None
               else _xyz(model, model.value(el.iri, KBP.installedPose)))
        if loc is None:
            unplaced += 1
            continue
        near = [space_door[s] for s, sb in spaces.items()
                if s in space_door and sb.near(*loc, SPACE_MARGIN_M)]
        if not near:
            continue
        w, d = max(near, key=lambda wd: (wd[0], str(wd[1])))
        if limiting is None or w < limiting.width_m:
            limiting = DoorPassage(door=_ref(model, d), width_m=w,
                                   why=f"the widest door into the room of {el.describe()}")
    if unplaced:
        notes.append(f"{unplaced} element(s) have neither bounds nor an installed pose: not used for the "
                     "door check")
    storages = {st for el in task.elements for st in model.objects(el.iri, KBP.storedIn)}
    outside = False
    for st in sorted(storages, key=str):
        loc = _xyz(model, model.value(st, KBP.installedPose))
        if loc is not None and not any(sb.near(*loc, 0.0) for sb in spaces.values()):
            outside = True
    if outside:
        ext = [(w, d) for d, (w, _) in doors.items() if model.value(d, KBP.isExternal) == Literal(True)]
        if ext:
            w, d = max(ext, key=lambda wd: (wd[0], str(wd[1])))
            if limiting is None or w < limiting.width_m:
                limiting = DoorPassage(door=_ref(model, d), width_m=w,
                                       why="the widest exterior door, on the way from the storage outside")
        else:
            notes.append("the storage lies outside the building but no door is marked kbp:isExternal true")
    return limiting


def select_robots(model: Graph, kb: Graph, task_id: str, *, scenario: str | None = None) -> RobotSelection:
    """B3: assess every robot of the knowledge base for the robotized task ``task_id``.

    Raises :class:`~kbplanner.core.errors.KbplannerError` when the task is not robotized or its
    specification is unknown; robots that do not fit are results, with reasons.
    """
    tasks = robotized_tasks(model, task_id)
    if not tasks:
        known = ", ".join(t.task_id for t in robotized_tasks(model)) or "none"
        raise KbplannerError(f"no robotized task with id {task_id!r}", element=task_id,
                             fix=f"choose one of the robotized tasks: {known}")
    task = tasks[0]
    if task.spec_id is None:
        raise KnowledgeBaseError(f"robotized task {task.task_id} has no task specification id",
                                 element=task.task_id, fix="set kbp:taskSpecificationId in the schedule")
    spec = task_specification(kb, task.spec_id, task=task.task_id)
    required: dict[URIRef, list[str]] = {}
    for skill in spec.skills:
        for c in skill.capabilities:
            required.setdefault(c, []).append(skill.skill_id)
    cap_labels = {c: label(kb, c) for c in required}
    grasps = KBP.Gripping in required
    notes: list[str] = []
    masses = [(m, e) for e in task.elements if (m := _f(model.value(e.iri, KBP.mass))) is not None]
    heaviest = max(masses, key=lambda me: (me[0], me[1].global_id)) if masses else None
    if grasps and len(masses) < len(task.elements):
        notes.append(f"{len(task.elements) - len(masses)} element(s) have no kbp:mass: the payload check "
                     "covers the others only")
    door = _doors(model, task, notes)
    js = jobsite_parameters(model, scenario)
    assessments = []
    for robot in load_robots(kb):
        checks: list[Reason] = []
        for cap, skills in required.items():
            ok = cap in robot.capabilities
            what = cap_labels[cap]
            checks.append(Reason(CAPABILITY, ok, (f"has {what}" if ok else f"missing capability {what} "
                                                  f"({curie(kb, cap)})") + f", required by skill "
                                 f"{', '.join(skills)}"))
        if grasps and heaviest is not None:
            m, e = heaviest
            if robot.payload_kg is None:
                checks.append(Reason(PAYLOAD, False, "no arm payload to lift the heaviest element "
                                     f"{m:.2f} kg ({e.describe()})"))
            else:
                ok = robot.payload_kg >= m
                checks.append(Reason(PAYLOAD, ok, f"payload {robot.payload_kg:g} kg "
                                     + ("covers" if ok else "below")
                                     + f" the heaviest element {m:.2f} kg ({e.describe()})"))
        if door is not None:
            need = robot.width_m + 2 * js.door_clearance_m
            ok = need <= door.width_m
            clear = f" + 2 x {js.door_clearance_m:g} m clearance" if js.door_clearance_m else ""
            checks.append(Reason(DOOR, ok, f"width {robot.width_m:.3f} m{clear} "
                                 + ("fits" if ok else "is wider than")
                                 + f" the narrowest door it must pass, {door.width_m:.3f} m "
                                 f"({door.door.describe()})"))
        for value, limit, what, unit in (
                (robot.width_m, js.max_robot_width_m, "width", "m"),
                (robot.length_m, js.max_robot_length_m, "length", "m"),
                (robot.height_m, js.max_robot_height_m, "height", "m"),
                (robot.mass_kg, js.max_robot_mass_kg, "mass", "kg")):
            if limit is None:
                continue
            ok = value <= limit
            checks.append(Reason(SITE, ok, f"{what} {value:g} {unit} " + ("within" if ok else "over")
                                 + f" the site's allowable {what} {limit:g} {unit}"))
        assessments.append(RobotAssessment(robot=robot, checks=tuple(checks)))
    assessments.sort(key=lambda a: (not a.fit, a.robot.label))
    log.info("%d of %d robots fit task %s", sum(a.fit for a in assessments), len(assessments), task_id)
    return RobotSelection(task=task, spec=spec, required={c: tuple(s) for c, s in sorted(required.items())},
                          capability_labels=cap_labels, heaviest=heaviest, door=door, jobsite=js,
                          assessments=assessments, notes=notes)
