"""Plots render to PNG deterministically from plain data."""

from __future__ import annotations

import numpy as np

from kbplanner.analysis.plots import (
    GanttBar,
    LayoutObject,
    distance_over_time,
    gantt,
    grouped_bars,
    site_layout,
)
from kbplanner.world.occupancy import OccupancyGrid

PNG = b"\x89PNG\r\n\x1a\n"


def test_every_plot_is_a_png_and_the_same_data_gives_the_same_bytes() -> None:
    occ = np.zeros((40, 60), dtype=bool)
    occ[10:30, 20] = True
    grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.1)
    objs = [LayoutObject("Storage", "MaterialStorage", 1.0, 1.0, 1.0, 0.5)]
    robot = np.array([[0.5, 0.5], [3.0, 2.0], [5.0, 3.5]])
    workers = {"Carpenter 1": np.array([[5.0, 0.5], [4.0, 3.0]])}
    a = site_layout(grid, objs, robot, workers, title="layout", marks=[("stop", 3.0, 2.0)])
    b = site_layout(grid, objs, robot, workers, title="layout", marks=[("stop", 3.0, 2.0)])
    assert a.startswith(PNG) and a == b
    t = np.arange(0.0, 600.0, 1.0)
    d = distance_over_time(
        t,
        {"Carpenter 1": 3 + np.sin(t / 60)},
        {"1 m": 1.0, "ISO/TS 15066": np.full(600, 2.1)},
        title="distance",
    )
    assert d.startswith(PNG)
    g = gantt(
        [GanttBar("F01", "navigate", 0, 60), GanttBar("F01", "pick", 60, 90, ok=False)], title="actions"
    )
    assert g.startswith(PNG)
    bars = grouped_bars({"outside": {"F01": 250.0}, "inside": {"F01": 200.0}}, title="per frame", ylabel="s")
    assert bars.startswith(PNG)
