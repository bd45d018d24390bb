"""Figures of a plan's feasibility (``kbplanner plan``, after B4): where an element cannot be installed.

Takes the task storey's occupancy grid, the refined plan and its per-element verdicts
(:mod:`kbplanner.planning.feasibility`); gives PNG bytes (:func:`~kbplanner.analysis.plots.to_png`,
deterministic):

- :func:`element_figure`, one per infeasible element: a top view ``window_m`` wide around the place
  the failing step acts on (the stack for a pick, the installed pose otherwise), with the occupancy
  grid (walls, site objects, the storage), the installed footprints of the elements installed before
  it (blue), the element itself (red: where it lies and where it goes), the robot's base where B4
  last placed it for this element (grey), the circle the arm reaches around the target (the arm's
  reach plus the tool, at any height), and the reason and the fix as text.
- :func:`plan_overview`: the whole storey, every element's installed footprint green (feasible) or
  red (with its label), the storages, and the base poses B4 chose.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Circle
from matplotlib.patches import Polygon as MplPolygon

from kbplanner.analysis.plots import to_png
from kbplanner.planning.base_poses import element_polygon
from kbplanner.planning.feasibility import ElementVerdict
from kbplanner.planning.plan_model import ElementInfo, Plan, Pose2, Pose6
from kbplanner.planning.pose_frames import pose6_matrix
from kbplanner.robot.robot_table import RobotSpec
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import World


def _rect(cx: float, cy: float, yaw: float, length: float, width: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    pts = np.array([[length / 2, width / 2], [-length / 2, width / 2], [-length / 2, -width / 2],
                    [length / 2, -width / 2]])
    return np.asarray(pts @ np.array([[c, s], [-s, c]]) + np.array([cx, cy]))


def _footprint(world: World, e: ElementInfo, pose: Pose6) -> np.ndarray:
    """The element's floor projection at ``pose``: its box in its own frame (from the world) turned by
    the full pose; without the world's box, its local x/y extents centred at the pose."""
    we = world.element(e.iri)
    if we is None or we.local_bounds is None:
        return _rect(pose.x, pose.y, pose.yaw, e.size_m[0], e.size_m[1])
    poly = element_polygon(we.local_bounds, pose6_matrix(pose))
    return np.asarray(poly.exterior.coords)[:-1] if hasattr(poly, "exterior") else _rect(
        pose.x, pose.y, pose.yaw, e.size_m[0], e.size_m[1])


def _grid(ax: Axes, grid: OccupancyGrid) -> None:
    ny, nx = grid.shape
    ox, oy = grid.origin
    ax.imshow(np.where(grid.occupied, 0.2, 1.0), origin="lower", cmap="gray", vmin=0, vmax=1,
              extent=(ox, ox + nx * grid.resolution, oy, oy + ny * grid.resolution), interpolation="nearest")


def _robot(ax: Axes, spec: RobotSpec | None, pose: Pose2, label: str | None) -> None:
    if spec is None:
        ax.plot(pose.x, pose.y, "s", color="dimgray", markersize=5, label=label)
        return
    ax.add_patch(MplPolygon(_rect(pose.x, pose.y, pose.yaw, spec.base.length_m, spec.base.width_m),
                            closed=True, facecolor="lightgray", edgecolor="dimgray", alpha=0.8, label=label))
    ax.annotate("", (pose.x + 0.5 * math.cos(pose.yaw), pose.y + 0.5 * math.sin(pose.yaw)), (pose.x, pose.y),
                arrowprops={"arrowstyle": "->", "color": "dimgray"})


def element_figure(grid: OccupancyGrid, world: World, plan: Plan, verdict: ElementVerdict,
                   spec: RobotSpec | None, *, window_m: float = 8.0) -> bytes:
    """Top view around an infeasible element's failing step (see the module docstring)."""
    assert verdict.at is not None
    fig, ax = plt.subplots(figsize=(7.5, 8.2))
    _grid(ax, grid)
    order = [e.iri for e in plan.elements]
    me = plan.element(verdict.iri)
    installed_before = [plan.element(i) for i in order[:order.index(verdict.iri)]
                        if all(s.feasible for s in plan.steps_for(i))]
    for n, e in enumerate(installed_before):
        ax.add_patch(MplPolygon(_footprint(world, e, e.installed_pose), closed=True, facecolor="#4c72b0",
                                edgecolor="black", alpha=0.7, linewidth=0.5,
                                label="installed before it" if n == 0 else None))
    ax.add_patch(MplPolygon(_footprint(world, me, me.installed_pose), closed=True, facecolor="#d62728",
                            edgecolor="black", alpha=0.8, label="its installed pose"))
    if me.storage_pose is not None:
        ax.add_patch(MplPolygon(_footprint(world, me, me.storage_pose), closed=True, facecolor="none",
                                edgecolor="#d62728", linestyle="--", linewidth=1.2, label="where it lies"))
    pose = me.storage_pose if me.storage_pose is not None and (verdict.at == (me.storage_pose.x,
                                                                              me.storage_pose.y)) else None
    x, y = (np.asarray(_footprint(world, me, pose if pose is not None else me.installed_pose)).mean(axis=0)
            .tolist())  # the element's centre where the failing step acts (its pose may be at its foot)
    if spec is not None and spec.arm is not None:
        ax.add_patch(Circle((x, y), spec.arm.reach_m + spec.tcp_m, fill=False, edgecolor="#ff7f0e",
                            linestyle=":", linewidth=1.2,
                            label="arm reach around the target (at its best height)"))
    if verdict.base_pose is not None:
        _robot(ax, spec, verdict.base_pose, "robot base (B4, earlier step)")
    ax.plot(x, y, "x", color="#d62728", markersize=9, label=f"target of step {verdict.step}")
    half = window_m / 2
    ax.set_xlim(x - half, x + half)
    ax.set_ylim(y - half, y + half)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{verdict.label}: step {verdict.step} ({verdict.skill_id} {verdict.action}) infeasible",
                 fontsize=9)
    text = "\n".join(textwrap.wrap(f"why: {verdict.reason}", 110)[:6]
                     + textwrap.wrap(f"fix: {verdict.fix}", 110))
    fig.text(0.02, 0.01, text, fontsize=6.5, va="bottom", ha="left", family="monospace")
    ax.legend(loc="upper left", fontsize=6.5, framealpha=0.85)
    fig.subplots_adjust(bottom=0.2, top=0.95)
    return to_png(fig)


def plan_overview(grid: OccupancyGrid, world: World, plan: Plan, verdicts: Sequence[ElementVerdict]) -> bytes:
    """The storey with every element green (installable) or red (not, labelled) and B4's base poses."""
    fig, ax = plt.subplots(figsize=(9, 7.5))
    _grid(ax, grid)
    ok = {v.iri: v.feasible for v in verdicts}
    seen: set[str] = set()
    for e in plan.elements:
        good = ok.get(e.iri, True)
        key = "installable" if good else "not installable"
        ax.add_patch(MplPolygon(_footprint(world, e, e.installed_pose), closed=True,
                                facecolor="#2ca02c" if good else "#d62728",
                                edgecolor="#2ca02c" if good else "#d62728", alpha=0.9,
                                linewidth=2.0, label=key if key not in seen else None))
        seen.add(key)
        if not good:
            ax.annotate(e.label, (e.installed_pose.x, e.installed_pose.y), fontsize=6, color="#d62728",
                        xytext=(3, 3), textcoords="offset points")
    lying = [e for e in plan.elements if e.storage_pose is not None]
    for n, e in enumerate(lying):
        assert e.storage_pose is not None
        ax.add_patch(MplPolygon(_footprint(world, e, e.storage_pose), closed=True, facecolor="none",
                                edgecolor="#8c564b", linewidth=0.8, label="storage (elements lying)" if n == 0
                                else None))
    bases = [s.base_pose for s in plan.steps if s.base_pose is not None and s.feasible]
    pts = [(e.installed_pose.x, e.installed_pose.y) for e in plan.elements]
    pts += [(e.storage_pose.x, e.storage_pose.y) for e in lying if e.storage_pose is not None]
    pts += [(b.x, b.y) for b in bases]
    if pts:  # the part of the storey where the task happens, 3 m around it
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        ax.set_xlim(min(xs) - 3.0, max(xs) + 3.0)
        ax.set_ylim(min(ys) - 3.0, max(ys) + 3.0)
    if bases:
        ax.plot([b.x for b in bases], [b.y for b in bases], ".", color="black", markersize=3,
                label="base poses (B4)")
    bad = sum(1 for v in verdicts if not v.feasible)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"plan of {plan.task_id} ({plan.scenario or 'bare model'}): "
                 f"{len(verdicts) - bad} of {len(verdicts)} elements installable", fontsize=9)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, framealpha=0.85)
    fig.tight_layout()
    return to_png(fig)
