"""Min / max filters over 2D grids with square and disk footprints, in whole-array numpy operations.

The maps (maps.py) filter 133 × 133 grids a dozen times a scan; scipy.ndimage's filters walk the grid line by line
with a buffer copy per line, several times slower than a handful of whole-array ``np.minimum`` / ``np.maximum`` on
shifted views at this size. Min and max are exact (no rounding), so these give the same values as ndimage's
``minimum_filter`` / ``maximum_filter`` (``mode="nearest"`` or ``"constant"``) and, on booleans, as
``binary_erosion`` / ``binary_dilation``; tests/terrain/test_terrain_gridops.py checks that on random grids.

A 1D window of width w takes ⌈log2 w⌉ + 1 operations (doubling: the extremum over 2 cells, over 4, ... then two
overlapping spans); a disk is the union of its rows, each a centred 1D window, so it takes one 1D filter per distinct
row width plus one operation per row.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

Op = Callable[..., Any]


def _pad(a: NDArray[Any], r: int, axis: int, cval: Any, spare_row: bool = False) -> NDArray[Any]:
    """Gives the 2D grid `a` padded by r cells at both ends of `axis`: edge values (cval None) or cval; with
    spare_row (axis 1), one more row (a copy of the last) below, so shifts along the flat grid stay in it."""
    n0, n1 = a.shape
    if axis == 0:
        out = np.empty((n0 + 2 * r, n1), dtype=a.dtype)
        out[r : r + n0] = a
        if cval is None:
            out[:r] = a[0]
            out[r + n0 :] = a[-1]
        else:
            out[:r] = cval
            out[r + n0 :] = cval
    else:
        full = np.empty((n0 + int(spare_row), n1 + 2 * r), dtype=a.dtype)
        out = full[:n0]
        out[:, r : r + n1] = a
        if cval is None:
            out[:, :r] = a[:, :1]
            out[:, r + n1 :] = a[:, -1:]
        else:
            out[:, :r] = cval
            out[:, r + n1 :] = cval
        if spare_row:
            full[n0:] = out[-1:]
            return full
    return out


def pad2(a: NDArray[Any], r: int, cval: Any = None) -> NDArray[Any]:
    """Gives the 2D grid `a` padded by r cells on every side: edge values (cval None; np.pad's mode="edge", the
    corners their corner cell) or cval (mode="constant"). The same grid as np.pad, without its generic set-up
    (several times its copies' cost on the maps' grids)."""
    n0, n1 = a.shape
    out = np.empty((n0 + 2 * r, n1 + 2 * r), dtype=a.dtype)
    out[r : r + n0, r : r + n1] = a
    if r == 0:
        return out
    if cval is None:
        out[:r, r : r + n1] = a[0]
        out[r + n0 :, r : r + n1] = a[-1]
        out[:, :r] = out[:, r : r + 1]
        out[:, r + n1 :] = out[:, r + n1 - 1 : r + n1]
    else:
        out[:r] = cval
        out[r + n0 :] = cval
        out[r : r + n0, :r] = cval
        out[r : r + n0, r + n1 :] = cval
    return out


def window_1d(a: NDArray[Any], width: int, axis: int, op: Op, cval: Any = None) -> NDArray[Any]:
    """Gives the extremum (op: np.minimum or np.maximum) over a centred window of odd `width` along `axis` (0 or 1)
    of a 2D grid; beyond the ends the edge value repeats (cval None, ndimage's mode="nearest") or cval stands
    (mode="constant")."""
    if width % 2 != 1 or width < 1:
        raise ValueError(f"window_1d: width must be odd and positive, got {width}")
    r = width // 2
    if r == 0:
        return a.copy()
    n = a.shape[axis]
    m = _pad(a, r, axis, cval, spare_row=axis == 1)
    span = 1
    # m[i] becomes the extremum of the padded cells i .. i + span - 1 (doubling span while it fits the window).
    if axis == 0:
        while 2 * span <= width:
            m = op(m[:-span], m[span:])
            span *= 2
        # The window of cell i is padded cells i .. i + 2r: two spans that overlap.
        out: NDArray[Any] = op(m[:n], m[width - span : width - span + n])
        return out
    # Along rows, on the flat padded grid (contiguous, several times faster than strided 2D views): the window of
    # a row's cell never reaches past its row's padding, so what wraps into the next row is never read; the spare
    # row keeps the shifted flat grid at least as long as the grid.
    n0 = m.shape[0] - 1
    w1 = m.shape[1]
    f = m.reshape(-1)
    while 2 * span <= width:
        f = op(f[:-span], f[span:])
        span *= 2
    lo = width - span
    g = op(f[: f.shape[0] - lo], f[lo:])
    # g[k] is the window starting at flat padded cell k: row i's cells start at i * w1.
    out = g[: n0 * w1].reshape(n0, w1)[:, :n]
    return out


def square_filter(a: NDArray[Any], size: int, op: Op, cval: Any = None) -> NDArray[Any]:
    """Gives the extremum over a centred size × size square (odd size); edges as in window_1d."""
    return window_1d(window_1d(a, size, 0, op, cval), size, 1, op, cval)


_ROWS: dict[tuple[tuple[int, ...], bytes], tuple[int, ...]] = {}


def _row_halves(footprint: NDArray[np.bool_]) -> tuple[int, ...]:
    """Gives each footprint row's half width (its run is the centred 2h + 1 cells); made once per footprint."""
    fp = np.asarray(footprint, dtype=bool)
    key = (fp.shape, fp.tobytes())
    halves = _ROWS.get(key)
    if halves is not None:
        return halves
    k = fp.shape[0]
    if fp.ndim != 2 or k % 2 != 1 or fp.shape[1] != k:
        raise ValueError(f"disk_filter: footprint must be square with an odd side, got shape {fp.shape}")
    r = k // 2
    out: list[int] = []
    for row in fp:
        w = int(np.count_nonzero(row))
        if w == 0 or w % 2 != 1 or not row[r - w // 2 : r + w // 2 + 1].all():
            raise ValueError("disk_filter: every footprint row must be one run centred on the middle column")
        out.append(w // 2)
    halves = _ROWS[key] = tuple(out)
    return halves


def _row_windows(a: NDArray[Any], halves: set[int], op: Op, cval: Any = None) -> dict[int, NDArray[Any]]:
    """Gives window_1d(a, 2h + 1, 1, op, cval) for every half width h in halves, from one padded grid and one
    doubling chain (a window's extremum is exact, whatever the order it is taken in: the same values)."""
    widths = sorted(halves)
    r = widths[-1]
    out: dict[int, NDArray[Any]] = {}
    if r == 0:
        return {0: a.copy()}
    n = a.shape[1]
    m = _pad(a, r, 1, cval, spare_row=True)
    n0 = m.shape[0] - 1
    w1 = m.shape[1]
    f = m.reshape(-1)
    span = 1
    chain = {1: f}  # span -> the extremum of the flat padded cells k .. k + span - 1
    while 2 * span <= 2 * r + 1:
        f = op(f[:-span], f[span:])
        span *= 2
        chain[span] = f
    for h in widths:
        if h == 0:
            out[0] = a.copy()
            continue
        width = 2 * h + 1
        s = 1 << (width.bit_length() - 1)  # the largest span within the window
        g = chain[s]
        off = r - h  # the window of cell j starts at padded cell j + off
        lo = off + width - s
        total = n0 * w1
        w = op(g[off : off + total], g[lo : lo + total])
        out[h] = w.reshape(n0, w1)[:, :n]
    return out


def disk_filter(a: NDArray[Any], footprint: NDArray[np.bool_], op: Op, cval: Any = None) -> NDArray[Any]:
    """Gives the extremum over a centred footprint whose rows are centred runs (a disk, a cross, a square); edges
    as in window_1d. Raises ValueError for any other footprint."""
    return disk_filters(a, (footprint,), op, cval)[0]


def disk_filters(
    a: NDArray[Any], footprints: tuple[NDArray[np.bool_], ...], op: Op, cval: Any = None
) -> list[NDArray[Any]]:
    """Gives disk_filter(a, footprint, op, cval) for each of the footprints, from one set of row windows (one
    padded grid, one doubling chain, one window per distinct row width of them all)."""
    halves = [_row_halves(fp) for fp in footprints]
    windows = _row_windows(a, {h for half in halves for h in half}, op, cval)
    n = a.shape[0]
    outs: list[NDArray[Any]] = []
    for half in halves:
        r = len(half) // 2
        # Row x: the extremum over footprint rows i (offset d = i - r) of the row windows' row x + d, the edge row
        # (cval None) or cval beyond the grid. The centre row first, then each other row over the rows it reaches
        # on the grid, then over the rows it reaches past the edge. Those last add nothing with edge values where
        # the rows narrow away from the centre (a disk: a nearer, wider row's window holds the edge row's cells),
        # and are left out there.
        out: NDArray[Any] = np.array(windows[half[r]])
        skip_edge = cval is None and _narrowing(half)
        for i, h in enumerate(half):
            d = i - r
            if d == 0:
                continue
            w = windows[h]
            k = min(abs(d), n)  # rows past the edge
            if d > 0:
                if k < n:
                    op(out[: n - k], w[k:], out=out[: n - k])
                past, edge = out[n - k :], w[n - 1]
            else:
                if k < n:
                    op(out[k:], w[: n - k], out=out[k:])
                past, edge = out[:k], w[0]
            if not skip_edge:
                op(past, edge if cval is None else cval, out=past)
        outs.append(out)
    return outs


def _narrowing(half: tuple[int, ...]) -> bool:
    """Gives whether the rows' half widths never grow away from the centre row, on either side."""
    r = len(half) // 2
    return all(half[r + d] >= half[r + d + 1] and half[r - d] >= half[r - d - 1] for d in range(r))


_INDICES: dict[tuple[int, int], tuple[NDArray[np.int32], NDArray[np.int32]]] = {}


def _indices(shape: tuple[int, int]) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    """Gives np.indices(shape) as int32 (read-only, made once per shape)."""
    ij = _INDICES.get(shape)
    if ij is None:
        i, j = np.indices(shape, dtype=np.int32)
        i.flags.writeable = False
        j.flags.writeable = False
        ij = _INDICES[shape] = (i, j)
    return ij


def distance_transform(mask: NDArray[np.bool_], edge: bool = False) -> NDArray[np.float64]:
    """Gives ndimage.distance_transform_edt(mask) of a 2D grid (per True cell the Euclidean distance in cells to
    the nearest False cell, 0 on False cells); edge: the cells just beyond the grid count as False too (the same as
    the transform of the grid padded by a False cell on every side, without the padding).

    The same squared distances as ndimage's (integers: its feature transform is exact, whichever cell it picks among
    equidistant ones), summed in int32 and rooted once, where ndimage goes through float64 copies of the offsets
    (~20 % less time on the maps' 133 × 133 grids). The transform runs on the grid or its transpose, whichever has
    fewer rows holding a False cell: its second pass, along each row, weighs the nearest False cell of every column
    that holds one, and runs ~1.2–1.4× faster with fewer of those columns (the stairs' regions: their edges run
    across the map's rows). The edge is added afterwards: the nearest cell beyond the grid lies straight out from a
    cell, so its squared distance is the least of (i + 1)², (n0 - i)², (j + 1)², (n1 - j)²."""
    mask = np.asarray(mask, dtype=bool)
    n0, n1 = (int(v) for v in mask.shape)
    free = ~mask
    rows_free = int(np.count_nonzero(free.any(axis=1)))
    if rows_free == 0:
        if not edge:
            # No False cell to measure to: the feature transform's indices are undefined (ours would give NaN);
            # ndimage's own answer for this case, so the maps match it whatever the grid holds.
            return np.asarray(ndimage.distance_transform_edt(mask), dtype=np.float64)
        d2 = _edge_squared((n0, n1)).copy()
    else:
        cols_free = int(np.count_nonzero(free.any(axis=0)))
        if rows_free < cols_free:
            d2 = np.ascontiguousarray(_squared_distances(np.ascontiguousarray(mask.T)).T)
        else:
            d2 = _squared_distances(mask)
        if edge:
            np.minimum(d2, _edge_squared((n0, n1)), out=d2)
    return np.sqrt(d2, dtype=np.float64)


def _squared_distances(mask: NDArray[np.bool_]) -> NDArray[np.int32]:
    """Gives per cell the squared distance (cells²) to the nearest False cell of a grid holding one, from ndimage's
    feature transform."""
    shape = (int(mask.shape[0]), int(mask.shape[1]))
    ft = np.empty((2, *shape), np.int32)
    ndimage.distance_transform_edt(mask, return_distances=False, return_indices=True, indices=ft)
    i, j = _indices(shape)
    d2 = ft[0]
    d2 -= i
    d2 *= d2
    dj = ft[1]
    dj -= j
    dj *= dj
    d2 += dj
    return d2


_EDGE: dict[tuple[int, int], NDArray[np.int32]] = {}


def _edge_squared(shape: tuple[int, int]) -> NDArray[np.int32]:
    """Gives per cell the squared distance (cells²) to the nearest cell just beyond the grid (read-only, made once
    per shape)."""
    e = _EDGE.get(shape)
    if e is None:
        i, j = _indices(shape)
        e = np.minimum(np.minimum(i + 1, shape[0] - i), np.minimum(j + 1, shape[1] - j))
        e *= e
        e.flags.writeable = False
        _EDGE[shape] = e
    return e
