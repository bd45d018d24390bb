"""B1-B3 output: the action-level plan as RDF (``plan.ttl``), linked to the model and the knowledge base.

Takes a :class:`~kbplanner.planning.plan_model.Plan` and the knowledge base (to know the value class of each
skill input); returns an rdflib graph, or byte-stable Turtle:

- the plan, ``kbp:Plan``: ``kbp:forTask`` (the schedule task), ``kbp:forSpecification``,
  ``kbp:forRobot`` (when a robot was chosen), ``kbp:planScenario``, ``kbp:orderRule``,
  ``kbp:feasible`` and one ``kbp:planStep`` per step;
- each step, ``kbp:PlanStep``: ``kbp:order`` (its number), ``kbp:forTask``, ``kbp:forSpecification``,
  ``kbp:forAction``, ``kbp:forSkill``, ``kbp:forElement``, ``kbp:forRobot``, ``kbp:feasible`` and
  ``kbp:infeasibleReason``, and one ``kbp:stepInput`` per input value (``kbp:forInput`` the skill
  input, ``kbp:value`` a ``kbp:Pose`` / ``kbp:Box`` node, an IRI or a literal).

Every node is an IRI minted under the project's data base (``{base}plan/{task}/{scenario}/{robot}``,
``.../step/{n}``, ``.../input/{name}``): no blank nodes, so equal plans give equal bytes.
"""

from __future__ import annotations

import logging
from urllib.parse import quote

from rdflib import RDF, RDFS, XSD, Graph, Literal, URIRef

from kbplanner.core.errors import KbplannerError
from kbplanner.core.iris import DATA_ROOT, base_iri
from kbplanner.core.rdf_io import bind_prefixes
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import select
from kbplanner.model.ifc_turtle import serialize
from kbplanner.planning.plan_model import JsonValue, Plan, SkillCall

log = logging.getLogger(__name__)

_POSE_KEYS = (KBP.x, KBP.y, KBP.z, KBP.roll, KBP.pitch, KBP.yaw)
_BOX_KEYS = (KBP.minX, KBP.minY, KBP.minZ, KBP.maxX, KBP.maxY, KBP.maxZ)


class PlanRdfError(KbplannerError):
    """A plan cannot be written as RDF (an IRI of the model that Turtle cannot hold)."""


def plan_base(plan: Plan) -> str:
    """The data base IRI of the plan's project: the task IRI's project base, else one from its name."""
    if plan.task_iri.startswith(DATA_ROOT):
        project = plan.task_iri[len(DATA_ROOT):].split("/", 1)[0]
        if project:
            return f"{DATA_ROOT}{project}/"
    return base_iri(plan.project)


def _key(text: str) -> str:
    return quote(text, safe="")


def plan_iri(plan: Plan, base: str | None = None) -> URIRef:
    """``{base}plan/{task}/{scenario or 'bare'}/{robot or 'no-robot'}``, each part percent-encoded.

    Example:
        >>> p = Plan("Demo", None, "T 1", "", "S", "", "", "", "rule")
        >>> str(plan_iri(p))
        'https://w3id.org/kbplanner/data/demo/plan/T%201/bare/no-robot'
    """
    b = base or plan_base(plan)
    parts = (plan.task_id, plan.scenario or "bare", plan.robot_id or "no-robot")
    return URIRef(f"{b}plan/" + "/".join(_key(p) for p in parts))


def _value_classes(kb: Graph, steps: list[SkillCall]) -> dict[tuple[str, str], tuple[URIRef, URIRef | None]]:
    """(skill IRI, input name) -> (input IRI, value class) for every skill of the plan."""
    out: dict[tuple[str, str], tuple[URIRef, URIRef | None]] = {}
    for skill in sorted({s.skill for s in steps}):
        for r in select(kb, "skill_inputs", skill=URIRef(skill)):
            inp, name, vc = r["input"], r["name"], r["valueClass"]
            if isinstance(inp, URIRef) and name is not None:
                out.setdefault((skill, str(name)), (inp, vc if isinstance(vc, URIRef) else None))
    return out


def _literal(value: JsonValue) -> Literal:
    if isinstance(value, bool):
        return Literal(value)
    if isinstance(value, int):
        return Literal(value, datatype=XSD.integer)
    if isinstance(value, float):
        return Literal(value, datatype=XSD.double)
    return Literal(str(value))


def _add_numbers(g: Graph, node: URIRef, cls: URIRef, keys: tuple[URIRef, ...], values: list[float]) -> None:
    g.add((node, RDF.type, cls))
    for k, v in zip(keys, values, strict=True):
        g.add((node, k, Literal(float(v), datatype=XSD.double)))


def _add_input(g: Graph, step: URIRef, name: str, value: JsonValue, inp: URIRef | None,
               value_class: URIRef | None) -> None:
    node = URIRef(f"{step}/input/{_key(name)}")
    g.add((step, KBP.stepInput, node))
    g.add((node, RDF.type, KBP.StepInput))
    g.add((node, RDFS.label, Literal(name)))
    if inp is not None:
        g.add((node, KBP.forInput, inp))
    if isinstance(value, list) and len(value) == 6 and value_class in (KBP.Pose, KBP.Box):
        target = URIRef(f"{node}/{'pose' if value_class == KBP.Pose else 'box'}")
        _add_numbers(g, target, value_class, _POSE_KEYS if value_class == KBP.Pose else _BOX_KEYS,
                     [float(v) for v in value])
        g.add((node, KBP.value, target))
    elif isinstance(value, list):
        for v in value:
            g.add((node, KBP.value, _literal(v)))
    elif isinstance(value, str) and value_class is not None and not str(value_class).startswith(str(XSD)):
        g.add((node, KBP.value, URIRef(value)))  # an element or another node of the model
    elif value is not None:
        g.add((node, KBP.value, _literal(value)))


def plan_graph(plan: Plan, kb: Graph, *, base: str | None = None) -> Graph:
    """The plan as an RDF graph (see the module docstring).

    Example:
        >>> p = Plan("Demo", None, "T1", "", "S", "", "", "", "rule")
        >>> sorted(str(o).rsplit("#", 1)[-1] for o in plan_graph(p, Graph()).objects(None, RDF.type))
        ['Plan']
    """
    g = Graph()
    bind_prefixes(g)
    root = plan_iri(plan, base)
    robot = next((URIRef(str(r["iri"])) for r in plan.selection if r.get("chosen")), None)
    task = URIRef(plan.task_iri) if plan.task_iri else None
    spec = URIRef(plan.spec_iri) if plan.spec_iri else None
    g.add((root, RDF.type, KBP.Plan))
    g.add((root, RDFS.label, Literal(f"plan of task {plan.task_id} ({plan.spec_id}) for "
                                     f"{plan.robot_label or 'no robot'}, {plan.scenario or 'bare model'}")))
    g.add((root, KBP.orderRule, Literal(plan.order_rule)))
    g.add((root, KBP.feasible, Literal(plan.feasible)))
    if plan.scenario is not None:
        g.add((root, KBP.planScenario, Literal(plan.scenario)))
    links = [(KBP.forTask, task), (KBP.forSpecification, spec), (KBP.forRobot, robot)]
    for prop, target in links:
        if target is not None:
            g.add((root, prop, target))
    classes = _value_classes(kb, plan.steps)
    for s in plan.steps:
        node = URIRef(f"{root}/step/{s.step}")
        g.add((root, KBP.planStep, node))
        g.add((node, RDF.type, KBP.PlanStep))
        g.add((node, RDFS.label, Literal(f"step {s.step}: {s.action_label} ({s.skill_id})")))
        g.add((node, KBP.order, Literal(s.step, datatype=XSD.integer)))
        for prop, target in links:
            if target is not None:
                g.add((node, prop, target))
        g.add((node, KBP.forAction, URIRef(s.action)))
        g.add((node, KBP.forSkill, URIRef(s.skill)))
        g.add((node, KBP.forElement, URIRef(s.element)))
        g.add((node, KBP.feasible, Literal(s.feasible)))
        if s.reason:
            g.add((node, KBP.infeasibleReason, Literal(s.reason)))
        for name, value in sorted(s.inputs.items()):
            inp, vc = classes.get((s.skill, name), (None, None))
            _add_input(g, node, name, value, inp, vc)
    return g


def plan_turtle(plan: Plan, kb: Graph, *, base: str | None = None) -> str:
    """The plan as byte-stable Turtle text.

    Raises:
        PlanRdfError: an IRI of the plan (from the model) cannot be written in Turtle.
    """
    try:
        return serialize(plan_graph(plan, kb, base=base)).decode("utf-8")
    except ValueError as exc:
        raise PlanRdfError(f"the plan cannot be written as Turtle: {exc}", element=plan.task_id,
                           fix="give the element or node a valid IRI (no spaces, quotes, <, >, braces) "
                               "in the model") from None
