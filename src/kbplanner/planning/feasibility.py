"""B4 verdicts per element: is the element installable, and if not, why, where and what to change.

Takes a plan refined by B4 (:func:`kbplanner.planning.manipulation.refine_plan`, the same checks that
``simulate`` relies on) or a B1-B3 plan; gives one :class:`ElementVerdict` per element of the plan, in
plan order: feasible, or the first infeasible step of the element (its reason, not the "skipped"
steps after it), the place the step acts on (where the element lies for a pick, its installed pose
otherwise: what a figure of the failure shows) and a **fix**: the sentence that tells the user what
to change in the project (the storage, the site layout, ``kbp:workSequence``, ``kbp:stackIndex``, the
robot, the model). Fixes are chosen by the reason's kind (:data:`FIXES`, first match wins); a reason
of no known kind gets :data:`DEFAULT_FIX`.

Used by ``kbplanner plan`` (:mod:`kbplanner.cli.plan`), which prints the verdicts, writes them to
``feasibility.json`` and draws a figure per infeasible element
(:mod:`kbplanner.analysis.plan_figures`).

Example:
    >>> fix_for("the element weighs 30 kg, more than the arm's payload of 16 kg (husky_ur16e)")[:31]
    'choose a robot whose arm carries'
"""

from __future__ import annotations

import re
from dataclasses import asdict, dataclass

from kbplanner.core.vocab import KBP
from kbplanner.planning.plan_model import Plan, Pose2, SkillCall

#: (pattern of a reason, the fix), first match wins. Patterns are regular expressions searched in the
#: reason text of B1-B3 (missing model information, robot selection) and B4 (poses, stack, payload).
FIXES: tuple[tuple[str, str], ...] = (
    (r"lies under \d+ element",
     "take the stack from the top: remove the contradicting kbp:workSequence values (the plan then "
     "follows kbp:stackIndex) or give the elements on top a lower kbp:workSequence, or restack the "
     "storage (kbp:stackIndex, the first installed on top)"),
    (r"weighs .* more than the arm's payload",
     "choose a robot whose arm carries the element (kbplanner plan --robot ID; kbplanner robots lists "
     "them), or split the element into lighter parts"),
    (r"not at a storage",
     "store the element: give it kbp:storedIn (a kbp:MaterialStorage with a pose, a size and a "
     "kbp:pickupLocation) and kbp:stackIndex"),
    (r"out of reach from any base pose",
     "bring the element within the arm's height range: a lower storage or stack (kbp:sizeZ, fewer "
     "elements per stack), or a robot with a longer arm"),
    (r"carry way closed by ",
     "install this element before the element the reason names (a lower kbp:workSequence than its; "
     "without kbp:workSequence B4 tries that order itself), or put the storage and its "
     "kbp:pickupLocation on this element's side of the element that closes the way"),
    (r"carry way needs the load turned",
     "give the robot room to turn the carried element near the pickup location: move the storage and its "
     "kbp:pickupLocation to a more open spot (where the element fits both ways next to the robot), or "
     "put the pickup location on the side of the stack facing the way to the walls"),
    (r"carry way walled off",
     "give the robot carrying the element a way: move the storage and its kbp:pickupLocation so that an "
     "opening wider than the carried element (the reason gives its sizes) leads to the installed pose, "
     "or split the element into shorter panels"),
    (r"shut in by the installed element",
     "install this element earlier (a lower kbp:workSequence than the elements around it), so the "
     "robot does not close itself in"),
    (r"no (free )?base pose|\b0 free base pose|neither carry footprint is free",
     "free the floor where the robot must stand: move the site objects or the storage that occupy it, "
     "or install this element before the elements whose installed footprints block it (a lower "
     "kbp:workSequence)"),
    (r"no carry pose",
     "check the element's kbp:graspPoint and size: the robot cannot hold it clear of itself; a robot "
     "with a longer arm or a grasp point at the element's centre of mass may"),
    (r"grasp point out of reach|pre-grasp|approach pose|no lift pose|arm would reach",
     "make the pick reachable: put the storage's kbp:pickupLocation next to the stack with room to "
     "stand on its long side, lower the stack (fewer elements per storage), or check kbp:graspPoint"),
    (r"installed pose out of reach|place unreachable|pre-place|orient pose|retract pose|into the robot",
     "make the installed pose reachable: free the floor in front of it (move what occupies it), or "
     "install it before the neighbouring elements (a lower kbp:workSequence)"),
    (r"has no arm|does not fit|no robot of the knowledge base fits",
     "choose a robot that fits the task (kbplanner robots lists each robot's reasons) or change the "
     "task's requirements"),
    (r"missing input",
     "add the missing model information (kbplanner requirements lists what the task needs; "
     "kbplanner requirements --template writes it to fill in)"),
)
DEFAULT_FIX = ("change what the reason names (the site layout, the storage, the work sequence or the "
               "robot) and plan again")


@dataclass(frozen=True)
class ElementVerdict:
    """Whether one element can be installed, and if not: the step, the reason, where, and the fix."""

    iri: str
    label: str
    feasible: bool
    step: int | None = None  # the first infeasible step
    action: str | None = None
    skill_id: str | None = None
    reason: str | None = None
    fix: str | None = None
    at: tuple[float, float] | None = None  # (x, y) the failing step acts on
    base_pose: Pose2 | None = None  # the last base pose B4 found for the element (before the failure)
    figure: str | None = None  # file name of its figure, once written

    def to_dict(self) -> dict[str, object]:
        """JSON-ready (poses rounded to 0.1 mm / 1 mrad, stable files)."""
        d = asdict(self)
        d["at"] = [round(v, 4) for v in self.at] if self.at is not None else None
        d["base_pose"] = ({k: round(v, 4) for k, v in asdict(self.base_pose).items()}
                          if self.base_pose is not None else None)
        return d


#: The fix for an installed pose outside the arm's height range (an install step; a pick gets the
#: storage fix of :data:`FIXES`).
INSTALL_OUT_OF_REACH_FIX = ("the installed pose is outside the arm's height range: choose a robot that "
                            "reaches it (a longer arm or a lifting base: kbplanner robots), or leave this "
                            "element to the workers (take it out of the robotized task)")


def fix_for(reason: str, *, pick: bool = True) -> str:
    """The fix sentence for an infeasibility reason (see :data:`FIXES`); ``pick``: of a pick step."""
    if not pick and reason.startswith("out of reach from any base pose"):
        return INSTALL_OUT_OF_REACH_FIX
    for pattern, fix in FIXES:
        if re.search(pattern, reason):
            return fix
    return DEFAULT_FIX


_PICK_KINDS = (str(KBP.MoveManipulatorAndGrasp), str(KBP.Navigation))


def _is_pick(step: SkillCall) -> bool:
    """A step on the way to the element where it lies (NV-1, MM-G-1), not to where it goes."""
    return step.skill_kind in _PICK_KINDS


def element_verdicts(plan: Plan) -> list[ElementVerdict]:
    """One verdict per element of ``plan``, in plan order (elements without steps are feasible)."""
    out = []
    for e in plan.elements:
        steps = plan.steps_for(e.iri)
        bad = next((s for s in steps if not s.feasible and not (s.reason or "").startswith("skipped")),
                   next((s for s in steps if not s.feasible), None))
        if bad is None:
            out.append(ElementVerdict(e.iri, e.label, True))
            continue
        reason = bad.reason or "infeasible (no reason given)"
        pick = _is_pick(bad)
        where = e.storage_pose if pick and e.storage_pose is not None else e.installed_pose
        before = [s.base_pose for s in steps if s.step < bad.step and s.base_pose is not None]
        out.append(ElementVerdict(
            e.iri, e.label, False, bad.step, bad.action_label, bad.skill_id, reason,
            fix_for(reason, pick=pick), (where.x, where.y), before[-1] if before else None))
    return out


def needs_figure(verdict: ElementVerdict) -> bool:
    """An element-specific failure worth a figure (not a robot that does not fit the whole task)."""
    reason = verdict.reason or ""
    return not verdict.feasible and verdict.at is not None and not re.search(
        r"^robot .* (does not fit|has no arm)|^no robot of the knowledge base fits", reason)


def figure_name(verdict: ElementVerdict) -> str:
    """A file name for the element's figure: its label made safe, and the failing step."""
    safe = re.sub(r"[^A-Za-z0-9]+", "-", verdict.label).strip("-") or "element"
    return f"infeasible-step{verdict.step:03d}-{safe}.png" if verdict.step is not None else f"{safe}.png"
