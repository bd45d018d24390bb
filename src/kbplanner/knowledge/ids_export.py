"""IDS export of the additional modeling requirements (A3, for BIM authors): buildingSMART IDS 1.0.

The same bindings that generate the SHACL requirement shapes (:mod:`kbplanner.knowledge.requirement_shapes`)
are mapped to IFC-side information: one IDS specification per unmet (robotized task, action, binding),
applicable to the IFC entities the SHACL requirement names (entity + ``GlobalId`` enumeration), requiring
properties of one property set, :data:`PSET`. How a binding path maps:

* a value class with datatype fields (a ``kbp:Pose``: x, y, z, roll, pitch, yaw) reached in one step
  (``kbp:graspPoint``): one property per field, ``GraspPointX`` ... ``GraspPointYaw``, typed from the
  field's XSD range (``xsd:double`` -> ``IFCREAL``);
* a datatype value in one step: one property typed from the value class;
* a path whose first step leads to a node outside the IFC (``kbp:storedIn`` a material storage, then
  its ``kbp:pickupLocation``): the element-side step as a reference property (``StoredIn``, ``IFCLABEL``,
  the name of the node); the rest of the path lives on site objects modeled in Turtle, which IFC and
  IDS cannot check. The specification's description says so, as does the IDS's description;
* paths that start at the task, or use alternatives, repetitions or inverse steps: no IFC counterpart;
  listed in the IDS's description and in :attr:`IdsExport.not_expressed`.

Bindings the bare model already meets (``kbp:installedPose`` comes from the IFC's own placement) are
not re-specified. The IDS is written with ``ifctester`` (IfcOpenShell's IDS library), which checks it
against the IDS 1.0 XML schema. :meth:`IdsExport.values` reads the values of the properties from an
augmented model graph, so the same mapping can write them back into an IFC
(:mod:`kbplanner.model.ifc_augment`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ifctester import ids as ifc_ids
from rdflib import RDFS, XSD, Graph, Literal, URIRef
from rdflib.term import Node

from kbplanner.core.errors import KbplannerError
from kbplanner.core.outputs import atomic_write_text
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.binding_paths import PredicatePath, path_curies, steps_of
from kbplanner.knowledge.knowledge_base import SH, curie, is_datatype, label
from kbplanner.knowledge.requirement_rows import class_fill
from kbplanner.knowledge.requirement_shapes import BindingTarget
from kbplanner.knowledge.requirements import RequirementsResult

PSET = "Kbplanner_RobotTaskInputs"
IFC_VERSIONS = ("IFC2X3", "IFC4", "IFC4X3_ADD2")

_IFC_TYPE = {
    XSD.double: "IFCREAL", XSD.float: "IFCREAL", XSD.decimal: "IFCREAL",
    XSD.integer: "IFCINTEGER", XSD.int: "IFCINTEGER", XSD.nonNegativeInteger: "IFCINTEGER",
    XSD.boolean: "IFCBOOLEAN", XSD.string: "IFCLABEL",
}
REFERENCE_TYPE = "IFCLABEL"

_FACETS = {SH.minInclusive: "minInclusive", SH.minExclusive: "minExclusive",
           SH.maxInclusive: "maxInclusive", SH.maxExclusive: "maxExclusive"}


def value_bounds(shapes: Graph | None, predicate: URIRef) -> tuple[tuple[str, float], ...]:
    """The numeric range facets the SHACL shapes put on ``predicate`` (e.g. ``sh:minInclusive 0``)."""
    if shapes is None:
        return ()
    found: dict[str, float] = {}
    for shape in sorted(shapes.subjects(SH.path, predicate), key=str):
        for facet, name in _FACETS.items():
            v = shapes.value(shape, facet)
            if isinstance(v, Literal) and isinstance(v.toPython(), int | float) and name not in found:
                found[name] = float(v.toPython())
    return tuple(sorted(found.items()))


def property_name(*iris: URIRef) -> str:
    """An IFC property name from IRIs' local names: ``graspPoint`` + ``x`` -> ``GraspPointX``."""
    parts = []
    for iri in iris:
        local = re.split(r"[#/]", str(iri))[-1]
        parts.append(local[:1].upper() + local[1:])
    return "".join(parts)


def ifc_type(datatype: URIRef) -> str:
    """The IFC measure type of an XSD datatype (``IFCLABEL`` for anything else)."""
    return _IFC_TYPE.get(datatype, "IFCLABEL")


@dataclass(frozen=True)
class IdsProperty:
    """One required property: where its value is in the RDF model (``steps``, then ``field``)."""

    name: str
    data_type: str
    steps: tuple[URIRef, ...]
    field: URIRef | None
    words: str
    bounds: tuple[tuple[str, float], ...] = ()  # XSD facets (minInclusive ...) from the SHACL shapes

    def value(self, graph: Graph, element: Node) -> Any | None:
        """The property's value for ``element`` in ``graph`` (the first in sorted order), else None."""
        nodes: list[Node] = [element]
        for p in self.steps:
            nodes = sorted({o for n in nodes for o in graph.objects(n, p)}, key=str)
        for node in nodes:
            if self.field is not None:
                v = graph.value(node, self.field)
                if isinstance(v, Literal):
                    return v.toPython()
            elif isinstance(node, Literal):
                return node.toPython()
            else:
                name = graph.value(node, RDFS.label)
                return str(name) if name is not None else re.split(r"[#/]", str(node))[-1]
        return None


@dataclass(frozen=True)
class IdsSpec:
    """One IDS specification: an unmet binding of a robotized task's action, on named IFC elements."""

    identifier: str
    name: str
    entities: dict[str, tuple[str, ...]]   # IFC class (upper case) -> GlobalIds
    properties: tuple[IdsProperty, ...]
    description: str
    instructions: str
    requirements: tuple[int, ...]          # numbers of the SHACL requirements it maps

    @property
    def global_ids(self) -> list[str]:
        """Every GlobalId the specification applies to, sorted."""
        return sorted(g for gids in self.entities.values() for g in gids)


@dataclass
class IdsExport:
    """The IDS form of a :class:`RequirementsResult`."""

    specs: list[IdsSpec]
    not_expressed: list[str] = field(default_factory=list)
    already_met: list[str] = field(default_factory=list)
    title: str = "kbplanner additional modeling requirements"

    def description(self) -> str:
        """The IDS's description: the mapping, what is already met, what IDS cannot express."""
        text = (f"Additional modeling requirements of the robotized tasks, generated by kbplanner from the "
                f"knowledge base's input bindings (the same that generate its SHACL shapes). Values go into "
                f"the property set {PSET}. ")
        if self.not_expressed:
            text += "Not expressible in IDS (checked only by kbplanner's SHACL validation): " + \
                "; ".join(self.not_expressed) + ". "
        if self.already_met:
            text += "Already held by the model: " + "; ".join(self.already_met) + "."
        return text.strip()

    def to_ids(self, ifc_versions: tuple[str, ...] = IFC_VERSIONS) -> ifc_ids.Ids:
        """The ifctester ``Ids`` object."""
        doc = ifc_ids.Ids(title=self.title, description=self.description(),
                          purpose="robot task planning (kbplanner)")
        for s in self.specs:
            for cls, gids in sorted(s.entities.items()):
                spec = ifc_ids.Specification(
                    name=s.name if len(s.entities) == 1 else f"{s.name} ({cls})",
                    ifcVersion=list(ifc_versions), identifier=s.identifier, description=s.description,
                    instructions=s.instructions, minOccurs=1)
                spec.applicability.append(ifc_ids.Entity(name=cls))
                spec.applicability.append(ifc_ids.Attribute(
                    name="GlobalId", value=ifc_ids.Restriction(options={"enumeration": list(gids)})))
                for prop in s.properties:
                    value = (ifc_ids.Restriction(options=dict(prop.bounds), base="double")
                             if prop.bounds else None)
                    spec.requirements.append(ifc_ids.Property(
                        propertySet=PSET, baseName=prop.name, value=value, dataType=prop.data_type,
                        cardinality="required", instructions=prop.words))
                doc.specifications.append(spec)
        return doc

    def to_string(self, ifc_versions: tuple[str, ...] = IFC_VERSIONS) -> str:
        """IDS XML text (valid against the IDS 1.0 schema)."""
        text = self.to_ids(ifc_versions).to_string()
        head = '<?xml version="1.0" encoding="utf-8"?>\n'
        return text if text.startswith("<?xml") else head + text + "\n"

    def write(self, path: Path, ifc_versions: tuple[str, ...] = IFC_VERSIONS) -> None:
        """Write the IDS file atomically; raises when it would not be valid IDS 1.0 (none written)."""
        if not self.specs:
            raise KbplannerError("nothing to write: not valid IDS without a specification", file=path,
                                 fix="write an IDS of a model that lacks something (the bare model)")
        text = self.to_string(ifc_versions)
        errors = list(ifc_ids.get_schema().iter_errors(text))
        if errors:
            raise KbplannerError(f"generated IDS is not valid IDS 1.0: {errors[0]}", file=path,
                                 fix="report this as a kbplanner bug")
        atomic_write_text(path, text)

    def values(self, graph: Graph, element_iris: dict[str, Node]) -> dict[str, dict[str, Any]]:
        """Per GlobalId, the value of every mapped property found in ``graph`` (an augmented model)."""
        out: dict[str, dict[str, Any]] = {}
        for s in self.specs:
            for gid in s.global_ids:
                node = element_iris.get(gid)
                if node is None:
                    continue
                for prop in s.properties:
                    v = prop.value(graph, node)
                    if v is not None:
                        out.setdefault(gid, {})[prop.name] = v
        return out


def _properties(kb: Graph, bt: BindingTarget, shapes: Graph | None) -> tuple[list[IdsProperty], str]:
    """The IFC properties of a binding and what of its path IDS cannot express ('' when all of it)."""
    b = bt.binding
    steps = steps_of(b.path)
    where = f"{bt.task.task_id} action {bt.action.order} {bt.action.skill.skill_id} '{b.input.name}'"
    if b.starts_at_task:
        return [], f"{where} ({path_curies(kb, b.path)}) starts at the task, not at an IFC element"
    if steps is None or not isinstance(steps[0], PredicatePath):
        return [], f"{where} ({path_curies(kb, b.path)}) uses a path form with no IFC property counterpart"
    first = steps[0].predicate
    vc = b.input.value_class
    if len(steps) == 1:
        if vc is not None and is_datatype(kb, vc):
            return [IdsProperty(property_name(first), ifc_type(vc), (first,), None, b.words,
                                value_bounds(shapes, first))], ""
        fields = class_fill(kb, vc) if vc is not None else []
        if fields:
            return [IdsProperty(property_name(first, f), ifc_type(rng), (first,), f,
                                f"{label(kb, f)} of the {b.words}", value_bounds(shapes, f))
                    for f, rng in fields], ""
        return [IdsProperty(property_name(first), REFERENCE_TYPE, (first,), None,
                            f"name of the {b.words}")], ""
    rest = path_curies(kb, b.path).split(" / ", 1)[-1]
    target = kb.value(first, RDFS.range)
    on = curie(kb, target) if isinstance(target, URIRef) else "the linked node"
    prop = IdsProperty(property_name(first), REFERENCE_TYPE, (first,), None,
                       f"name of the {label(kb, target) if isinstance(target, URIRef) else 'node'} "
                       f"({curie(kb, first)})")
    return [prop], (f"{where}: only the element's {curie(kb, first)} (property {prop.name}); "
                    f"the rest of the path ({rest}) is on a {on} modeled in Turtle (site layout or "
                    "scenario overlay), outside the IFC")


def ids_export(result: RequirementsResult, shapes: Graph | None = None) -> IdsExport:
    """A3 as IDS: one specification per unmet binding of :func:`derive_requirements`'s result.

    ``shapes`` (e.g. the well-formedness shapes of ``shapes/``) give value constraints: a numeric range
    a shape puts on a property becomes the IDS property's ``xs:restriction``.

    Example:
        >>> from kbplanner.knowledge.knowledge_base import load_kb
        >>> from kbplanner.knowledge.requirements import derive_requirements
        >>> ids_export(derive_requirements(Graph(), load_kb())).specs
        []
    """
    model, kb = result.model, result.kb
    by_shape: dict[URIRef, list[int]] = {}
    elements: dict[URIRef, set[Node]] = {}
    for r in result.requirements:
        by_shape.setdefault(r.shape, []).append(r.number)
        elements.setdefault(r.shape, set()).update(e.iri for e in r.elements)
    out = IdsExport(specs=[])
    for c in result.checks:
        if c.unmet == 0:
            out.already_met.append(f"{c.task_id} action {c.action_order} {c.skill_id} '{c.input_name}' "
                                   f"({c.needs})")
    for shape, numbers in by_shape.items():
        bt = result.shapes.targets[shape]
        props, missing = _properties(kb, bt, shapes)
        if missing:
            out.not_expressed.append(missing)
        if not props:
            continue
        entities: dict[str, list[str]] = {}
        for e in sorted(elements[shape], key=str):
            cls = model.value(e, KBP.ifcClass)
            gid = model.value(e, KBP.globalId)
            if cls is None or gid is None:
                out.not_expressed.append(f"{curie(model, e)} has no IFC class or GlobalId in the model")
                continue
            entities.setdefault(str(cls).upper(), []).append(str(gid))
        if not entities:
            continue
        req = [r for r in result.requirements if r.shape == shape]
        a = bt.action
        out.specs.append(IdsSpec(
            identifier=f"{bt.task.task_id}/{a.order}/{a.skill.skill_id}/{bt.binding.input.name}",
            name=(f"{bt.task.task_id} action {a.order} '{a.label}': "
                  f"{a.skill.skill_id} {bt.binding.input.name}"),
            entities={k: tuple(sorted(v)) for k, v in entities.items()},
            properties=tuple(props),
            description=f"{req[0].missing}." + (f" Not in IDS: {missing}." if missing else ""),
            instructions=f"Add {PSET} with " + ", ".join(p.name for p in props)
            + f" to each element (in kbplanner's RDF: {req[0].how_to_add})",
            requirements=tuple(sorted(numbers))))
    out.specs.sort(key=lambda s: s.identifier)
    return out
