"""Jobsite parameters (A5): site restrictions on robots and the effective parameters of each action.

A project (or one scenario) describes its jobsite in Turtle: a ``kbp:JobsiteParameters`` node with the
allowable robot width, length, height and mass, a door clearance, site-wide skill parameters
(``kbp:maxSpeed`` caps every action's maximum speed, ``kbp:safetyStopDistance`` is a minimum for
every action, other kinds replace the value), per-action limits (``kbp:hasActionLimit`` nodes that
``kbp:appliesTo`` a skill or one action and set parameter kinds such as ``kbp:minSpeed``; like the
site-wide values, a limit's ``kbp:maxSpeed`` is a maximum: it lowers a faster setting or default and
never raises a slower one, its ``kbp:safetyStopDistance`` a minimum) and no-go
zones. ``jobsite_parameters(model, scenario=...)`` reads them (a node with ``kbp:forScenario`` applies
to that scenario only and overrides the project-wide node); ``action_parameters(spec, jobsite)`` gives
the effective value of every skill parameter of every action, with where it came from:

    skill default  <  action setting (knowledge base)  <  site-wide value  <  limit for the skill
    <  limit for the action

(each later one replaces the value, except that caps take the minimum and floors the maximum).

Their well-formedness (positive values, min <= max, zones inside the site extent) is checked by
``shapes/jobsite.ttl`` in :func:`kbplanner.knowledge.validation.validate_model`; contradictions that only
appear once values are combined (an effective minimum speed above the maximum) raise
:class:`JobsiteError` naming the jobsite term and the action.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from rdflib import Graph, Literal, URIRef
from rdflib.term import Node

from kbplanner.core.errors import KbplannerError
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import curie, select
from kbplanner.knowledge.task_specs import Action, ParamValue, TaskSpecification

log = logging.getLogger(__name__)

# Site-wide values that restrict rather than replace: caps and minimums.
_CAPS = {KBP.maxSpeed}
_FLOORS = {KBP.safetyStopDistance}
_SIZE_LIMITS = {KBP.maxRobotWidth: "max_robot_width_m", KBP.maxRobotLength: "max_robot_length_m",
                KBP.maxRobotHeight: "max_robot_height_m", KBP.maxRobotMass: "max_robot_mass_kg",
                KBP.doorClearance: "door_clearance_m"}
_NOT_PARAMETERS = {*_SIZE_LIMITS, KBP.forScenario, KBP.hasActionLimit, KBP.hasNoGoZone, KBP.appliesTo}


class JobsiteError(KbplannerError):
    """Jobsite parameters that cannot be used: contradictory values or an ambiguous definition."""


@dataclass(frozen=True)
class NoGoZone:
    """An area the robot must not enter: centre (m), yaw (rad) and size (m) in the site frame."""

    iri: URIRef
    label: str
    x: float
    y: float
    yaw: float
    size_x: float
    size_y: float


@dataclass(frozen=True)
class ActionLimit:
    """Parameter values for every action using a skill, or for one action."""

    iri: Node
    applies_to: URIRef
    values: dict[URIRef, ParamValue]


@dataclass(frozen=True)
class JobsiteParameters:
    """The jobsite parameters in force for a model (and scenario)."""

    nodes: tuple[URIRef, ...] = ()
    max_robot_width_m: float | None = None
    max_robot_length_m: float | None = None
    max_robot_height_m: float | None = None
    max_robot_mass_kg: float | None = None
    door_clearance_m: float = 0.0
    site_values: dict[URIRef, ParamValue] = field(default_factory=dict)
    limits: tuple[ActionLimit, ...] = ()
    no_go_zones: tuple[NoGoZone, ...] = ()
    sources: dict[URIRef, URIRef] = field(default_factory=dict)

    def source(self, kind: URIRef) -> str:
        """The jobsite node that set ``kind`` (for messages)."""
        node = self.sources.get(kind)
        return str(node) if node is not None else ""


def _value(v: Node | None) -> ParamValue | None:
    if isinstance(v, Literal):
        py = v.toPython()
        if isinstance(py, bool):
            return py
        try:
            return float(py)
        except (TypeError, ValueError):
            return str(v)
    if isinstance(v, URIRef):
        return v
    return None


def _float(v: Node | None) -> float | None:
    val = _value(v)
    return val if isinstance(val, float) else None


def jobsite_parameters(model: Graph, scenario: str | None = None) -> JobsiteParameters:
    """A5: the jobsite parameters of the model; nodes for ``scenario`` override project-wide ones.

    Example:
        >>> jobsite_parameters(Graph()).max_robot_width_m is None
        True
    """
    per_node: dict[URIRef, dict[URIRef, list[Node]]] = {}
    scenario_of: dict[URIRef, str | None] = {}
    for r in select(model, "jobsite_parameters"):
        node, prop, val = r["jobsite"], r["property"], r["value"]
        if not isinstance(node, URIRef) or not isinstance(prop, URIRef) or val is None:
            continue
        per_node.setdefault(node, {}).setdefault(prop, []).append(val)
        scenario_of[node] = str(r["scenario"]) if r["scenario"] is not None else None
    general = sorted(n for n, s in scenario_of.items() if s is None)
    specific = sorted(n for n, s in scenario_of.items() if s is not None and s == scenario)
    merged: dict[URIRef, tuple[Node, URIRef]] = {}
    for layer in (general, specific):
        seen: dict[URIRef, tuple[Node, URIRef]] = {}
        for node in layer:
            for prop, vals in per_node[node].items():
                if prop in (KBP.hasActionLimit, KBP.hasNoGoZone):
                    continue
                for v in vals:
                    if prop in seen and seen[prop][0] != v:
                        raise JobsiteError(
                            f"{curie(model, prop)} is given twice with different values "
                            f"({seen[prop][0]} and {v})", element=f"{seen[prop][1]}, {node}",
                            fix="keep one value per property in the project's jobsite parameters "
                                "(use kbp:forScenario for a scenario's own values)")
                    seen[prop] = (v, node)
        merged.update(seen)
    nodes = tuple([*general, *specific])
    sizes: dict[str, float] = {}
    site_values: dict[URIRef, ParamValue] = {}
    sources: dict[URIRef, URIRef] = {}
    for prop, (v, node) in sorted(merged.items(), key=lambda kv: str(kv[0])):
        if prop in _SIZE_LIMITS:
            f = _float(v)
            if f is not None:
                sizes[_SIZE_LIMITS[prop]] = f
        elif prop not in _NOT_PARAMETERS and str(prop).startswith(str(KBP._NS)):
            pv = _value(v)
            if pv is not None:
                site_values[prop] = pv
        sources[prop] = node

    limits: dict[Node, dict[URIRef, ParamValue]] = {}
    applies: dict[Node, URIRef] = {}
    for r in select(model, "jobsite_action_limits"):
        node, limit, prop = r["jobsite"], r["limit"], r["property"]
        sc = str(r["scenario"]) if r["scenario"] is not None else None
        if node not in nodes or limit is None or not isinstance(prop, URIRef) or sc not in (None, scenario):
            continue
        if isinstance(r["appliesTo"], URIRef):
            applies[limit] = r["appliesTo"]
        if prop in _NOT_PARAMETERS or not str(prop).startswith(str(KBP._NS)):
            continue
        pv = _value(r["value"])
        if pv is not None:
            limits.setdefault(limit, {})[prop] = pv
    action_limits = tuple(ActionLimit(iri=lim, applies_to=applies[lim], values=vals)
                          for lim, vals in sorted(limits.items(), key=lambda kv: str(kv[0]))
                          if lim in applies)
    zones = []
    for r in select(model, "no_go_zones"):
        z = r["zone"]
        nums = [_float(r[k]) for k in ("x", "y", "sizeX", "sizeY")]
        if not isinstance(z, URIRef) or any(v is None for v in nums):
            continue  # incomplete zones are reported by validation (shapes/jobsite.ttl)
        x, y, sx, sy = (float(v) for v in nums if v is not None)
        zones.append(NoGoZone(iri=z, label=str(r["label"] or ""), x=x, y=y, yaw=_float(r["yaw"]) or 0.0,
                              size_x=sx, size_y=sy))
    return JobsiteParameters(
        nodes=nodes,
        max_robot_width_m=sizes.get("max_robot_width_m"),
        max_robot_length_m=sizes.get("max_robot_length_m"),
        max_robot_height_m=sizes.get("max_robot_height_m"),
        max_robot_mass_kg=sizes.get("max_robot_mass_kg"),
        door_clearance_m=sizes.get("door_clearance_m", 0.0),
        site_values=site_values,
        limits=action_limits,
        no_go_zones=tuple(zones),
        sources=sources,
    )


@dataclass(frozen=True)
class EffectiveParameter:
    """The value a skill parameter takes in one action, and where it came from."""

    kind: URIRef
    name: str
    value: ParamValue | None
    unit: str
    source: str


@dataclass(frozen=True)
class ActionParameters:
    """The effective parameters of one action of a task specification."""

    action: Action
    parameters: tuple[EffectiveParameter, ...]

    def value(self, kind: URIRef) -> ParamValue | None:
        """The effective value of the parameter of ``kind`` (e.g. ``KBP.maxSpeed``), or None."""
        return next((p.value for p in self.parameters if p.kind == kind), None)


def _name(kind: URIRef) -> str:
    return str(kind).rsplit("#", 1)[-1]


def _apply(kind: URIRef, value: ParamValue | None, source: str, site: ParamValue, where: str,
           what: str) -> tuple[ParamValue | None, str]:
    """Combine a jobsite value with the value so far: a cap (maximum speed) only lowers it, a floor
    (safety stop distance) only raises it, any other kind replaces it."""
    if kind in _CAPS and isinstance(site, float) and isinstance(value, float):
        return (site, f"{where} ({what} cap)") if site < value else (value, source)
    if kind in _FLOORS and isinstance(site, float) and isinstance(value, float):
        return (site, f"{where} ({what} minimum)") if site > value else (value, source)
    return site, where


def action_parameters(spec: TaskSpecification, jobsite: JobsiteParameters | None = None
                      ) -> list[ActionParameters]:
    """A5: the effective parameters of every action of ``spec`` under the jobsite parameters.

    Example:
        >>> from kbplanner.knowledge.knowledge_base import load_kb
        >>> from kbplanner.knowledge.task_specs import task_specification
        >>> spec = task_specification(load_kb(), "I-W-F-#1")
        >>> action_parameters(spec)[2].value(KBP.maxSpeed)
        0.3
    """
    js = jobsite or JobsiteParameters()
    out: list[ActionParameters] = []
    for action in spec.actions:
        params: list[EffectiveParameter] = []
        settings = {p.iri: v for p, v in action.settings}
        for p in sorted(action.skill.parameters, key=lambda q: str(q.kind)):
            value: ParamValue | None = p.default
            source = f"default of skill {action.skill.skill_id}"
            if p.iri in settings:
                value, source = settings[p.iri], f"action {action.order} of {spec.spec_id}"
            if p.kind in js.site_values:
                value, source = _apply(p.kind, value, source, js.site_values[p.kind],
                                       f"jobsite {js.source(p.kind)}", "site-wide")
            for lim in js.limits:
                if lim.applies_to == action.skill.iri and p.kind in lim.values:
                    value, source = _apply(p.kind, value, source, lim.values[p.kind],
                                           f"jobsite limit {lim.iri} for {action.skill.skill_id}", "limit")
            for lim in js.limits:
                if lim.applies_to == action.iri and p.kind in lim.values:
                    value, source = _apply(p.kind, value, source, lim.values[p.kind],
                                           f"jobsite limit {lim.iri} for action {action.order}", "limit")
            params.append(EffectiveParameter(kind=p.kind, name=_name(p.kind), value=value, unit=p.unit,
                                             source=source))
        ap = ActionParameters(action=action, parameters=tuple(params))
        lo, hi = ap.value(KBP.minSpeed), ap.value(KBP.maxSpeed)
        if isinstance(lo, float) and isinstance(hi, float) and lo > hi:
            src = {q.kind: q.source for q in params}
            raise JobsiteError(
                f"action {action.order} '{action.label}' of {spec.spec_id} ({action.skill.skill_id}) "
                f"would run with minimum speed {lo} m/s above its maximum speed {hi} m/s "
                f"(minSpeed from {src[KBP.minSpeed]}; maxSpeed from {src[KBP.maxSpeed]})",
                element=spec.spec_id,
                fix="lower kbp:minSpeed or raise kbp:maxSpeed in the jobsite parameters "
                    "(add an kbp:ActionLimit for this skill with both values)")
        out.append(ap)
    return out
