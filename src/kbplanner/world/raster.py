"""Occupancy maps, rasterising (helper of ``occupancy``, A6 world): triangles and sections onto a grid.

Takes triangles (site frame, metres) and a boolean grid; marks the cells they overlap within a
height band (clipping each triangle to the band, then a separating axis test per cell), and the
cells inside a mesh's horizontal section. A section whose outline cannot be turned into polygons
(self-intersecting or degenerate geometry: trimesh's "unable to recover polygon!") is not fatal:
the cells enclosed by the mesh's own outline on the grid are filled instead, and the caller is told.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
from scipy import ndimage

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]

_CELL_TOL = 1e-9  # in cells: touching a cell border is not overlapping it
_PAIRS_PER_CHUNK = 2_000_000


# --------------------------------------------------------------------------------------------
# Rasterising triangles within a height band
# --------------------------------------------------------------------------------------------


def clip(polys: FloatArray, counts: npt.NDArray[np.int64], value: float, keep_above: bool
          ) -> tuple[FloatArray, npt.NDArray[np.int64]]:
    """Clip convex polygons (N, K, 3), ``counts`` vertices each, to z >= value (or z <= value)."""
    n, k, _ = polys.shape
    rows = np.arange(n)
    out = np.zeros((n, k + 1, 3))
    m = np.zeros(n, dtype=np.int64)
    sign = 1.0 if keep_above else -1.0
    for i in range(k):
        valid = i < counts
        cur = polys[:, i]
        prev_idx = np.where(i == 0, counts - 1, i - 1)
        prev = polys[rows, np.maximum(prev_idx, 0)]
        cur_in = sign * (cur[:, 2] - value) >= 0
        prev_in = sign * (prev[:, 2] - value) >= 0
        cross = valid & (cur_in != prev_in)
        dz = cur[:, 2] - prev[:, 2]
        t = (value - prev[:, 2]) / np.where(dz == 0, 1.0, dz)
        hit = prev + t[:, None] * (cur - prev)
        hit[:, 2] = value
        idx = rows[cross]
        out[idx, m[idx]] = hit[cross]
        m[idx] += 1
        emit = valid & cur_in
        idx = rows[emit]
        out[idx, m[idx]] = cur[emit]
        m[idx] += 1
    keep = m > 0
    out, m = out[keep], m[keep]
    # Pad with the last vertex so every polygon has k + 1 entries (degenerate edges are harmless).
    last = out[np.arange(len(m)), m - 1]
    pad = np.arange(k + 1)[None, :] >= m[:, None]
    out[pad] = np.repeat(last, k + 1, axis=0).reshape(len(m), k + 1, 3)[pad]
    return out, m


def rasterise(polys: FloatArray, grid: BoolArray, origin: tuple[float, float], res: float) -> None:
    """Mark every cell of ``grid`` overlapped by a convex xy polygon (N, K, 2), padded by repetition."""
    if len(polys) == 0:
        return
    ny, nx = grid.shape
    u = (polys[:, :, 0] - origin[0]) / res  # polygon coordinates in cell units
    v = (polys[:, :, 1] - origin[1]) / res
    ix0 = np.floor(u.min(axis=1) + _CELL_TOL).astype(np.int64)
    ix1 = np.maximum(np.ceil(u.max(axis=1) - _CELL_TOL).astype(np.int64) - 1, ix0)
    iy0 = np.floor(v.min(axis=1) + _CELL_TOL).astype(np.int64)
    iy1 = np.maximum(np.ceil(v.max(axis=1) - _CELL_TOL).astype(np.int64) - 1, iy0)
    ix0, iy0 = np.maximum(ix0, 0), np.maximum(iy0, 0)
    ix1, iy1 = np.minimum(ix1, nx - 1), np.minimum(iy1, ny - 1)
    inside = (ix1 >= ix0) & (iy1 >= iy0)
    u, v, ix0, ix1, iy0, iy1 = u[inside], v[inside], ix0[inside], ix1[inside], iy0[inside], iy1[inside]
    # Edge normals (orientation made counter-clockwise) for the separating axis test.
    du = np.roll(u, -1, axis=1) - u
    dv = np.roll(v, -1, axis=1) - v
    area2 = (u * np.roll(v, -1, axis=1) - np.roll(u, -1, axis=1) * v).sum(axis=1)
    orient = np.where(area2 < 0, -1.0, 1.0)[:, None]
    nu, nv = dv * orient, -du * orient  # outward for CCW polygons
    offset = nu * u + nv * v
    offset[(nu == 0) & (nv == 0)] = 1.0  # zero-length (padding) edges separate nothing
    slack = 0.5 * (np.abs(nu) + np.abs(nv))
    wx = ix1 - ix0 + 1
    counts = wx * (iy1 - iy0 + 1)
    start = 0
    while start < len(counts):
        stop = start + max(1, int(np.searchsorted(np.cumsum(counts[start:]), _PAIRS_PER_CHUNK)))
        sl = slice(start, stop)
        c = counts[sl]
        pid = np.repeat(np.arange(start, stop), c)
        local = np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c)
        cx = ix0[pid] + local % wx[pid]
        cy = iy0[pid] + local // wx[pid]
        cu, cv = cx + 0.5, cy + 0.5
        # A cell is off the polygon when, for some edge, all its corners are strictly outside.
        sep = nu[pid] * cu[:, None] + nv[pid] * cv[:, None] - offset[pid]
        hit = np.all(sep <= slack[pid] - _CELL_TOL, axis=1)
        grid[cy[hit], cx[hit]] = True
        start = stop


def fill_section(mesh: Any, z: float, grid: BoolArray, origin: tuple[float, float], res: float) -> str | None:
    """Mark cells whose centre lies inside the mesh's horizontal section at height ``z``.

    The faces within the band already mark every cell where a vertical line through the band
    crosses the surface; the cells left are those where the line stays inside the solid over the
    whole band, and one section at any height of the band finds exactly those.

    Returns None, or what went wrong when the section could not be made into polygons (the cells
    enclosed by the section's outline are then filled instead).
    """
    lo, hi = np.asarray(mesh.bounds)[:, 2]
    if not lo < z < hi:
        return None
    try:
        path = mesh.section(plane_origin=(0.0, 0.0, z), plane_normal=(0.0, 0.0, 1.0))
        if path is None:
            return None
        planar, to_3d = path.to_2D()
        polygons = list(planar.polygons_full)
    except Exception as exc:  # trimesh/shapely on self-intersecting or degenerate geometry
        fill_from_outline(mesh, z, grid, origin, res)
        return (f"its section at z = {z:.2f} m cannot be made into polygons ({type(exc).__name__}: {exc}); "
                "filled from its outline instead")
    ny, nx = grid.shape
    for poly in polygons:
        poly3 = shapely.transform(poly, lambda uv, m=to_3d: (np.c_[uv, np.zeros(len(uv)), np.ones(len(uv))]
                                                             @ np.asarray(m).T)[:, :2])
        x0, y0, x1, y1 = poly3.bounds
        ix0 = max(0, math.floor((x0 - origin[0]) / res))
        iy0 = max(0, math.floor((y0 - origin[1]) / res))
        ix1 = min(nx - 1, math.floor((x1 - origin[0]) / res))
        iy1 = min(ny - 1, math.floor((y1 - origin[1]) / res))
        if ix1 < ix0 or iy1 < iy0:
            continue
        cx = origin[0] + (np.arange(ix0, ix1 + 1) + 0.5) * res
        cy = origin[1] + (np.arange(iy0, iy1 + 1) + 0.5) * res
        xx, yy = np.meshgrid(cx, cy)
        grid[iy0 : iy1 + 1, ix0 : ix1 + 1] |= shapely.contains_xy(poly3, xx, yy)
    return None


def fill_from_outline(mesh: Any, z: float, grid: BoolArray, origin: tuple[float, float], res: float) -> None:
    """Mark the cells enclosed by the mesh's outline at height ``z`` (the fallback of :func:`fill_section`).

    The triangles crossing ``z`` are clipped to a thin slab around it and rasterised on a window
    of the grid around the mesh; the holes of that outline are filled (``ndimage.binary_fill_holes``).
    """
    ny, nx = grid.shape
    (x0, y0, _), (x1, y1, _) = np.asarray(mesh.bounds)
    ix0 = max(0, math.floor((x0 - origin[0]) / res) - 1)
    iy0 = max(0, math.floor((y0 - origin[1]) / res) - 1)
    ix1 = min(nx - 1, math.floor((x1 - origin[0]) / res) + 1)
    iy1 = min(ny - 1, math.floor((y1 - origin[1]) / res) + 1)
    if ix1 < ix0 or iy1 < iy0:
        return
    tris = np.asarray(mesh.triangles, dtype=np.float64)
    tz = tris[:, :, 2]
    tris = tris[(tz.min(axis=1) <= z) & (tz.max(axis=1) >= z)]
    if len(tris) == 0:
        return
    counts = np.full(len(tris), 3, dtype=np.int64)
    polys, counts = clip(tris, counts, z - 1e-4, keep_above=True)
    polys, counts = clip(polys, counts, z + 1e-4, keep_above=False)
    window = np.zeros((iy1 - iy0 + 1, ix1 - ix0 + 1), dtype=bool)
    rasterise(polys[:, :, :2], window, (origin[0] + ix0 * res, origin[1] + iy0 * res), res)
    grid[iy0 : iy1 + 1, ix0 : ix1 + 1] |= np.asarray(ndimage.binary_fill_holes(window), dtype=bool)
