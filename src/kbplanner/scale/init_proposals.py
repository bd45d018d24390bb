"""``kbplanner init`` (issue 10), step 4-5: the storage proposals of a scenario, each checked, the best kept.

For one scenario (``storage-inside`` or ``storage-outside``) up to :data:`PROPOSALS` placements of the frame
storages are tried (:func:`kbplanner.scale.init_storage.place_storages`): the first as before (nearest the
panels or the entrance), each next one with its stacks :data:`~.init_storage.AVOID_M` away from those tried
and, outside, :data:`KEEP_STEP_M` farther from the entrance door (room for the robot to turn the frame
before the door). Each is written into the staged project, checked with the pickup checks of ``kbplanner
world`` (:func:`kbplanner.world.site_checks.check_pickup_locations`) and planned as ``kbplanner plan`` plans
it (:mod:`.init_plan_check`); the first that installs every frame, else the one that installs the most, is
kept (when each frame a proposal cannot install has no free base pose near its installed pose and no storage
stands near it, :func:`placement_bound`, the restack rounds below are tried on it first, and other
placements only when they do not install every frame), written with the order B4 found as its
``kbp:workSequence`` (the stacks follow it: the first installed on top). The elements its plan cannot
install are returned with reason and fix. When the kept proposal leaves elements uninstallable, it is
planned again in init's stack-by-stack order (the walls farthest from the entrance first, in a stack the
panel farthest from its pickup on top: :func:`storages_at`) and that order kept when it installs more. When
the kept proposal then leaves elements blocked by those installed before them, B4's install-order feedback
(:func:`~kbplanner.planning.install_order.blocked_move`) is applied without the stack's limit, as init lays
the stacks: the element is moved before them and laid higher in its stack, and kept when the plan installs
more (:data:`RESTACK_ROUNDS` rounds); so is an element whose way back to the pickup an element installed
before closes (:func:`next_move`).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from urllib.parse import quote

from shapely.geometry import Polygon

from kbplanner.core.errors import KbplannerError
from kbplanner.model.project_data import ProjectData
from kbplanner.planning.install_order import blocked_move, move_before
from kbplanner.planning.pose_search import RefineSettings
from kbplanner.scale import init_site as site
from kbplanner.scale.init_floor import with_floor
from kbplanner.scale.init_ifc import FrameRecord
from kbplanner.scale.init_plan_check import Failure, ScenarioCheck, check_scenario, pickup_blocker
from kbplanner.scale.init_storage import ENTRANCE_KEEP, Spot, place_storages
from kbplanner.world.build import world_of
from kbplanner.world.maps import storey_map
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.site_checks import check_pickup_locations

PROPOSALS = 3  # storage placements tried per scenario when the plan of the first does not hold
KEEP_STEP_M = 1.5  # each next outside proposal keeps its stacks this much farther from the entrance
MAX_STACK = 8  # frames per stack: the top one stays within the arm's reach
RESTACK_ROUNDS = 2  # plans again with a blocked element laid higher in its stack, per proposal

Say = Callable[[str], None]


@dataclass(frozen=True)
class Place:
    """Where a scenario's storages may go (the arguments of :func:`place_storages` for it)."""

    key: str
    label: str
    inside: bool
    near: tuple[float, float]
    entrance: tuple[float, float] | None


@dataclass
class Proposal:
    """The proposal kept for a scenario: its storages, its check (None: not checked), what was tried."""

    storages: list[site.Storage]
    check: ScenarioCheck | None
    tried: list[str] = field(default_factory=list)  # one line per proposal tried


def _far_first(pickup: tuple[float, float, float], r: FrameRecord) -> tuple[float, int]:
    return (-round(math.hypot(r.spot.x - pickup[0], r.spot.y - pickup[1]), 4), r.sequence)


def storages_at(key: str, spots: Sequence[Spot], frames: Sequence[FrameRecord],
                z: float) -> list[site.Storage]:
    """The frames stacked on the storages at ``spots``: :data:`MAX_STACK` each, in init's order; in a
    stack the panel farthest from its pickup on top (the ones installed last stand nearest the place
    where the robot turns with the next frame)."""
    out = []
    for i, sp in enumerate(spots):
        chunk = sorted(frames[i * MAX_STACK : (i + 1) * MAX_STACK], key=partial(_far_first, sp.pickup))
        out.append(site.Storage(f"{key}-{i + 1}", f"Frame storage {i + 1} ({key})", sp.x, sp.y, z, sp.yaw,
                                (sp.pickup[0], sp.pickup[1], z, sp.pickup[2]), tuple(chunk)))
    return out


def iri_of(base: str, gid: str) -> str:
    return f"{base}element/{quote(gid, safe='')}"


def restacked(storages: Sequence[site.Storage], order: Sequence[str]) -> list[site.Storage]:
    """``storages`` with each stack in ``order`` (GlobalIds, first installed first: on top)."""
    pos = {g: i for i, g in enumerate(order)}
    return [site.Storage(s.key, s.label, s.x, s.y, s.z, s.yaw, s.pickup,
                         tuple(sorted(s.panels, key=lambda r: pos.get(r.global_id, len(pos)))))
            for s in storages]


def _tell(say: Say, key: str, k: int, _label: str, done: int, total: int) -> None:
    say(f"B4 of {key}, proposal {k + 1}: {done}/{total}")


#: An install failure another storage placement cannot mend, when no storage stands near the installed
#: pose: no free base pose at all (the walls and the elements installed before cover the floor there).
UNBOUND = "no base pose near the installed pose is free"
UNBOUND_WHY = (f"each frame it cannot install fails with '{UNBOUND}' and no storage stands near its "
               "installed pose: the order may mend that, another place of the storage rarely does")


def placement_bound(got: ScenarioCheck, storages: Sequence[site.Storage]) -> bool:
    """Whether a failure of the checked proposal may depend on where its storages stand: any failure but
    an install with no free base pose near the installed pose (:data:`UNBOUND`), or such a one with a
    storage or its pickup location within B4's blocking radius (plus the storage's half diagonal) of
    the installed pose. Placements are tried again only then (the order is tried afterwards)."""
    if got.plan is None:
        return True
    radius = RefineSettings().blocking_radius_m + math.hypot(*site.STORAGE_SIZE[:2]) / 2
    for f in got.failures:
        if UNBOUND not in f.reason or "install" not in _step(f.reason):
            return True
        pose = got.plan.element(f.iri).installed_pose
        if any(math.hypot(x - pose.x, y - pose.y) <= radius
               for st in storages for x, y in ((st.x, st.y), st.pickup[:2])):
            return True
    return False


def _failing(got: ScenarioCheck) -> str:
    """`` (not: F004 at install frame, ...)``: the elements a checked proposal cannot install and the
    step each fails at."""
    if not got.failures:
        return ""
    return " (not: " + ", ".join(f"{f.label.rsplit(' ', 1)[-1]} at {_step(f.reason)}"
                                 for f in got.failures) + ")"


def _step(reason: str) -> str:
    """``step 28 (MM-R-1 install frame): ...`` -> ``install frame``; a reason of the pickup way ->
    ``the way to the pickup``."""
    if reason.startswith("step ") and "(" in reason:
        inner = reason.split("(", 1)[1].split(")", 1)[0]
        return inner.split(" ", 1)[-1]
    return "the way to the pickup" if "pickup" in reason.split(":", 1)[0] else reason.split(":", 1)[0]


def _beat(best: tuple[list[site.Storage], ScenarioCheck | None] | None) -> int | None:
    """What a next proposal must install more than to be kept: the best's installable count (None: no
    checked proposal yet, so the check runs to the end)."""
    return None if best is None or best[1] is None else best[1].installable


def _outcome(got: ScenarioCheck) -> str:
    """``installs 12 of 14``, or why its B4 was abandoned."""
    return got.abandoned or f"installs {got.installable} of {got.total}"


def _summary(k: int, spots: Sequence[Spot], what: str) -> str:
    where = ", ".join(f"({s.x:.2f}, {s.y:.2f})" for s in spots)
    return f"proposal {k + 1} (storages at {where}): {what}"


def propose(
    stage: Path,
    base: str,
    place: Place,
    *,
    grid: OccupancyGrid,
    stacks: int,
    start: tuple[float, float],
    panels: Sequence[tuple[float, float]],
    hull: Polygon,
    frames: Sequence[FrameRecord],
    z: float,
    seed: int,
    check: bool,
    write_toml: Callable[[str, str], None],
    say: Say,
    notes: list[str],
) -> Proposal | None:
    """The kept proposal of scenario ``place.key``, written at ``scenarios/<key>.ttl`` in ``stage``
    (module docstring); None (the file removed, a note why) when no placement has room or passes the
    pickup checks. ``write_toml(key, rel)`` lists the scenario in the staged project.toml."""
    rel = f"scenarios/{place.key.replace('-', '_')}.ttl"
    path = stage / rel
    path.parent.mkdir(exist_ok=True)
    gid_of = {iri_of(base, r.global_id): r.global_id for r in frames}
    tried: list[tuple[float, float]] = []
    lines: list[str] = []
    best: tuple[list[site.Storage], ScenarioCheck | None] | None = None
    last_problem = ""
    restacked_best: list[site.Storage] | None = None  # the storages the restack rounds were tried on
    for k in range(PROPOSALS if check else 1):
        keep = ENTRANCE_KEEP + (0.0 if place.inside else k * KEEP_STEP_M)
        spots = place_storages(grid, stacks, start=start, panels=panels, footprint=hull,
                               inside=place.inside, near=place.near, entrance=place.entrance,
                               entrance_keep=keep, avoid=tried)
        if len(spots) < stacks:
            last_problem = f"room for {len(spots)} of {stacks} frame storages found on the task storey's map"
            if k == 0:
                break
            lines.append(f"proposal {k + 1}: {last_problem}")
            continue
        tried += [(s.x, s.y) for s in spots]
        storages = storages_at(place.key, spots, frames, z)
        path.write_text(site.scenario(base, place.key, place.label, storages, [] if check else None),
                        encoding="utf-8")
        write_toml(place.key, rel)
        say(f"checking the pickup locations of {place.key} (proposal {k + 1}) on its world")
        data = ProjectData.load(stage, scenario=place.key)
        world = world_of(data, task_id=site.FRAME_TASK)
        grid_k = storey_map(world).grid
        try:
            check_pickup_locations(world, grid_k)
        except KbplannerError as exc:  # a proposal that does not hold is dropped, with the reason
            last_problem = exc.problem
            lines.append(_summary(k, spots, f"dropped: {exc.problem}"))
            continue
        if not check:
            best = (storages, None)
            break
        say(f"planning {place.key} (proposal {k + 1}) as `kbplanner plan` does (B1-B4)")
        got = check_scenario(stage, place.key, site.FRAME_TASK, seed, partial(_tell, say, place.key, k),
                             (data, world, grid_k), beat=_beat(best))
        if got.abandoned:  # it cannot install more than the best: neither kept nor laid again
            say(f"{place.key} proposal {k + 1}: {got.abandoned}")
            lines.append(_summary(k, spots, f"plan {got.abandoned}{_failing(got)}"))
            continue
        lines.append(_summary(k, spots, f"plan installs {got.installable} of {got.total}{_failing(got)}"))
        if best is None or best[1] is None or got.installable > best[1].installable:
            best = (storages, got)
        if not got.failures:
            break
        if not placement_bound(got, storages) and restacked_best is None:
            # only the order can mend these: tried on this placement first, the others only if it does not
            lines.append(f"the order tried first: {UNBOUND_WHY}")
            again, fixed, what = _restack(stage, base, place, storages, got, seed, say, path)
            lines += what
            restacked_best = again  # this placement's storages, laid again when that installs more
            if best[1] is None or fixed.installable > best[1].installable:
                best = (again, fixed)
            if not fixed.failures:
                break
    if best is None:
        path.unlink(missing_ok=True)
        notes.append(f"scenario {place.key} not written: {last_problem}")
        return None
    storages, kept = best
    if kept is None:
        path.write_text(site.scenario(base, place.key, place.label, storages), encoding="utf-8")
        return Proposal(storages, None, lines)
    by_stack = [r.global_id for st in storages for r in st.panels]
    if kept.failures and [gid_of.get(i) for i in kept.order] != by_stack:
        # init's own order, stack by stack, may plan more than B1's (nearest first); the same order
        # checked again would plan the same
        path.write_text(site.scenario(base, place.key, place.label, storages), encoding="utf-8")
        say(f"planning {place.key} again in the stack-by-stack order")
        other = check_scenario(stage, place.key, site.FRAME_TASK, seed, beat=kept.installable)
        lines.append(f"the kept proposal in the stack-by-stack order: plan {_outcome(other)}{_failing(other)}"
                     + ("" if other.installable > kept.installable else ", not kept"))
        if other.installable > kept.installable:
            kept = other
    if kept.failures and storages is not restacked_best:  # the stacks laid again for the elements
        # blocked by those installed before them (not again where the loop above tried it)
        storages, kept, what = _restack(stage, base, place, storages, kept, seed, say, path)
        lines += what
    got = kept
    order = [gid_of[i] for i in got.order if i in gid_of]
    storages = restacked(storages, order)
    note = "\n".join(["Checked by `kbplanner init` as `kbplanner plan` checks it (B1-B4, and the robot's",
                      "way to each pickup location):", *lines])
    path.write_text(site.scenario(base, place.key, place.label, storages, order or None, note),
                    encoding="utf-8")
    write_toml(place.key, rel)
    if any(UNBOUND in f.reason for f in got.failures):  # what takes the floor there, on the kept world
        world = world_of(ProjectData.load(stage, scenario=place.key), task_id=site.FRAME_TASK)
        got = replace(got, failures=with_floor(world, storey_map(world), got.failures, UNBOUND))
    return Proposal(storages, got, lines)


def next_move(got: ScenarioCheck, radius: float, tried: set[tuple[str, str]]) -> tuple[str, str] | None:
    """The next (element, before) move for a checked proposal: B4's install-order feedback
    (:func:`~kbplanner.planning.install_order.blocked_move`, on the plan with init's own work sequence
    taken off: init lays the stacks and writes the sequence), else an element whose way back to the
    pickup an element installed before it closes (:func:`~.init_plan_check.pickup_blocker`) goes before
    that one."""
    assert got.plan is not None
    plan = copy.copy(got.plan)
    plan.elements = [replace(e, work_sequence=None) for e in got.plan.elements]
    move = blocked_move(plan, plan, {}, radius, tried)
    if move is not None:
        return move
    order = [e.iri for e in plan.elements]
    for f in got.failures:
        named = pickup_blocker(f.reason)
        if (named is not None and f.iri in order and named in order[:order.index(f.iri)]
                and (f.iri, named) not in tried):
            return f.iri, named
    return None


def _restack(stage: Path, base: str, place: Place, storages: list[site.Storage], got: ScenarioCheck,
             seed: int, say: Say, path: Path) -> tuple[list[site.Storage], ScenarioCheck, list[str]]:
    """B4's install-order feedback without the stack's limit (init lays the stacks): an element blocked
    by elements installed before it (:func:`~kbplanner.planning.install_order.blocked_move`) is moved
    before them and laid higher in its stack; kept when the plan installs more (at most
    :data:`RESTACK_ROUNDS` rounds)."""
    tried: set[tuple[str, str]] = set()
    what: list[str] = []
    radius = RefineSettings().blocking_radius_m
    gid_of = {iri_of(base, r.global_id): r.global_id for s in storages for r in s.panels}
    for n in range(RESTACK_ROUNDS):
        if not got.failures or got.plan is None:
            break
        move = next_move(got, radius, tried)
        if move is None:
            break
        tried.add(move)
        order = [gid_of[e.iri] for e in move_before(got.plan, *move).elements if e.iri in gid_of]
        again = restacked(storages, order)
        path.write_text(site.scenario(base, place.key, place.label, again, order), encoding="utf-8")
        say(f"planning {place.key} again with {move[0].rsplit('/', 1)[-1]} laid higher (round {n + 1})")
        new = check_scenario(stage, place.key, site.FRAME_TASK, seed, beat=got.installable)
        labels = {e.iri: e.label for e in got.plan.elements}
        what.append(f"the kept proposal with {labels.get(move[0], move[0])} installed before "
                    f"{labels.get(move[1], move[1])} (laid higher in its stack): plan {_outcome(new)}"
                    f"{_failing(new)}"
                    + ("" if new.installable > got.installable else ", not kept"))
        if new.installable > got.installable:
            storages, got = again, new
    return storages, got, what


def failures_text(key: str, failures: Sequence[Failure]) -> list[str]:
    """One line per element the kept proposal of ``key`` cannot install: label, reason, fix."""
    return [f"{key}: {f.label}: {f.reason}. Fix: {f.fix}" for f in failures]
