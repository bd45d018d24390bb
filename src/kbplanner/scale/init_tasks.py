"""A1 for `kbplanner init`: the task types ``init`` can set up, by name -> the knowledge base's task kind.

Kept apart from :mod:`kbplanner.scale.project_init` so that the CLI can list them without importing
ifcopenshell, shapely or the graph libraries (start-up time); :func:`task_specification` (the KB
specification of a task type) imports them when called.
"""

from __future__ import annotations

TASK_TYPES = {"frame-interior-walls": "InteriorWallFraming"}  # init's task types -> KB task kind


def task_specification(task: str) -> str:
    """The KB specification of an init task type or specification id (else :class:`InitError`)."""
    from kbplanner.core.vocab import KBP
    from kbplanner.knowledge.knowledge_base import load_kb
    from kbplanner.scale.init_walls import InitError

    kb = load_kb()
    specs: dict[str, str] = {}  # spec id -> kind local name
    for spec, sid in kb.subject_objects(KBP.specificationId):
        kind = kb.value(spec, KBP.taskKind)
        specs[str(sid)] = str(kind).rsplit("#", 1)[-1] if kind is not None else ""
    supported = set(TASK_TYPES.values())
    if task in TASK_TYPES:
        ids = sorted(s for s, k in specs.items() if k == TASK_TYPES[task])
        if ids:
            return ids[0]
    elif specs.get(task) in supported:
        return task
    names = [
        f"{t} (specifications {', '.join(sorted(s for s, k in specs.items() if k == kind))})"
        for t, kind in TASK_TYPES.items()
    ]
    other = sorted(s for s, k in specs.items() if k not in supported)
    raise InitError(
        f"unknown task type {task!r} for init",
        element="--task",
        fix=f"give one of: {'; '.join(names)}"
        + (
            f"; the knowledge base's other specifications ({', '.join(other)}) have no derivation in init yet"
            if other
            else ""
        ),
    )
