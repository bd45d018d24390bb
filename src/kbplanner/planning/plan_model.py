"""The action-level plan (B1-B4 produce it, B5 executes it): typed, serialisable to JSON.

A :class:`Plan` is the robotized task broken into skill calls: for each element of the task, in a
recorded order, each action of the task specification becomes a :class:`SkillCall` with its inputs
(fetched by SPARQL from the same bindings that produced the requirements), its effective parameters
(skill defaults < action settings < jobsite parameters), and what B4 chose (base pose, arm poses).
Infeasible steps stay in the plan with ``feasible=False`` and a reason; the executor records them
as failures and goes on with the next element.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from typing import Any

from kbplanner.core.outputs import json_text

JsonValue = Any


@dataclass(frozen=True)
class Pose6:
    """x, y, z (m), roll, pitch, yaw (rad) in the site frame (or an element's local frame)."""

    x: float
    y: float
    z: float
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0

    def as_list(self) -> list[float]:
        """[x, y, z, roll, pitch, yaw]."""
        return [self.x, self.y, self.z, self.roll, self.pitch, self.yaw]

    @classmethod
    def from_list(cls, v: list[float] | tuple[float, ...]) -> Pose6:
        """From [x, y, z, roll, pitch, yaw]."""
        return cls(*(float(a) for a in v))


@dataclass(frozen=True)
class Pose2:
    """A base pose on the floor: x, y (m), yaw (rad)."""

    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class ElementInfo:
    """What the executor needs of an element of the task: identity, geometry, mass, where it is."""

    iri: str
    global_id: str
    label: str
    mass_kg: float | None
    size_m: tuple[float, float, float]  # extents along the element's local x, y, z
    installed_pose: Pose6
    storage_pose: Pose6 | None  # where it lies at the start (None: already in place)
    mesh_file: str | None
    work_sequence: int | None = None  # kbp:workSequence (an explicit order B4 does not change)


@dataclass
class SkillCall:
    """One action of the task specification applied to one element."""

    step: int
    element: str  # element IRI
    action: str  # action IRI
    action_label: str
    action_order: int
    skill: str  # skill IRI
    skill_id: str
    skill_kind: str  # IRI of the kbp:SkillKind; the executor's skill table is keyed by it
    inputs: dict[str, JsonValue] = field(default_factory=dict)  # input name -> value (poses as 6-lists)
    parameters: dict[str, JsonValue] = field(default_factory=dict)  # parameter kind local name -> value
    base_pose: Pose2 | None = None  # where the base stands for a manipulation (B4)
    arm_poses: dict[str, list[float]] = field(default_factory=dict)  # initial / intermediate / final ...
    notes: list[str] = field(default_factory=list)
    feasible: bool = True
    reason: str | None = None
    roles: dict[str, str] = field(default_factory=dict)  # kbp:InputRole local name -> input name

    def by_role(self, role: str) -> JsonValue:
        """The value of the input with role ``role`` (a local name such as ``DestinationRole``), or None.

        The executor and B4 read inputs only this way: the input's name is a label.

        Example:
            >>> c = SkillCall(1, "e", "a", "go", 1, "s", "NV-1", "k", inputs={"goal": [1, 2, 0, 0, 0, 0]},
            ...               roles={"DestinationRole": "goal"})
            >>> c.by_role("DestinationRole")
            [1, 2, 0, 0, 0, 0]
        """
        name = self.roles.get(role)
        return self.inputs.get(name) if name is not None else None


@dataclass
class Plan:
    """The plan of one robotized task for one robot in one scenario."""

    project: str
    scenario: str | None
    task_id: str
    task_label: str
    spec_id: str
    robot_id: str
    robot_label: str
    robot_urdf: str
    order_rule: str
    elements: list[ElementInfo] = field(default_factory=list)
    steps: list[SkillCall] = field(default_factory=list)
    robot_start: Pose2 | None = None
    storey_elevation_m: float = 0.0
    selection: list[dict[str, JsonValue]] = field(default_factory=list)  # every robot, fit or not, reasons
    notes: list[str] = field(default_factory=list)
    task_iri: str = ""  # the construction task (plan.ttl links to it)
    spec_iri: str = ""  # the task specification of the knowledge base

    def keep_first(self, n: int) -> None:
        """Keep only the first ``n`` elements of the plan's order and their steps (a quick look)."""
        keep = {e.iri for e in self.elements[:n]}
        self.elements = [e for e in self.elements if e.iri in keep]
        self.steps = [s for s in self.steps if s.element in keep]

    def steps_for(self, element_iri: str) -> list[SkillCall]:
        """The skill calls of one element, in order."""
        return [s for s in self.steps if s.element == element_iri]

    def element(self, iri: str) -> ElementInfo:
        """The element with this IRI."""
        return next(e for e in self.elements if e.iri == iri)

    @property
    def feasible(self) -> bool:
        """True when every step is feasible."""
        return all(s.feasible for s in self.steps)

    def to_json(self) -> str:
        """Stable JSON text (sorted keys)."""
        return json_text(asdict(self), name="plan.json") + "\n"

    @classmethod
    def from_json(cls, text: str) -> Plan:
        """Read a plan written by :meth:`to_json`."""
        d = json.loads(text)

        def pose6(v: dict[str, float] | None) -> Pose6 | None:
            return Pose6(**v) if v else None

        def pose2(v: dict[str, float] | None) -> Pose2 | None:
            return Pose2(**v) if v else None

        elements = [
            ElementInfo(
                iri=e["iri"], global_id=e["global_id"], label=e["label"], mass_kg=e["mass_kg"],
                size_m=tuple(e["size_m"]), installed_pose=Pose6(**e["installed_pose"]),
                storage_pose=pose6(e["storage_pose"]), mesh_file=e["mesh_file"],
                work_sequence=e.get("work_sequence"),
            )
            for e in d.pop("elements")
        ]
        steps = []
        for s in d.pop("steps"):
            s["base_pose"] = pose2(s.get("base_pose"))
            steps.append(SkillCall(**s))
        d["robot_start"] = pose2(d.get("robot_start"))
        return cls(elements=elements, steps=steps, **d)
