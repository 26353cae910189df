"""Simulated depth sensors: MuJoCo ray casting from cameras fixed on the robot body, with noise.

Each camera is a pinhole-like fan of rays (a grid of azimuth × elevation angles) from a body-relative pose. All rays
of one camera leave one point, so one ``mj_multiRay`` call casts them. The robot's own geoms are excluded: when the
robot's geom groups differ from the terrain's (the usual case: robot collision geoms in group 3, visuals in group 2),
by a geom-group mask, so the robot is transparent; otherwise its hits are dropped after the cast (it then occludes).

Noise: Gaussian range noise of ``noise_m + noise_per_m * range`` (m), plus a small fraction of outliers with a uniform
range error (stereo mismatches), which the voxel filter must remove.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class DepthCamera:
    """One depth camera: pose in the body frame and its ray fan.

    p_body_cam: position in the body frame (m); yaw_deg, pitch_deg: optical axis direction in the body frame (deg;
    pitch positive looks down); h_fov_deg, v_fov_deg: field of view (deg); n_h, n_v: rays across and down.
    """

    name: str
    p_body_cam: tuple[float, float, float]
    yaw_deg: float
    pitch_deg: float
    h_fov_deg: float = 90.0
    v_fov_deg: float = 60.0
    n_h: int = 64
    n_v: int = 48

    def rays_cam(self) -> NDArray[np.float64]:
        """Gives the unit ray directions (n_h*n_v, 3) in the body frame."""
        az = np.radians(np.linspace(-self.h_fov_deg / 2, self.h_fov_deg / 2, self.n_h))
        el = np.radians(np.linspace(-self.v_fov_deg / 2, self.v_fov_deg / 2, self.n_v))
        a, e = np.meshgrid(az, el, indexing="xy")
        # Fan around +x in the camera frame, then pitch down and yaw into the body frame.
        d = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1).reshape(-1, 3)
        p = np.radians(self.pitch_deg)
        y = np.radians(self.yaw_deg)
        R_pitch = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
        R_yaw = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
        return d @ (R_yaw @ R_pitch).T


def _default_cameras() -> tuple[DepthCamera, ...]:
    return (
        DepthCamera("front", (0.45, 0.0, 0.0), 0.0, 35.0, 100.0, 70.0, 80, 60),
        DepthCamera("left", (0.0, 0.13, 0.0), 90.0, 40.0, 100.0, 60.0, 56, 40),
        DepthCamera("right", (0.0, -0.13, 0.0), -90.0, 40.0, 100.0, 60.0, 56, 40),
        DepthCamera("rear", (-0.45, 0.0, 0.0), 180.0, 40.0, 90.0, 60.0, 48, 36),
        # A thin fan just above the horizon: the others all look down, so an overhang a little above the body
        # (a table top to crouch under) would go unseen.
        DepthCamera("front_up", (0.45, 0.0, 0.0), 0.0, -15.0, 100.0, 30.0, 48, 16),
    )


@dataclass(frozen=True)
class SensorParams:
    """Depth sensing. rate_hz: scan rate (Hz); max_range_m: ray cutoff (m); noise_m: range noise floor (m, 1σ);
    noise_per_m: range noise growth per meter of range (1σ); outlier_fraction: share of rays with a gross error;
    outlier_m: half range of that error (m); seed: noise seed; dense_spacing_m: see below."""

    cameras: tuple[DepthCamera, ...] = field(default_factory=_default_cameras)
    rate_hz: float = 10.0
    max_range_m: float = 4.0
    noise_m: float = 0.003
    noise_per_m: float = 0.004
    outlier_fraction: float = 0.002
    outlier_m: float = 0.3
    seed: int = 0
    # Fewer rays where the scan is already dense: a camera's rays on the odd cells of a checkerboard over its fan
    # are left out of a scan where their four neighbours' last ranges × the fan's angular step are all below this
    # spacing (m): the even rays alone sample that surface at about this spacing. 0: every ray every scan.
    dense_spacing_m: float = 0.0


@dataclass(frozen=True, eq=False)
class PointCloud:
    """One scan. p_world_points: (N, 3) hits (m, world); p_world_origins: (N, 3) the camera each ray left (m);
    t_s: sim time of the scan (s)."""

    p_world_points: NDArray[np.float64]
    p_world_origins: NDArray[np.float64]
    t_s: float

    @property
    def size(self) -> int:
        return int(self.p_world_points.shape[0])


class DepthSensor:
    """Casts every camera's rays from the robot body pose in an MjData; holds preallocated buffers.

    model: the compiled MuJoCo model; body: name or id of the body the cameras are fixed to (the robot's root);
    every geom whose body belongs to that body's tree is treated as the robot's own.
    """

    def __init__(self, model: mujoco.MjModel, body: str | int, params: SensorParams | None = None) -> None:
        self.params = params or SensorParams()
        self.model = model
        if isinstance(body, str):
            body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
            if body_id < 0:
                raise ValueError(f"sensor body {body!r} is not in the model")
        else:
            body_id = int(body)
        self.body_id = body_id
        root = model.body_rootid[body_id]
        robot_geom = model.body_rootid[model.geom_bodyid] == root
        self._robot_geom = np.append(robot_geom, False)  # index -1 (no hit) maps to False
        robot_groups = set(np.unique(model.geom_group[robot_geom]).tolist())
        world_groups = set(np.unique(model.geom_group[~robot_geom]).tolist())
        self._filter_after = bool(robot_groups & world_groups)
        mask = np.ones(6, np.uint8)
        if not self._filter_after:
            for g in robot_groups:
                if 0 <= g < 6:
                    mask[g] = 0
        self._geomgroup = mask
        self._rays_body = [cam.rays_cam() for cam in self.params.cameras]
        self._p_body_cam = [np.asarray(cam.p_body_cam, dtype=np.float64) for cam in self.params.cameras]
        n = sum(r.shape[0] for r in self._rays_body)
        self.n_rays = n
        self._vec = [np.zeros(r.shape, dtype=np.float64) for r in self._rays_body]
        self._geomid = [np.zeros(r.shape[0], dtype=np.int32) for r in self._rays_body]
        self._dist = [np.zeros(r.shape[0], dtype=np.float64) for r in self._rays_body]
        self._rng = np.random.default_rng(self.params.seed)
        # dense_spacing_m: per camera, the odd checkerboard cells (n_v, n_h), the fan's angular step (rad) and the
        # last scan's range of every ray (inf: no hit); the even rays are cast every scan, so their ranges are fresh.
        self._odd: list[NDArray[np.bool_]] = []
        self._step_rad: list[float] = []
        self._last_range: list[NDArray[np.float64]] = []
        if self.params.dense_spacing_m < 0:
            raise ValueError(f"SensorParams.dense_spacing_m must be >= 0, got {self.params.dense_spacing_m}")
        for cam in self.params.cameras:
            i, j = np.meshgrid(np.arange(cam.n_v), np.arange(cam.n_h), indexing="ij")
            self._odd.append((i + j) % 2 == 1)
            self._step_rad.append(
                float(
                    np.radians(max(cam.h_fov_deg / max(cam.n_h - 1, 1), cam.v_fov_deg / max(cam.n_v - 1, 1)))
                )
            )
            self._last_range.append(np.full((cam.n_v, cam.n_h), np.inf))
        self.rays_cast = n  # the last scan's rays
        self.raycast_ms = 0.0  # the last scan's time in MuJoCo's ray casting alone (ms)
        self.raycast_cpu_ms = 0.0  # the same in this thread's CPU time (ms)

    def scan(self, data: mujoco.MjData) -> PointCloud:
        """Gives the noisy point cloud seen from the body pose in `data` (needs mj_kinematics or later done)."""
        p = self.params
        p_world_body = data.xpos[self.body_id]
        R_world_body = data.xmat[self.body_id].reshape(3, 3)
        points: list[NDArray[np.float64]] = []
        origins: list[NDArray[np.float64]] = []
        counts: list[int] = []
        raycast_s = 0.0
        raycast_cpu_s = 0.0
        cast_total = 0
        for k, rays in enumerate(self._rays_body):
            sel = self._dense_skip(k) if p.dense_spacing_m > 0 else None
            vec: NDArray[np.float64]
            if sel is None:
                vec = self._vec[k]
                np.matmul(rays, R_world_body.T, out=vec)
                geomid, dist = self._geomid[k], self._dist[k]
            else:
                vec = rays[sel] @ R_world_body.T
                geomid, dist = self._geomid[k][: sel.size], self._dist[k][: sel.size]
            n_cast = int(vec.shape[0])
            origin = p_world_body + R_world_body @ self._p_body_cam[k]
            t0, c0 = time.perf_counter(), time.thread_time()
            mujoco.mj_multiRay(
                self.model, data, origin, vec.ravel(), self._geomgroup, 1, -1, geomid, dist, None,
                n_cast, p.max_range_m,
            )  # fmt: skip
            raycast_s += time.perf_counter() - t0
            raycast_cpu_s += time.thread_time() - c0
            cast_total += n_cast
            if p.dense_spacing_m > 0:
                last = self._last_range[k].reshape(-1)
                ranges = np.where(geomid >= 0, dist, np.inf)
                if sel is None:
                    last[:] = ranges
                else:
                    last[sel] = ranges
            hit = geomid >= 0
            if self._filter_after:
                hit &= ~self._robot_geom[geomid]
            r = dist[hit]
            sigma = p.noise_m + p.noise_per_m * r
            r = r + sigma * self._rng.standard_normal(r.shape[0])
            if p.outlier_fraction > 0:
                bad = np.asarray(self._rng.random(r.shape[0]) < p.outlier_fraction)
                r[bad] += self._rng.uniform(-p.outlier_m, p.outlier_m, int(np.count_nonzero(bad)))
            r = np.maximum(r, 0.0)
            # origin + vec[hit] r, in place on the compressed rows (compress: ~2× faster than a boolean row index)
            q = np.compress(hit, vec, axis=0)
            q *= r[:, None]
            q += origin
            points.append(q)
            origins.append(origin)
            counts.append(r.shape[0])
        self.rays_cast = cast_total
        self.raycast_ms = raycast_s * 1e3
        self.raycast_cpu_ms = raycast_cpu_s * 1e3
        # (each camera's origin repeated for its points: one repeat, not a broadcast per camera concatenated)
        return PointCloud(np.concatenate(points), np.repeat(origins, counts, axis=0), float(data.time))

    def _dense_skip(self, k: int) -> NDArray[np.intp] | None:
        """Gives the indices of camera k's rays to cast this scan (None: all): an odd checkerboard ray is left out
        where its four neighbours' last ranges (beyond the fan: infinite) × the angular step are all below
        dense_spacing_m."""
        last = self._last_range[k]
        nv, nh = last.shape
        padded = np.full((nv + 2, nh + 2), np.inf)
        padded[1:-1, 1:-1] = last
        far = np.maximum(
            np.maximum(padded[:-2, 1:-1], padded[2:, 1:-1]), np.maximum(padded[1:-1, :-2], padded[1:-1, 2:])
        )
        skip = self._odd[k] & (far * self._step_rad[k] < self.params.dense_spacing_m)
        if not skip.any():
            return None
        return np.flatnonzero(~skip.reshape(-1))
