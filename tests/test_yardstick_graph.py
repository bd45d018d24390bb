"""B5 navigation's yardstick (simulation layer): the grid graph built in CSR form directly
(``grid_yardstick._graph``) holds, row by row, the row of the matrix the former
``csr_matrix((costs, (rows, cols)))`` construction made and then the row of its transpose (what scipy's
undirected Dijkstra scans per node), so its directed Dijkstra returns the same distances and
predecessors as the undirected one on the former matrix: the same cells and lengths."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import sparse
from scipy.sparse import csgraph

from kbplanner.simulation import grid_yardstick


def _former_graph(free: np.ndarray) -> tuple[np.ndarray, sparse.csr_matrix]:
    ny, nx = free.shape
    index = np.full(free.shape, -1, dtype=np.int64)
    flat = np.flatnonzero(free)
    index.ravel()[flat] = np.arange(len(flat))
    rows, cols, costs = [], [], []
    for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = index[0 : ny - dy, max(0, -dx) : nx - max(0, dx)]
        b = index[dy:ny, max(0, dx) : nx - max(0, -dx)]
        both = (a >= 0) & (b >= 0)
        rows.append(a[both])
        cols.append(b[both])
        costs.append(np.full(int(both.sum()), math.hypot(dy, dx)))
    r, c, w = np.concatenate(rows), np.concatenate(cols), np.concatenate(costs)
    n = len(flat)
    return index, sparse.csr_matrix((w, (r, c)), shape=(n, n))


def _free(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    ny, nx = int(rng.integers(1, 90)), int(rng.integers(1, 140))
    free = rng.random((ny, nx)) > [0.05, 0.3, 0.6][seed % 3]
    for _ in range(5):
        y, x = rng.integers(0, ny), rng.integers(0, nx)
        free[y : y + rng.integers(1, 20), x : x + rng.integers(1, 4)] = False
    return free


def _both_rows(graph: sparse.csr_matrix) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row the graph's entries, then its transpose's (``graph.T.tocsr()``, as scipy's undirected
    Dijkstra builds it): ``indptr``, ``indices``, ``data``."""
    tr = graph.T.tocsr()
    indptr, indices, data = [0], [], []
    for v in range(graph.shape[0]):
        for g in (graph, tr):
            a, b = g.indptr[v], g.indptr[v + 1]
            indices += g.indices[a:b].tolist()
            data += g.data[a:b].tolist()
        indptr.append(len(indices))
    return np.array(indptr), np.array(indices, dtype=np.int64), np.array(data)


@pytest.mark.parametrize("seed", range(12))
def test_the_graph_is_the_former_matrix_both_ways_and_dijkstra_answers_alike(seed: int) -> None:
    free = _free(seed)
    index, graph = grid_yardstick._graph(free)
    index0, graph0 = _former_graph(free)
    assert np.array_equal(index, index0)
    assert graph.shape == graph0.shape
    indptr, indices, data = _both_rows(graph0)
    assert np.array_equal(graph.indptr, indptr)
    assert np.array_equal(graph.indices, indices)
    assert np.array_equal(graph.data, data)
    if graph.shape[0] < 2:
        return
    rng = np.random.default_rng(seed)
    for src in rng.integers(0, graph.shape[0], 3).tolist():
        d, p = csgraph.dijkstra(graph, directed=True, indices=src, return_predecessors=True)
        d0, p0 = csgraph.dijkstra(graph0, directed=False, indices=src, return_predecessors=True)
        assert np.array_equal(d, d0) and np.array_equal(p, p0)


def test_lengths_on_a_grid_with_a_wall_and_a_gap() -> None:
    occ = np.zeros((40, 60), dtype=bool)
    occ[:30, 30] = True  # a wall with a gap at the top
    free = ~occ
    cells = grid_yardstick._dijkstra_cells(free, (5, 5), (5, 55))
    assert cells is not None and cells[0] == (5, 5) and cells[-1] == (5, 55)
    assert max(y for y, _ in cells) >= 30  # through the gap
    assert all(free[y, x] for y, x in cells)
    assert all(max(abs(a - c), abs(b - d)) == 1 for (a, b), (c, d) in itertools.pairwise(cells))
    assert grid_yardstick._dijkstra_cells(free, (5, 5), (5, 5)) == [(5, 5)]
    occ[30:, 30] = True  # the gap closed
    assert grid_yardstick._dijkstra_cells(~occ, (5, 5), (5, 55)) is None
