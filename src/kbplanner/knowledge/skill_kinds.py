"""B2-B5 contract: the closed set of executable skill kinds and the input roles each one uses.

Construction tasks are composed in Turtle from these kinds only (``ontology/kb/capabilities.ttl``
declares them, :mod:`kbplanner.simulation.skills` implements each one). A skill input declares its
role (``kbp:inputRole``, a closed set declared in ``ontology/robotics.ttl``); the executor and B4 find
an input by its role, never by its ``kbp:inputName``, which is a label only.

:func:`check_executable` runs before planning and simulation: a skill of a kind outside the set, an
input without a role, a role the skill's kind cannot use, or a kind's required role that the skill
lacks is a :class:`~kbplanner.core.errors.KnowledgeBaseError` naming the skill, the input, the file
and what exists (exit 2), instead of a failed step in the middle of a run.

Example:
    >>> from kbplanner.knowledge.knowledge_base import load_kb
    >>> from kbplanner.knowledge.task_specs import task_specification
    >>> check_executable(load_kb(), task_specification(load_kb(), "L-M-#1"))
    >>> sorted(local(k) for k in KINDS)[:3]
    ['Fasten', 'FollowToolPath', 'Inspect']
"""

from __future__ import annotations

from dataclasses import dataclass

from rdflib import Graph, URIRef

from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import curie, source_of
from kbplanner.knowledge.task_specs import Skill, TaskSpecification

# Roles every kind accepts: what the robot and the world supply at run time, and the work element.
_RUNTIME = frozenset({KBP.RobotPoseRole, KBP.MapRole, KBP.ScanRole, KBP.WorkElementRole})


@dataclass(frozen=True)
class KindContract:
    """What an executable skill kind needs (``required``) and can use (``accepted``, with the required)."""

    kind: URIRef
    summary: str
    required: frozenset[URIRef]
    accepted: frozenset[URIRef]

    @property
    def usable(self) -> frozenset[URIRef]:
        """Every role the kind's executor uses."""
        return self.required | self.accepted | _RUNTIME


def _contract(kind: URIRef, summary: str, required: set[URIRef], accepted: set[URIRef]) -> KindContract:
    return KindContract(kind, summary, frozenset(required), frozenset(accepted))


KINDS: dict[URIRef, KindContract] = {c.kind: c for c in (
    _contract(KBP.Navigation, "drive the base to a destination pose (OMPL path, speed and separation "
              "monitoring)", {KBP.DestinationRole}, set()),
    _contract(KBP.NavigationWithObject, "the same, carrying the held element",
              {KBP.DestinationRole}, {KBP.HeldElementRole}),
    _contract(KBP.MoveManipulatorAndGrasp, "pick: grasp the element where it lies at its storage and lift it",
              {KBP.GraspFrameRole}, {KBP.ElementPoseRole}),
    _contract(KBP.MoveManipulatorAndRelease, "place: put the held element at its target pose and release it",
              {KBP.TargetPoseRole}, {KBP.HeldElementRole}),
    _contract(KBP.Fasten, "hold a tool pose for a dwell time, pressing with a contact force",
              {KBP.TargetPoseRole}, {KBP.DwellTimeRole, KBP.ContactForceRole, KBP.HeldElementRole}),
    _contract(KBP.FollowToolPath, "move the tool along a line on a surface at the tool speed",
              {KBP.ToolPathRole}, {KBP.PathStartRole, KBP.LocalisationReferenceRole}),
    _contract(KBP.Inspect, "turn to a view target and hold the view for a dwell time",
              {KBP.ViewTargetRole}, {KBP.DwellTimeRole}),
)}


def local(iri: URIRef | str) -> str:
    """``...#DestinationRole`` -> ``DestinationRole``."""
    return str(iri).rsplit("#", 1)[-1]


def _names(iris: object) -> str:
    return ", ".join(sorted(f"kbp:{local(i)}" for i in iris))  # type: ignore[attr-defined]


def declared_roles(kb: Graph) -> list[URIRef]:
    """Every ``kbp:InputRole`` of the ontology, sorted."""
    from rdflib import RDF

    return sorted((r for r in kb.subjects(RDF.type, KBP.InputRole) if isinstance(r, URIRef)), key=str)


def check_skill(kb: Graph, skill: Skill) -> None:
    """Raise KnowledgeBaseError when ``skill`` cannot be executed (see module docstring)."""
    where = source_of(kb, skill.iri)
    if skill.kind is None or skill.kind not in KINDS:
        what = curie(kb, skill.kind) if skill.kind is not None else "no kind (kbp:skillKind is missing)"
        raise KnowledgeBaseError(
            f"skill {skill.skill_id} has kind {what}, which the executor does not implement",
            file=where, element=curie(kb, skill.iri),
            fix=f"compose the task from the executable kinds: {_names(KINDS)}")
    contract = KINDS[skill.kind]
    for inp in skill.inputs:
        file = source_of(kb, inp.iri) or where
        if inp.role is None:
            raise KnowledgeBaseError(
                f"input '{inp.name}' of skill {skill.skill_id} has no kbp:inputRole",
                file=file, element=curie(kb, inp.iri),
                fix=f"add kbp:inputRole with one of the roles kind kbp:{local(skill.kind)} uses: "
                    f"{_names(contract.usable)}")
        if inp.role not in contract.usable:
            known = "a declared kbp:InputRole" if (inp.role, None, None) in kb else "not a declared role"
            raise KnowledgeBaseError(
                f"input '{inp.name}' of skill {skill.skill_id} has role {curie(kb, inp.role)} ({known}), "
                f"which the executor of kind kbp:{local(skill.kind)} cannot use",
                file=file, element=curie(kb, inp.iri),
                fix=f"use one of the roles of kbp:{local(skill.kind)}: {_names(contract.usable)}; or give "
                    "the skill another kind")
    roles = [i.role for i in skill.inputs]
    for role in sorted(contract.required, key=str):
        if role not in roles:
            raise KnowledgeBaseError(
                f"skill {skill.skill_id} (kind kbp:{local(skill.kind)}) has no input with role "
                f"kbp:{local(role)}",
                file=where, element=curie(kb, skill.iri),
                fix=f"add a kbp:SkillInput with kbp:inputRole kbp:{local(role)} (bound by the action or "
                    "supplied at run time)")
    dup = sorted({local(r) for r in roles if r is not None and roles.count(r) > 1})
    if dup:
        raise KnowledgeBaseError(
            f"skill {skill.skill_id} has several inputs with role kbp:{dup[0]}", file=where,
            element=curie(kb, skill.iri), fix="give each input of a skill its own role")


def check_executable(kb: Graph, spec: TaskSpecification) -> None:
    """Check every skill of ``spec`` with :func:`check_skill` (before planning and simulation)."""
    for skill in spec.skills:
        check_skill(kb, skill)
