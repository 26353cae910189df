"""Ground-height memory: the last observed ground height of each cell, kept while the cameras no longer see it.

The voxel map decays what it no longer sees (voxels.py), so a low box that passes under the body or behind the
cameras drops out of the maps while the hind feet still have to step over it. Terrain does not move: the memory keeps,
per world-aligned cell (the voxel map's lattice), the last ground height observed there, and fills the cells a scan
leaves unknown with it. A cell observed again is overwritten (observed otherwise wins at once). The memory is a dense
grid that rolls with the voxel map's window (cells leaving the window are dropped), so it is bounded by the window.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray

from planning.terrain.voxels import Columns


class _RollingGrid:
    """A dense grid of remembered values (NaN: none) on a world-aligned lattice, rolled to follow a moving window:
    cells leaving the window are dropped, cells entering it start empty."""

    def __init__(self) -> None:
        self._z: NDArray[np.float64] | None = None
        self._i0 = (0, 0)  # lattice index of cell (0, 0)
        self._res = 0.0

    def _rolled(
        self, origin_xy: tuple[float, float], res: float, shape: tuple[int, ...]
    ) -> NDArray[np.float64]:
        """Gives the grid re-indexed to the window at origin_xy (m) with this resolution (m) and shape (a new, empty
        grid when the resolution or the shape changed)."""
        i0 = (int(round(origin_xy[0] / res)), int(round(origin_xy[1] / res)))
        if self._z is None or self._z.shape != shape or abs(self._res - res) > 1e-12:
            self._z = np.full(shape, np.nan)
        elif i0 != self._i0:
            self._z = _shifted(self._z, i0[0] - self._i0[0], i0[1] - self._i0[1])
        self._i0, self._res = i0, res
        return self._z


class GroundMemory(_RollingGrid):
    """Last observed ground height (m, world) per cell of the columns' lattice; NaN where never observed. With it
    the last bound the free space seen in each column gave its ground (Columns.free_floor_z), kept the same way: the
    shadow past a stone's far edge is carved by the front camera's rays only while the edge lies ahead, and the
    hind feet reach it after the camera has passed."""

    def __init__(self) -> None:
        super().__init__()
        self._free = _RollingGrid()

    @property
    def n_cells(self) -> int:
        """How many cells hold a remembered height."""
        return 0 if self._z is None else int(np.count_nonzero(np.isfinite(self._z)))

    def apply(self, columns: Columns) -> Columns:
        """Stores the columns' observed ground heights and gives the columns with unknown cells filled from memory."""
        g = columns.ground_z
        mem = self._rolled(columns.origin_xy, columns.resolution_m, g.shape)
        seen = np.isfinite(g)
        np.copyto(mem, g, where=seen)
        fill = ~seen & np.isfinite(mem)
        free = columns.free_floor_z
        if free is not None:
            kept = self._free._rolled(columns.origin_xy, columns.resolution_m, g.shape)
            bound = np.isfinite(free)
            np.copyto(kept, free, where=bound)
            remembered = np.isfinite(kept) & ~bound  # bounds this scan did not see again
            if remembered.any():
                columns = dataclasses.replace(columns, free_floor_z=np.where(remembered, kept, free))
        if not fill.any():
            return columns
        return dataclasses.replace(columns, ground_z=np.where(fill, mem, g))


def _shifted(a: NDArray[np.float64], dx: int, dy: int) -> NDArray[np.float64]:
    """Gives a (nx, ny) re-indexed so that new[i, j] = old[i + dx, j + dy]; NaN where old had no cell."""
    nx, ny = a.shape
    out = np.full(a.shape, np.nan)
    sx0, sx1 = max(dx, 0), min(nx + dx, nx)
    sy0, sy1 = max(dy, 0), min(ny + dy, ny)
    if sx0 < sx1 and sy0 < sy1:
        out[sx0 - dx : sx1 - dx, sy0 - dy : sy1 - dy] = a[sx0:sx1, sy0:sy1]
    return out


class OverhangMemory(_RollingGrid):
    """The lowest overhang (m, world z of its underside) seen above each map cell, kept while the sensor no longer
    sees it.

    The cameras see an overhang only from a distance (their rays leave the body at most a little above the
    horizon), and the voxel map forgets what it no longer sees: under a table the top above the body drops out of
    the maps. Overhangs do not move, so the lowest underside seen over each cell of the maps' lattice is kept (a
    dense grid rolling with the maps' window, like GroundMemory) and given back with every scan's maps.
    """

    def apply(
        self, origin_xy: tuple[float, float], resolution_m: float, z_underside: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Stores a scan's overhang undersides ((nx, ny) on the lattice at origin_xy, resolution_m; inf where none)
        and gives the lowest remembered underside per cell (inf where none was ever seen)."""
        z = np.asarray(z_underside, dtype=np.float64)
        mem = self._rolled(origin_xy, float(resolution_m), z.shape)
        seen = np.isfinite(z)
        mem[seen] = np.fmin(mem[seen], z[seen])
        return np.where(np.isfinite(mem), mem, np.inf)
