"""Test buildings (scale, issue 6), step 5: the site, jobsite and scenario files of the generated building.

Turtle for the project directory: the site layout (extent, robot start and arrival poses on upper
floors, office, the carpenters' lumber storage, entrance area, generator), two workers with routes,
the jobsite parameters (A5), the work sequence of the framing tasks, and the scenario
``storage-in-units``: two frame storages per unit with their pickup locations, ``kbp:storedIn`` /
``kbp:stackIndex`` of every panel, and a grasp point per panel (its centre of mass, local).
"""

from __future__ import annotations

import math
from urllib.parse import quote

from kbplanner.scale.building_geometry import Builder
from kbplanner.scale.building_plan import (
    CORRIDOR_W,
    MAX_STACK,
    PICKUP_STANDOFF,
    SCENARIO,
    STORAGE_FROM_WEST,
    STORAGE_SIZE,
    STORAGE_YS,
    STOREY_HEIGHT,
    UNIT_D,
    UNIT_W,
    GeneratorError,
    Panel,
)


def _num(v: float) -> str:
    """A Turtle xsd:double literal, stable: ``1.5e0``."""
    r = repr(round(float(v), 6) + 0.0)
    return r if "e" in r else f"{r}e0"


_PREFIXES = """@prefix kbp:  <https://w3id.org/kbplanner/ontology#> .
@prefix kb:   <https://w3id.org/kbplanner/kb#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix xsd:  <http://www.w3.org/2001/XMLSchema#> .
"""


def _pose_ttl(iri: str, x: float, y: float, z: float, yaw: float, label: str | None = None) -> list[str]:
    out = [f"<{iri}> a kbp:Pose ;"]
    if label:
        out.append(f'    rdfs:label "{label}" ;')
    out += [
        f"    kbp:x {_num(x)} ; kbp:y {_num(y)} ; kbp:z {_num(z)} ;",
        f"    kbp:roll 0.0e0 ; kbp:pitch 0.0e0 ; kbp:yaw {_num(yaw)} .",
    ]
    return out


Route = tuple[str, str, str, float, list[tuple[str, float]]]  # key, label, role, speed m/s, (stop, dwell s)


def _workers_ttl(base: str, routes: list[Route]) -> list[str]:
    """Turtle of workers walking their routes (key, label, role, speed, stops with dwell times)."""
    out: list[str] = []
    for key, label, role, speed, stops in routes:
        iri = f"{base}worker/{key}"
        stop_iris = [f"<{iri}-stop-{i + 1}>" for i in range(len(stops))]
        out += [
            f"<{iri}> a kbp:Worker ;",
            f'    rdfs:label "{label}" ;',
            f'    kbp:role "{role}" ;',
            f"    kbp:walkingSpeed {_num(speed)} ;",
            f"    kbp:routeStop {' , '.join(stop_iris)} .",
        ]
        for i, (loc, dwell) in enumerate(stops):
            out += [
                f"{stop_iris[i]} a kbp:RouteStop ;",
                f"    kbp:order {i + 1} ; kbp:location <{base}site/{loc}> ; kbp:dwellTime {_num(dwell)} .",
            ]
        out.append("")
    return out


def _jobsite_ttl(base: str, comment: list[str], label: str, door_clearance: float) -> str:
    """Turtle of the jobsite parameters (A5) as in the case study: a robot passes 0.9 m doors with
    ``door_clearance`` m free on each side; ``comment`` lines open the file."""
    return "\n".join(
        [
            _PREFIXES,
            *comment,
            "",
            f"<{base}jobsite/params> a kbp:JobsiteParameters ;",
            f'    rdfs:label "{label}" ;',
            "    kbp:maxRobotWidth 0.9e0 ; kbp:maxRobotLength 1.4e0 ; kbp:maxRobotHeight 1.9e0 ;",
            "    kbp:maxRobotMass 150.0e0 ; kbp:maxSpeed 1.0e0 ; kbp:safetyStopDistance 0.5e0 ;",
            f"    kbp:doorClearance {_num(door_clearance)} ;",
            f"    kbp:hasActionLimit <{base}jobsite/nv-1> , <{base}jobsite/nv-2> .",
            f'<{base}jobsite/nv-1> a kbp:ActionLimit ; rdfs:label "unloaded navigation" ;',
            "    kbp:appliesTo kb:NV-1 ; kbp:minSpeed 0.1e0 ; kbp:maxSpeed 0.8e0 .",
            f'<{base}jobsite/nv-2> a kbp:ActionLimit ; rdfs:label "navigation carrying a frame" ;',
            "    kbp:appliesTo kb:NV-2 ; kbp:minSpeed 0.05e0 ; kbp:maxSpeed 0.3e0 ;",
            "    kbp:safetyStopDistance 1.0e0 .",
            "",
        ]
    )


def _site_object(
    base: str,
    key: str,
    cls: str,
    label: str,
    obstructs: bool,
    size: tuple[float, float, float],
    x: float,
    y: float,
    yaw: float = 0.0,
) -> list[str]:
    iri, pose = f"{base}site/{key}", f"{base}site/{key}-pose"
    return [
        f"<{iri}> a kbp:{cls} ;",
        f'    rdfs:label "{label}" ;',
        f"    kbp:obstructs {'true' if obstructs else 'false'} ;",
        f"    kbp:sizeX {_num(size[0])} ; kbp:sizeY {_num(size[1])} ; kbp:sizeZ {_num(size[2])} ;",
        f"    kbp:installedPose <{pose}> .",
        *_pose_ttl(pose, x, y, 0.0, yaw),
        "",
    ]


class SiteFiles:
    """The Turtle files of a generated building's site and scenario (``base``: the project's base IRI)."""

    def __init__(self, builder: Builder, base: str) -> None:
        self.b = builder
        self.base = base
        self.n, self.m = builder.n, builder.m

    def element(self, gid: str) -> str:
        return f"<{self.base}element/{quote(gid, safe='')}>"

    def site_layout(self) -> str:
        b, base = self.b, self.base
        L, Dc = b.length, b.depth
        entrance_y = UNIT_D + CORRIDOR_W / 2
        out = [
            _PREFIXES,
            "# Site layout of the generated building (site frame = IFC world frame, metres, radians).",
            "# The entrance door is in the west facade at the corridor; the robot starts 5 m west of it.",
            "# There is no frame storage here: the scenario adds one per unit (a modeling requirement).",
            "",
            f"<{base}site/layout> a kbp:SiteLayout ;",
            '    rdfs:label "Generated site layout" ;',
            f"    kbp:siteExtent <{base}site/layout-extent> ;",
            *(f"    kbp:robotArrival <{base}pose/robot-arrival-L{k + 1:02d}> ;" for k in range(1, self.n)),
            f"    kbp:robotStart <{base}pose/robot-start> .",
            f"<{base}site/layout-extent> a kbp:Box ;",
            '    rdfs:label "site boundary (building + 15 m)" ;',
            f"    kbp:minX {_num(-15.0)} ; kbp:minY {_num(-15.0)} ; kbp:minZ {_num(-2.0)} ;",
            f"    kbp:maxX {_num(L + 15.0)} ; kbp:maxY {_num(Dc + 15.0)} ; "
            f"kbp:maxZ {_num((self.n + 1) * STOREY_HEIGHT + 2.0)} .",
            *_pose_ttl(
                f"{base}pose/robot-start",
                -5.0,
                entrance_y,
                0.0,
                0.0,
                "robot start: 5 m west of the entrance, facing it",
            ),
        ]
        # Upper floors: the robot comes up in the lift and is set down in the lobby in front of the lift
        # door, facing west along the corridor.
        for k in range(1, self.n):
            out += _pose_ttl(f"{base}pose/robot-arrival-L{k + 1:02d}", L - 2.0, 4.5, k * STOREY_HEIGHT,
                             math.pi, f"robot arrival on Level {k + 1}: the lift lobby, facing the corridor")
        out.append("")
        out += _site_object(
            base, "office", "SiteOffice", "Site office", True, (6.0, 2.5, 2.7), -9.0, Dc + 9.0
        )
        out += _site_object(
            base,
            "lumber-storage",
            "MaterialStorage",
            "Lumber storage (carpenters)",
            True,
            (3.6, 1.4, 1.0),
            -9.0,
            -6.0,
        )
        out += _site_object(
            base, "entrance-area", "Workspace", "Entrance area", False, (2.0, 3.0, 2.0), -2.0, entrance_y
        )
        out += _site_object(base, "generator", "Equipment", "Generator", True, (2.2, 1.0, 1.3), L + 6.0, -6.0)
        return "\n".join(out)

    def workers(self) -> str:
        base = self.base
        out = [
            _PREFIXES,
            "# Workers of the generated site: a carpenter carrying lumber to the entrance (across the",
            "# robot's way in) and the site supervisor's round. Speeds m/s, dwell times s.",
            "",
        ]
        routes: list[Route] = [
            (
                "carpenter-1",
                "Carpenter 1",
                "carpenter",
                1.2,
                [("lumber-storage", 30.0), ("entrance-area", 60.0)],
            ),
            (
                "supervisor",
                "Site supervisor",
                "supervisor",
                1.0,
                [("office", 120.0), ("generator", 20.0), ("lumber-storage", 20.0)],
            ),
        ]
        out += _workers_ttl(base, routes)
        return "\n".join(out)

    def jobsite(self) -> str:
        return _jobsite_ttl(
            self.base,
            ["# Jobsite parameters (A5) of the generated site, as in the case study: a robot passes 0.9 m",
             "# doors with 0.1 m free on each side; speeds m/s, distances m, mass kg."],
            "Generated jobsite parameters",
            0.1,
        )

    def work_sequence(self) -> str:
        out = [
            _PREFIXES,
            "# Work sequence of each storey's framing task (T-FRAME-Lnn): unit by unit; in a unit the",
            "# bedroom partition P2 (east end first), then P1 from the facade northwards.",
            "",
        ]
        for p in sorted(self.b.panels, key=lambda p: (p.storey, p.sequence)):
            out.append(f"{self.element(p.global_id)} kbp:workSequence {p.sequence} .  # {p.panel_id}")
        return "\n".join(out) + "\n"

    def storage_key(self, storey: int, unit: int, stack: int) -> str:
        return f"frame-storage-L{storey:02d}-U{unit:02d}-S{stack}"

    def storages(self) -> str:
        base = self.base
        out = [
            _PREFIXES,
            f"# Scenario '{SCENARIO}': two frame storages (bearers {STORAGE_SIZE[0]} x {STORAGE_SIZE[1]} m)",
            "# in the living room of every unit, long sides north-south, each with the robot's pickup",
            f"# location {PICKUP_STANDOFF} m east of the stack's centre line facing west; the panels of a",
            f"# unit in install order, at most {MAX_STACK} per stack, kbp:storedIn a storage with",
            "# kbp:stackIndex (0 = bottom; the first installed lies on top).",
            "",
            f"<{base}scenario/{SCENARIO}> a kbp:Scenario ;",
            f'    kbp:scenarioName "{SCENARIO}" ;',
            '    rdfs:label "Frame storage in every unit" .',
            "",
        ]
        by_unit: dict[tuple[int, int], list[Panel]] = {}
        for p in self.b.panels:
            by_unit.setdefault((p.storey, p.unit), []).append(p)
        for (k, j), unit_panels in sorted(by_unit.items()):
            ordered = sorted(unit_panels, key=lambda p: p.unit_order)
            stacks = [ordered[i : i + MAX_STACK] for i in range(0, len(ordered), MAX_STACK)]
            if len(stacks) > len(STORAGE_YS):
                raise GeneratorError(
                    f"unit {j} of Level {k} has {len(ordered)} frames, more than "
                    f"{len(STORAGE_YS)} stacks of {MAX_STACK}",
                    element=f"L{k}-U{j}",
                    fix="use another seed",
                )
            for s_no, panels in enumerate(stacks, start=1):
                out += self._storage(k, j, s_no, panels)
        return "\n".join(out)

    def _storage(self, k: int, j: int, s_no: int, panels: list[Panel]) -> list[str]:
        base = self.base
        yaw = -math.pi / 2  # storage local x along -y; local +y (the pickup side) along +x
        key = self.storage_key(k, j, s_no)
        z = (k - 1) * STOREY_HEIGHT
        sx, sy = (j - 1) * UNIT_W + STORAGE_FROM_WEST, STORAGE_YS[s_no - 1]
        iri, pose, pickup = f"{base}site/{key}", f"{base}site/{key}-pose", f"{base}pose/{key}-pickup"
        out = [
            f"<{iri}> a kbp:MaterialStorage ;",
            f'    rdfs:label "Frame storage {s_no} Level {k} unit {j}" ;',
            "    kbp:obstructs true ;",
            f"    kbp:sizeX {_num(STORAGE_SIZE[0])} ; kbp:sizeY {_num(STORAGE_SIZE[1])} ; "
            f"kbp:sizeZ {_num(STORAGE_SIZE[2])} ;",
            f"    kbp:installedPose <{pose}> ;",
            f"    kbp:pickupLocation <{pickup}> .",
            *_pose_ttl(pose, sx, sy, z, yaw),
            *_pose_ttl(
                pickup,
                sx + PICKUP_STANDOFF,
                sy,
                z,
                -math.pi,
                f"robot pickup location: {PICKUP_STANDOFF} m from the middle of the stack, facing it",
            ),
        ]
        for i, p in enumerate(panels):
            out.append(
                f"{self.element(p.global_id)} kbp:storedIn <{iri}> ; "
                f"kbp:stackIndex {len(panels) - 1 - i} .  # {p.panel_id}"
            )
        out.append("")
        return out

    def grasp_points(self) -> str:
        base = self.base
        out = [
            _PREFIXES,
            "# Augmentation (MM-G-1 'pick frame'): a grasp point per panel, its centre of mass in the",
            "# panel's own frame (origin at the middle of the bottom plate on the wall axis, x along it).",
            "",
        ]
        for p in sorted(self.b.panels, key=lambda p: p.panel_id):
            x, y, z = p.centre_of_mass_local
            pose = f"{base}pose/{p.panel_id}-grasp"
            out += [
                f"{self.element(p.global_id)} kbp:graspPoint <{pose}> .",
                *_pose_ttl(pose, x, y, z, 0.0, f"grasp point of {p.panel_id} (local, centre of mass)"),
                "",
            ]
        return "\n".join(out)
