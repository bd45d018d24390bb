"""B4, the carry leg: joins asked of parts of a window, decided there where they can be (the same answers).

:class:`~kbplanner.planning.carry_reach.CarryReach` asks whether a carry footprint joins two poses on a
window of the map (the navigation's "walled off" test), and whether the start and a goal share a joint
component of both carry footprints (the load turned at a standstill where both fit). Labelling a whole
window (up to 72 x 635 x 618 cells) for each is the costly part; :class:`WindowParts` asks a part of the
window around the poses first (:class:`~kbplanner.world.cspace_join.PartJoin`: exact free cells, their
own labels): joined in a part is joined on the window; a component that does not reach the part's rim
is the window's. Only what the parts leave open goes to the whole window. :func:`joint_components`
joins the labels of several footprints on one grid (the whole window's or a part's).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence

import numpy as np
import numpy.typing as npt

from kbplanner.planning.plan_model import Pose2
from kbplanner.world.cspace_join import PartJoin
from kbplanner.world.footprint import Footprint
from kbplanner.world.occupancy import OccupancyGrid

#: Whether a footprint joins two poses is first asked of a part of the window around them, grown by
#: this many cells (:class:`~kbplanner.world.cspace_join.PartJoin`: the same answer where it decides,
#: without building and labelling the whole window); a second part, twice as wide, also around the
#: goals' centre; at most :data:`PARTS_PER_SPACE` parts per window and footprint, then the whole window.
PART_MARGIN_CELLS = 30
PARTS_PER_SPACE = 2
#: joint_components marks the label pairs of two footprints in an array of this many keys at most
DENSE_PAIR_KEYS = 1 << 24


def joint_components(parts: Sequence[tuple[npt.NDArray[np.int32], npt.NDArray[np.int64]]]
                     ) -> tuple[tuple[int, ...], npt.NDArray[np.int64]]:
    """Components of free cells of several footprints on one grid, joined where a cell is free for two.

    ``parts``: per footprint, the 26-connected labels with the yaw ring and their roots
    (:meth:`~kbplanner.world.footprint.ConfigurationSpace.labels_and_roots`, the navigation's "walled
    off" test). A graph whose nodes are every footprint's labels and whose edges join the labels of two
    footprints that share a free cell (the robot may change from one footprint to the other standing
    still there). Returns (node offset per footprint, joint component per node).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    offsets = []
    n_nodes = 0
    for _lab, root in parts:
        offsets.append(n_nodes)
        n_nodes += len(root)
    edges = [np.zeros((0, 2), dtype=np.int64)]
    for i in range(len(parts)):
        for j in range(i + 1, len(parts)):
            (li, ri), (lj, rj) = parts[i], parts[j]
            keys = _label_pairs(li, len(ri), lj, len(rj))
            a = ri[keys // len(rj)] + offsets[i]
            b = rj[keys % len(rj)] + offsets[j]
            edges.append(np.stack([a, b], axis=1))
    e = np.concatenate(edges)
    graph = coo_matrix((np.ones(len(e), dtype=np.int8), (e[:, 0], e[:, 1])), shape=(n_nodes, n_nodes))
    _, joint = connected_components(graph, directed=False)
    return tuple(offsets), np.asarray(joint, dtype=np.int64)


def _label_pairs(li: npt.NDArray[np.int32], ni: int, lj: npt.NDArray[np.int32],
                 nj: int) -> npt.NDArray[np.int64]:
    """The distinct pairs of non-zero labels (``li < ni``, ``lj < nj``) on the same cell, as sorted keys
    ``li * nj + lj``: marked per key in a boolean array (labels are few; cheaper than counting them)
    where the keys fit :data:`DENSE_PAIR_KEYS`, else the unique keys of the cells free in both (the same
    keys)."""
    if ni * nj <= DENSE_PAIR_KEYS:
        # keys below DENSE_PAIR_KEYS < 2**31: no overflow in int32
        keys = np.multiply(li, nj, dtype=np.int32)
        keys += lj
        seen = np.zeros((ni, nj), dtype=bool)
        seen.reshape(-1)[keys.ravel()] = True
        seen[0, :] = False  # label 0: not free
        seen[:, 0] = False
        return np.flatnonzero(seen).astype(np.int64)
    both = (li > 0) & (lj > 0)
    return np.unique(li[both].astype(np.int64) * nj + lj[both])


class WindowParts:
    """The parts of a carry-leg check's windows (``window(i)``), per window and footprint, kept.

    ``around`` is the (x, y) the goals lie near (a wider part is cut around it too).
    """

    def __init__(self, window: Callable[[int], OccupancyGrid], footprints: Sequence[Footprint],
                 around: tuple[float, float], n_bins: int) -> None:
        self.window = window
        self.footprints = tuple(footprints)
        self.around = around
        self.n_bins = n_bins
        self.parts: dict[tuple[int, int], list[PartJoin]] = {}
        # joint components of the parts of the first window on the same cells, per (y0, y1, x0, x1)
        self.joints: dict[tuple[int, int, int, int], tuple[tuple[int, ...], npt.NDArray[np.int64]]] = {}

    def joins(self, i: int, k: int, a: Pose2, b: Pose2) -> bool | None:
        """Whether footprint ``k`` joins ``a`` and ``b`` on window ``i``, as the window's configuration
        space says; None where no part decides."""
        pa, pb = (a.x, a.y, a.yaw), (b.x, b.y, b.yaw)
        for part in self.parts_for(i, k, a, b):
            got = part.joined(pa, pb)
            if got is not None:
                return got
        return None

    def parts_for(self, i: int, k: int, a: Pose2, b: Pose2) -> Iterator[PartJoin]:
        """Parts of window ``i`` holding ``a`` and ``b`` for footprint ``k``: those kept, then new ones
        while fewer than :data:`PARTS_PER_SPACE` were made (the first around them, the next wider and
        around the goals' centre too, so that later goals fall in it)."""
        pa, pb = (a.x, a.y, a.yaw), (b.x, b.y, b.yaw)
        parts = self.parts.setdefault((i, k), [])
        yield from [p for p in parts if p.holds(pa) and p.holds(pb)]
        while len(parts) < PARTS_PER_SPACE:
            points = [(a.x, a.y), (b.x, b.y)] + ([self.around] if parts else [])
            part = PartJoin(self.window(i), self.footprints[k], points, diagonal=True, n_bins=self.n_bins,
                            margin_cells=PART_MARGIN_CELLS * (1 + len(parts)))
            parts.append(part)
            yield part

    def part_like(self, i: int, k: int, like: PartJoin) -> PartJoin:
        """Footprint ``k``'s part of window ``i`` on the cells of ``like`` (kept)."""
        parts = self.parts.setdefault((i, k), [])
        part = next((p for p in parts if p.region == like.region), None)
        if part is None:
            part = PartJoin(self.window(i), self.footprints[k], [], margin_cells=0, diagonal=True,
                            n_bins=self.n_bins, region=like.region)
            parts.append(part)
        return part

    def reaches(self, start: Pose2, goal: Pose2) -> bool:
        """Whether the start and ``goal`` share a joint component on a part of the first window around
        them (then they do on the window), without labelling the window."""
        return any(self._pair_joins(first, start, goal) for first in self.parts_for(0, 0, start, goal))

    def _pair_joins(self, first: PartJoin, start: Pose2, goal: Pose2) -> bool:
        """Whether the start and ``goal`` share a joint component on the cells of part ``first``."""
        parts: list[tuple[npt.NDArray[np.int32], npt.NDArray[np.int64], PartJoin]] = []
        for k in range(len(self.footprints)):
            part = first if k == 0 else self.part_like(0, k, first)
            if part.labels is None or part.roots is None:
                return False
            parts.append((part.labels, part.roots, part))
        key = first.region
        got = self.joints.get(key)
        if got is None:
            got = joint_components([(lab, roots) for lab, roots, _p in parts])
            self.joints[key] = got
        offsets, joint = got

        def component(pose: Pose2) -> int:
            q = (pose.x, pose.y, pose.yaw)
            for (_lab, _roots, p), off in zip(parts, offsets, strict=True):
                c = p.component(q) if p.holds(q) else 0
                if c:
                    return int(joint[off + c]) + 1
            return 0

        there = component(goal)
        return there > 0 and there == component(start)
