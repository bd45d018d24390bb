"""Configuration space build (B3 fit checks, B4 carry legs, B5 navigation): footprint kernels and the
FFT correlation that turns an occupancy grid into one free map per yaw bin.

:meth:`kbplanner.world.footprint.ConfigurationSpace.build` calls :func:`free_maps`; the kernels
(:func:`rasterised_kernel`: the footprint swept over a yaw bin, grown by half a cell each side and
a margin) and their distinct set per footprint (:func:`kernel_set`) are kept for the process. The
free maps are exact: a cell of bin ``k`` is free when no occupied cell and no cell off the grid lies
under bin ``k``'s kernel (the FFT's sums of cells are rounded far below the 0.5 they are compared with;
tests/test_cspace_unpadded.py compares with a binary dilation and with the build before session 11).
Since session 15 the transforms are as long as the grid (:func:`transform_shape`) and a kernel that is
another's turned over (a yaw bin half a turn or mirrored from another's, :attr:`KernelSet.mirror`) takes
that one's transform read backwards or conjugated (:func:`hits_many`).

Example:
    >>> from kbplanner.world.footprint import Rect
    >>> occ = np.zeros((20, 30), dtype=bool); occ[:, 20] = True
    >>> free = free_maps(occ, (Rect(0, 0, 0.5, 0.3),), 0.05, 8, 0.0)
    >>> free.shape, bool(free[0, 10, 10]), bool(free[0, 10, 19])
    ((8, 20, 30), True, False)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol, TypeVar

import numpy as np
import numpy.typing as npt
from scipy import fft as sp_fft

BoolArray = npt.NDArray[np.bool_]
_S = TypeVar("_S", bound=np.generic)


class Rect(Protocol):
    """What is read of a :class:`kbplanner.world.footprint.Rect` here."""

    @property
    def cx(self) -> float: ...
    @property
    def cy(self) -> float: ...
    @property
    def length(self) -> float: ...
    @property
    def width(self) -> float: ...
    @property
    def yaw(self) -> float: ...
    def corners(self, yaw: float = 0.0) -> npt.NDArray[np.float64]: ...
    def __hash__(self) -> int: ...

_SUB_ANGLE_RAD = math.radians(0.5)  # sweep step when covering a yaw bin


def kernel_half_size(rects: tuple[Rect, ...], resolution: float, margin_m: float) -> int:
    """Half the side (cells) of every kernel of a footprint, whatever its yaw interval: the kernel of
    :meth:`Footprint.kernel` has shape (2h+1, 2h+1)."""
    radius = float(max(np.hypot(*r.corners().T).max() for r in rects))  # Footprint.radius_m
    return math.ceil((radius + resolution + margin_m) / resolution) + 1


@functools.lru_cache(maxsize=4096)
def rasterised_kernel(rects: tuple[Rect, ...], resolution: float, yaw_lo: float, yaw_hi: float,
                      margin_m: float) -> BoolArray:
    """:meth:`Footprint.kernel` (read-only), memoised: a navigation rebuilds configuration spaces for
    the same footprints (robot, robot + load in each carry mode) on many windows of the map.

    The union of each rectangle's cells (:func:`_rect_cells`, memoised per rectangle: the robot's base
    is a rectangle of every carry footprint, rasterised once per yaw bin for all of them)."""
    h = kernel_half_size(rects, resolution, margin_m)
    out = np.zeros((2 * h + 1, 2 * h + 1), dtype=bool)
    for r in rects:
        cells = _rect_cells(r, resolution, yaw_lo, yaw_hi, margin_m)
        if cells is not None:
            dy0, dx0, inside = cells
            out[h + dy0:h + dy0 + inside.shape[0], h + dx0:h + dx0 + inside.shape[1]] |= inside
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=8192)
def _rect_cells(r: Rect, resolution: float, yaw_lo: float, yaw_hi: float, margin_m: float
                ) -> tuple[int, int, BoolArray] | None:
    """The cells one rectangle of a footprint covers over a yaw interval, as (dy0, dx0, mask): the mask's
    first row and column at those offsets (cells) from the robot's cell; None when it covers none.

    Each cell's value is the very float ``xx - cx`` etc. of a meshgrid gives: a cell's offset is
    ``(integer offset) * resolution`` whatever the kernel's size, so a rectangle's cells do not depend on
    the other rectangles of its footprint (tests/test_footprint_kernel.py compares with the loop over a
    meshgrid)."""
    grow = resolution + margin_m
    n_sub = max(2, math.ceil((yaw_hi - yaw_lo) / _SUB_ANGLE_RAD) + 1)
    h = kernel_half_size((r,), resolution, margin_m)  # the rectangle's own reach covers its cells
    offs = np.arange(-h, h + 1) * resolution
    eps = 1e-9
    # A rectangle grown by an axis-aligned square (Minkowski sum of two centrally symmetric convex
    # polygons) is exactly the intersection of four slabs: along the rectangle's two axes and along
    # x and y, each as wide as the two shapes' support functions added. Every sub-angle at once, on
    # the box of cells its x and y slabs leave: the scalars as one float each (Python floats,
    # math.cos/sin), the cells' offsets along x and y as vectors broadcast against each other.
    cxs, cys, uxs, uys, t1, t2, t3, t4 = ([] for _ in range(8))
    hl, hw = r.length / 2, r.width / 2
    for yaw in np.linspace(yaw_lo, yaw_hi, n_sub):
        c, s = math.cos(float(yaw)), math.sin(float(yaw))
        a = float(yaw) + r.yaw
        ux, uy = math.cos(a), math.sin(a)
        cxs.append(c * r.cx - s * r.cy)
        cys.append(s * r.cx + c * r.cy)
        uxs.append(ux)
        uys.append(uy)
        t1.append(hl + grow * (abs(ux) + abs(uy)) + eps)
        t2.append(hw + grow * (abs(uy) + abs(ux)) + eps)
        t3.append(hl * abs(ux) + hw * abs(uy) + grow + eps)
        t4.append(hl * abs(uy) + hw * abs(ux) + grow + eps)
    cx, cy = np.array(cxs)[:, None], np.array(cys)[:, None]
    uxa, uya = np.array(uxs)[:, None, None], np.array(uys)[:, None, None]
    in_x = np.abs(offs[None, :] - cx) <= np.array(t3)[:, None]  # (sub-angle, column)
    in_y = np.abs(offs[None, :] - cy) <= np.array(t4)[:, None]  # (sub-angle, row)
    cols, rows = np.nonzero(in_x.any(axis=0))[0], np.nonzero(in_y.any(axis=0))[0]
    if not len(cols) or not len(rows):
        return None
    x0, x1, y0, y1 = int(cols[0]), int(cols[-1]) + 1, int(rows[0]), int(rows[-1]) + 1
    dx = (offs[None, x0:x1] - cx)[:, None, :]  # (sub-angle, 1, column): the floats of xx - cx
    dy = (offs[None, y0:y1] - cy)[:, :, None]  # (sub-angle, row, 1)
    inside = np.abs(dx * uxa + dy * uya) <= np.array(t1)[:, None, None]
    inside &= np.abs(-dx * uya + dy * uxa) <= np.array(t2)[:, None, None]
    inside &= in_x[:, None, x0:x1]
    inside &= in_y[:, y0:y1, None]
    mask = inside.any(axis=0)
    mask.setflags(write=False)
    return y0 - h, x0 - h, mask


#: Complex cells (frequency rows x columns x bins) transformed at once by a build (512 kB: in the caches)
BATCH_CELLS = 64 * 1024

#: How a distinct kernel is another's turned over (:attr:`KernelSet.mirror`): its rows reversed (the
#: footprint mirrored across the robot's x axis), its columns reversed, or both (half a turn)
ROWS, COLUMNS, BOTH = 1, 2, 3


@dataclass(frozen=True)
class KernelSet:
    """The kernels of every yaw bin of a footprint, as :func:`free_maps` correlates them:
    ``flipped[j]`` the j-th distinct kernel turned half a turn (all ``2h+1`` square), ``index[k]``
    bin ``k``'s distinct kernel, ``first[j]`` the first bin of kernel ``j``."""

    h: int
    flipped: BoolArray
    index: npt.NDArray[np.intp]
    #: per distinct kernel, the offsets (dy0, dy1, dx0, dx1) of its first and last rows and columns
    #: that hold a cell, from the robot's cell ((0, -1, 0, -1) for an empty kernel: nothing to block)
    extents: tuple[tuple[int, int, int, int], ...]
    first: tuple[int, ...]
    #: per distinct kernel ``j``, ``(i, how)`` when it is an earlier distinct kernel ``i`` with its rows,
    #: columns or both reversed (:data:`ROWS`, :data:`COLUMNS`, :data:`BOTH`, cell for cell: a kernel of
    #: a yaw bin half a turn or mirrored from another's), its transform then read off ``i``'s; else
    #: ``(-1, 0)``
    mirror: tuple[tuple[int, int], ...] = ()

    def bin_extents(self) -> tuple[tuple[int, int, int, int], ...]:
        """:attr:`extents` of every yaw bin's kernel."""
        return tuple(self.extents[j] for j in self.index)


@functools.lru_cache(maxsize=64)
def kernel_set(rects: tuple[Rect, ...], resolution: float, n_bins: int, margin_m: float) -> KernelSet:
    width = 2 * math.pi / n_bins
    kernels = [rasterised_kernel(rects, resolution, k * width - width / 2, k * width + width / 2, margin_m)
               for k in range(n_bins)]
    h = max(k.shape[0] for k in kernels) // 2
    size = 2 * h + 1
    seen: dict[tuple[tuple[int, ...], bytes], int] = {}
    index = np.empty(n_bins, dtype=np.intp)
    flipped: list[BoolArray] = []
    first: list[int] = []
    extents: list[tuple[int, int, int, int]] = []
    own: dict[bytes, int] = {}  # the kernels transformed for themselves
    mirror: list[tuple[int, int]] = []
    for k, kern in enumerate(kernels):
        j = seen.setdefault((kern.shape, kern.tobytes()), len(flipped))
        index[k] = j
        if j == len(flipped):
            hk = kern.shape[0] // 2
            full = np.zeros((size, size), dtype=bool)
            first.append(k)
            full[h - hk : h + hk + 1, h - hk : h + hk + 1] = kern
            f = np.ascontiguousarray(full[::-1, ::-1])
            flipped.append(f)
            rows, cols = np.nonzero(kern)
            extents.append((int(rows.min()) - hk, int(rows.max()) - hk, int(cols.min()) - hk,
                            int(cols.max()) - hk) if len(rows) else (0, -1, 0, -1))
            turned = ((own.get(f[::-1, ::-1].tobytes()), BOTH), (own.get(f[::-1].tobytes()), ROWS),
                      (own.get(f[:, ::-1].tobytes()), COLUMNS))
            i, how = next(((i, how) for i, how in turned if i is not None), (-1, 0))
            mirror.append((i, how))
            if i < 0:
                own[f.tobytes()] = j
    stack = np.stack(flipped)
    stack.setflags(write=False)
    index.setflags(write=False)
    return KernelSet(h=h, flipped=stack, index=index, extents=tuple(extents), first=tuple(first),
                     mirror=tuple(mirror))


def free_maps(occupied: BoolArray, rects: tuple[Rect, ...], resolution: float, n_yaw_bins: int,
              margin_m: float) -> BoolArray:
    """``free[bin, iy, ix]``: whether the footprint of ``rects`` at cell (ix, iy), any yaw of the bin
    (bin ``k`` covers [k*w - w/2, k*w + w/2], w = 2*pi / n_yaw_bins), any position in the cell, is
    clear of every occupied cell of ``occupied`` and of the cells off it."""
    kset = kernel_set(rects, resolution, n_yaw_bins, margin_m)
    ny, nx = occupied.shape
    free = np.empty((n_yaw_bins, ny, nx), dtype=bool)
    # Correlation by FFT of the grid (its transform computed once for all bins, the kernels all of one
    # size) with each bin's kernel: hits < 0.5 means no occupied cell of the grid under the swept
    # footprint. Cells off the grid count as occupied: a cell is also blocked where the kernel's extent
    # (its first and last rows and columns that hold a cell) leaves the grid - the very cells that a
    # correlation of the grid padded with h occupied cells all round blocks for them (the build before
    # session 11; tests/test_cspace_unpadded.py). The transform is circular and only as long as the grid
    # (transform_shape): a wrapped-around term only reaches cells whose kernel leaves the grid, blocked
    # anyway (see hits_many).
    if ny and nx:
        shape = transform_shape(ny, nx)
        rows_f = sp_fft.rfft(occupied.astype(np.float32), n=shape[1], axis=1)
        grid_f = sp_fft.fft(rows_f, n=shape[0], axis=0, overwrite_x=True)
        # one free map per distinct kernel (e.g. a centrally symmetric footprint half a turn later has
        # the same), written in its first bin and copied to the others
        for j, hits in kernel_hits(grid_f, kset, shape, (0, ny), (0, nx)):
            k = kset.first[j]
            np.less(hits, 0.5, out=free[k])
            block_off_grid(free[k : k + 1], kset.extents[j : j + 1])
        for k, j in enumerate(kset.index):
            if kset.first[j] != k:
                free[k] = free[kset.first[j]]
    return free


def block_off_grid(free: BoolArray, extents: Sequence[tuple[int, int, int, int]]) -> None:
    """Block, in place, the cells of each map ``free[j]`` whose kernel (``extents[j]``, as
    :class:`KernelSet` keeps them) reaches off the grid: what cells off the grid counted as occupied
    give."""
    ny, nx = free.shape[1:]
    for j, (dy0, dy1, dx0, dx1) in enumerate(extents):
        y0, y1, x0, x1 = max(0, -dy0), min(ny, ny - dy1), max(0, -dx0), min(nx, nx - dx1)
        if y0 >= y1 or x0 >= x1:
            free[j] = False
            continue
        free[j, :y0] = False
        free[j, y1:] = False
        free[j, :, :x0] = False
        free[j, :, x1:] = False


def transform_shape(ny: int, nx: int) -> tuple[int, int]:
    """The lengths of the circular transforms :func:`free_maps` correlates a grid of ``ny x nx`` cells
    with: each at least the grid's own (not the grid plus a kernel's reach): a term wrapped around
    comes from a cell ``n`` or more rows or columns away, under the kernel only of cells whose kernel
    reaches off the grid, which :func:`block_off_grid` blocks anyway."""
    return (sp_fft.next_fast_len(ny, real=True), sp_fft.next_fast_len(nx, real=True))


def kernel_hits(grid_f: npt.NDArray[np.complex64], kset: KernelSet, shape: tuple[int, int],
                rows: tuple[int, int], cols: tuple[int, int]
                ) -> Iterator[tuple[int, npt.NDArray[np.float32]]]:
    """``(j, hits)`` for every distinct kernel ``j`` of ``kset``: :func:`hits_many` of the grid whose
    transform is ``grid_f`` (``shape``), its rows ``rows[0] ..`` (``rows[1]`` of them) and columns
    ``cols[0] ..``. A few kernels per call (about :data:`BATCH_CELLS` complex cells), each with the
    kernels turned over from it (:attr:`KernelSet.mirror`): their transforms are its own read
    backwards or conjugated."""
    m, nh = shape[0], shape[1] // 2 + 1
    step = max(1, BATCH_CELLS // (m * nh))
    groups: dict[int, list[int]] = {}
    for j, (i, _how) in enumerate(kset.mirror or [(-1, 0)] * len(kset.flipped)):
        groups.setdefault(j if i < 0 else i, []).append(j)
    batches: list[list[int]] = [[]]
    for group in groups.values():
        if batches[-1] and len(batches[-1]) + len(group) > step:
            batches.append([])
        batches[-1].extend(group)
    work = np.empty((max(len(b) for b in batches), m, nh), dtype=np.complex64)  # reused: no new pages
    for batch in batches:
        hits = hits_many(grid_f, kset, batch, shape, rows, cols, work)
        yield from zip(batch, hits, strict=True)


def _centred(src: npt.NDArray[_S], h: int, dst: npt.NDArray[_S], axis: int) -> None:
    """Write ``src``'s entries ``u`` along ``axis`` (a kernel's ``2h + 1`` rows or columns) into ``dst``
    at ``(u - h) mod length``, the kernel's centre at 0, adding those a length apart (a transform
    shorter than the kernel); ``dst``'s other entries 0."""
    size, length = src.shape[axis], dst.shape[axis]

    def at(sl: slice) -> tuple[slice, ...]:
        return (slice(None),) * axis + (sl,)

    if size <= length:
        dst[at(slice(h + 1, length - h))] = 0
        dst[at(slice(0, h + 1))] = src[at(slice(h, size))]
        dst[at(slice(length - h, length))] = src[at(slice(0, h))]
    else:  # folded: entries a length apart added, then turned by h
        reps = -(-size // length)
        wide = np.zeros((*src.shape[:axis], reps * length, *src.shape[axis + 1:]), dtype=src.dtype)
        wide[at(slice(0, size))] = src
        folded = wide.reshape((*src.shape[:axis], reps, length, *src.shape[axis + 1:])).sum(axis=axis)
        dst[...] = np.roll(folded, -h, axis=axis)


def hits_many(grid_f: npt.NDArray[np.complex64], kset: KernelSet, js: Sequence[int], shape: tuple[int, ...],
              rows: tuple[int, int], cols: tuple[int, int],
              work: npt.NDArray[np.complex64] | None = None) -> npt.NDArray[np.float32]:
    """How many occupied cells of the grid each of the distinct kernels ``js`` of ``kset`` covers at
    each cell: ``hits[n, y, x]`` for the grid's rows ``rows[0] .. rows[0] + rows[1] - 1`` and columns
    likewise, ``grid_f`` the grid's transform (``shape``, unpadded). The circular correlation with each
    kernel placed with its centre at cell (0, 0) (:func:`_centred`), each transform along one axis of
    the stack, the two passes of each 2-D transform done by hand so that only rows that hold something
    are transformed along x: the kernel's ``2h + 1`` rows (the others are zero) and, back, the rows kept.
    A kernel that is an earlier one of ``js`` turned over (:attr:`KernelSet.mirror`; centred, the same
    kernel reflected through cell 0) takes that one's transform with the frequencies' rows reversed
    and/or conjugated: the same spectrum, to rounding. ``work``: an array of at least (len(js),
    shape[0], shape[1] // 2 + 1) to transform in (a fresh one costs its pages each time). Counts of
    cells; the rounding (float32) stays far below the 0.5 they are compared with
    (tests/test_cspace_unpadded.py).

    A cell's count is exact where the kernel, from it, stays on the grid transformed (each cell under it
    at most ``n - 1`` rows or columns away: nothing wraps around); :func:`free_maps` blocks the others
    (:func:`block_off_grid`), whatever their counts. (:func:`kbplanner.world.cspace_join.part_free`
    transforms a grid grown by the kernels' reach all round and keeps the cells inside.)"""
    n, h = len(js), kset.h
    m, nh = shape[0], shape[1] // 2 + 1
    if work is None or work.shape[0] < n or work.shape[1:] != (m, nh):
        work = np.empty((n, m, nh), dtype=np.complex64)
    spec = work[:n]
    mirror = kset.mirror or [(-1, 0)] * len(kset.flipped)
    slot = {j: s for s, j in enumerate(js)}
    own = [s for s, j in enumerate(js) if mirror[j][0] < 0 or mirror[j][0] not in slot]
    if own:
        kern = np.empty((len(own), 2 * h + 1, shape[1]), dtype=np.float32)
        _centred(kset.flipped[[js[s] for s in own]], h, kern, 2)
        rows_f = sp_fft.rfft(kern, axis=2)
        if len(own) == n:
            _centred(rows_f, h, spec, 1)
            spec = sp_fft.fft(spec, axis=1, overwrite_x=True)
        else:
            part = np.empty((len(own), m, nh), dtype=np.complex64)
            _centred(rows_f, h, part, 1)
            spec[own] = sp_fft.fft(part, axis=1, overwrite_x=True)
    backwards = (-np.arange(m)) % m  # the frequencies' rows of a kernel with its rows reversed
    for s, j in enumerate(js):
        i, how = mirror[j]
        if i < 0 or i not in slot:
            continue
        if how == BOTH:
            np.conjugate(spec[slot[i]], out=spec[s])
        else:
            np.take(spec[slot[i]], backwards, axis=0, out=spec[s])
            if how == COLUMNS:
                np.conjugate(spec[s], out=spec[s])
    spec *= grid_f
    back = sp_fft.ifft(spec, axis=1, overwrite_x=True)[:, rows[0] : rows[0] + rows[1]]
    out: npt.NDArray[np.float32] = sp_fft.irfft(back, n=shape[1], axis=2, overwrite_x=True)
    return out[:, :, cols[0] : cols[0] + cols[1]]
