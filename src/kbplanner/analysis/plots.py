"""Plots (report): site layouts with trajectories, distance over time, action Gantt charts, durations.

Every function takes plain typed data and returns PNG bytes (matplotlib, Agg backend, fixed size and
DPI, no timestamps in the metadata), so the same inputs give the same image and a report can embed it.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import numpy.typing as npt
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as MplPolygon

from kbplanner.world.occupancy import OccupancyGrid

FloatArray = npt.NDArray[np.float64]
_COLOURS = (
    "tab:red",
    "tab:blue",
    "tab:green",
    "tab:purple",
    "tab:brown",
    "tab:pink",
    "tab:olive",
    "tab:cyan",
)
_KIND_COLOURS = {
    "MaterialStorage": "#d9a441",
    "SiteOffice": "#7f7f7f",
    "Equipment": "#8c564b",
    "SafetyFence": "#444444",
    "Workspace": "#9ecae1",
    "TemporaryStructure": "#bcbd22",
    "NoGoZone": "#f4a6a6",
}


@dataclass(frozen=True)
class LayoutObject:
    """A site object drawn on the layout: a box of size (sx, sy) at (x, y) turned by yaw."""

    label: str
    kind: str
    x: float
    y: float
    sx: float
    sy: float
    yaw: float = 0.0


@dataclass(frozen=True)
class GanttBar:
    """One action of the robot: which element, which action, when (s), outcome."""

    element: str
    action: str
    start_s: float
    end_s: float
    ok: bool = True


def to_png(fig: Figure) -> bytes:
    """PNG bytes of a figure (deterministic metadata), closing the figure."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def _box_corners(o: LayoutObject) -> FloatArray:
    hx, hy = o.sx / 2, o.sy / 2
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    pts = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
    return np.asarray(pts @ np.array([[c, s], [-s, c]]) + np.array([o.x, o.y]), dtype=np.float64)


LABEL_LINE = 0.022  # a label's height, as a fraction of the plot's x span (font size 6)
LABEL_CHAR = 0.0075  # a character's width, as a fraction of the plot's x span


def _free_label_spot(placed: Sequence[tuple[float, float, float]], x: float, y: float, half_w: float,
                     line: float) -> tuple[float, float]:
    """Where a label centred at (x, y), ``half_w`` wide each side, overlaps no label placed before:
    moved up, then down, a line at a time, until it is free."""
    for step in (0, 1, -1, 2, -2, 3, -3, 4, -4):
        cy = y + step * line
        if all(abs(x - px) >= half_w + pw or abs(cy - py) >= line for px, py, pw in placed):
            return x, cy
    return x, y


def site_layout(
    grid: OccupancyGrid | None,
    objects: Sequence[LayoutObject],
    robot_xy: FloatArray | None,
    workers: Mapping[str, FloatArray],
    *,
    title: str,
    marks: Sequence[tuple[str, float, float]] = (),
) -> bytes:
    """Top view: occupancy (walls), site objects, the robot's path and each worker's path (metres)."""
    fig, ax = plt.subplots(figsize=(9, 7.5))
    if grid is not None:
        ny, nx = grid.shape
        ox, oy = grid.origin
        ext = (ox, ox + nx * grid.resolution, oy, oy + ny * grid.resolution)
        ax.imshow(
            np.where(grid.occupied, 0.15, 1.0),
            origin="lower",
            extent=ext,
            cmap="gray",
            vmin=0,
            vmax=1,
            interpolation="nearest",
        )
    seen: set[str] = set()
    placed: list[tuple[float, float, float]] = []
    xs = [o.x for o in objects] + ([grid.origin[0], grid.origin[0] + grid.shape[1] * grid.resolution]
                                   if grid is not None else [])
    span = (max(xs) - min(xs)) if len(xs) > 1 else 10.0
    for o in sorted(objects, key=lambda o: (o.y, o.x, o.label)):
        colour = _KIND_COLOURS.get(o.kind, "#cccccc")
        label = o.kind if o.kind not in seen else None
        seen.add(o.kind)
        ax.add_patch(
            MplPolygon(
                _box_corners(o),
                closed=True,
                facecolor=colour,
                edgecolor="black",
                alpha=0.55,
                linewidth=0.6,
                label=label,
            )
        )
        half_w = len(o.label) * LABEL_CHAR * span / 2
        lx, ly = _free_label_spot(placed, o.x, o.y, half_w, LABEL_LINE * span)
        placed.append((lx, ly, half_w))
        ax.annotate(o.label, (lx, ly), fontsize=6, ha="center", va="center",
                    bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "alpha": 0.7, "linewidth": 0})
    for i, (name, xy) in enumerate(sorted(workers.items())):
        if len(xy):
            ax.plot(
                xy[:, 0],
                xy[:, 1],
                "-",
                color=_COLOURS[(i + 1) % len(_COLOURS)],
                linewidth=0.9,
                alpha=0.8,
                label=name,
            )
    if robot_xy is not None and len(robot_xy):
        ax.plot(robot_xy[:, 0], robot_xy[:, 1], "-", color="black", linewidth=1.6, label="robot")
        ax.plot(robot_xy[0, 0], robot_xy[0, 1], "o", color="black", markersize=5)
    for text, x, y in marks:
        ax.plot(x, y, "x", color="red", markersize=7)
        ax.annotate(text, (x, y), fontsize=7, color="red", xytext=(3, 3), textcoords="offset points")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, framealpha=0.85)
    fig.tight_layout()
    return to_png(fig)


def distance_over_time(
    t: FloatArray,
    distances: Mapping[str, FloatArray],
    thresholds: Mapping[str, FloatArray | float],
    *,
    title: str,
    max_distance_m: float = 15.0,
) -> bytes:
    """Robot-to-worker distance (m) over time (min) for each worker, with the threshold lines."""
    fig, ax = plt.subplots(figsize=(9, 4))
    minutes = np.asarray(t, float) / 60.0
    for i, (name, d) in enumerate(sorted(distances.items())):
        ax.plot(
            minutes,
            np.minimum(d, max_distance_m),
            color=_COLOURS[(i + 1) % len(_COLOURS)],
            linewidth=0.9,
            label=name,
        )
    styles = ("--", ":", "-.")
    for j, (name, thr) in enumerate(thresholds.items()):
        arr = np.broadcast_to(np.asarray(thr, float), minutes.shape)
        ax.plot(minutes, arr, styles[j % len(styles)], color="black", linewidth=1.0, label=name)
    ax.set_xlabel("time (min)")
    ax.set_ylabel(f"distance from robot footprint (m, capped at {max_distance_m:g})")
    ax.set_ylim(0, max_distance_m)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    return to_png(fig)


def gantt(bars: Sequence[GanttBar], *, title: str) -> bytes:
    """Robot actions over time: one row per element, one colour per action; failed actions hatched."""
    elements = list(dict.fromkeys(b.element for b in bars))
    actions = list(dict.fromkeys(b.action for b in bars))
    colour = {a: _COLOURS[i % len(_COLOURS)] for i, a in enumerate(actions)}
    fig, ax = plt.subplots(figsize=(11, 0.35 * max(len(elements), 4) + 1.2))
    for b in bars:
        row = elements.index(b.element)
        ax.barh(
            row,
            (b.end_s - b.start_s) / 60.0,
            left=b.start_s / 60.0,
            color=colour[b.action],
            edgecolor="black" if not b.ok else None,
            hatch="//" if not b.ok else None,
            height=0.7,
        )
    ax.set_yticks(range(len(elements)), elements, fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("time (min)")
    ax.set_title(title)
    handles = [plt.Rectangle((0, 0), 1, 1, color=colour[a]) for a in actions]
    ax.legend(handles, actions, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    return to_png(fig)


def grouped_bars(groups: Mapping[str, Mapping[str, float]], *, title: str, ylabel: str) -> bytes:
    """Bars per category (e.g. frame) side by side per group (e.g. scenario)."""
    cats = list(dict.fromkeys(c for g in groups.values() for c in g))
    fig, ax = plt.subplots(figsize=(9, 4))
    width = 0.8 / max(len(groups), 1)
    x = np.arange(len(cats))
    for i, (gname, values) in enumerate(groups.items()):
        ax.bar(
            x + i * width,
            [values.get(c, 0.0) for c in cats],
            width=width,
            label=gname,
            color=_COLOURS[i % len(_COLOURS)],
        )
    ax.set_xticks(x + width * (len(groups) - 1) / 2, cats, rotation=45, ha="right", fontsize=7)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=7)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return to_png(fig)


def seed_strips(panels: Sequence[tuple[str, Mapping[str, Sequence[float]]]], *, title: str) -> bytes:
    """Box and strip plots: one panel per figure, a box per group (e.g. scenario) with every seed's value
    as a point (spread sideways by a fixed pattern, not at random, so the image is reproducible)."""
    n = max(len(panels), 1)
    cols = min(n, 3)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.4 * rows), squeeze=False)
    for k, (label, groups) in enumerate(panels):
        ax = axes[k // cols][k % cols]
        names = list(groups)
        data = [np.asarray(groups[g], dtype=np.float64) for g in names]
        filled = [i for i, d in enumerate(data) if len(d)]
        if filled:
            ax.boxplot([data[i] for i in filled], positions=[i + 1 for i in filled], widths=0.5,
                       showfliers=False, medianprops={"color": "black"})
        for i, d in enumerate(data):
            offsets = ((np.arange(len(d)) % 7) - 3) * 0.04
            ax.scatter(i + 1 + offsets, d, s=14, alpha=0.75, color=_COLOURS[i % len(_COLOURS)], zorder=3)
        ax.set_xticks(range(1, len(names) + 1), names, rotation=20, ha="right", fontsize=7)
        ax.set_xlim(0.4, len(names) + 0.6)
        ax.set_title(label, fontsize=9)
        ax.grid(axis="y", alpha=0.3)
    for k in range(len(panels), rows * cols):
        axes[k // cols][k % cols].axis("off")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return to_png(fig)
