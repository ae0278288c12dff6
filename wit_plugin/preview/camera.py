"""The preview's camera and rasteriser: triangles to a z-buffer of triangle ids and barycentrics."""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..infra.feedback import Feedback

DISTANCE = 3.0  # camera distance in model radii (a field of view of about 35°)


MARGIN = 0.03  # share of the picture left free on each side


CELL_BUDGET = 1 << 21  # candidate pixels per rasteriser chunk (bounds memory to ~100 MB)


_FAR = np.uint32(0xFFFFFFFF)


@dataclass
class _Camera:
    """Perspective camera: view axes, position, focal length (pixels) and principal point."""

    position: np.ndarray
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    focal: float
    cx: float
    cy: float
    width: int
    height: int

    @classmethod
    def framing(cls, xyz: np.ndarray, width: int, height: int, azimuth_deg: float, elevation_deg: float) -> _Camera:
        """Look at the centre of the model's box from the given direction; fit every vertex in the frame."""
        points = xyz.reshape(-1, 3)
        lo, hi = points.min(axis=0), points.max(axis=0)
        centre = (lo + hi) / 2
        radius = max(float(np.linalg.norm(hi - lo)) / 2, 1e-6)
        az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
        to_camera = np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])
        forward = -to_camera
        right = np.cross(forward, [0.0, 0.0, 1.0]) if elevation_deg < 90 else np.array([1.0, 0.0, 0.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        camera = cls(centre + DISTANCE * radius * to_camera, right, up, forward, 1.0, 0.0, 0.0, width, height)
        view = camera.view(points)
        sx, sy = view[:, 0] / view[:, 2], view[:, 1] / view[:, 2]
        span_x, span_y = max(np.ptp(sx), 1e-9), max(np.ptp(sy), 1e-9)
        camera.focal = min(width / span_x, height / span_y) * (1 - 2 * MARGIN)
        camera.cx = width / 2 - camera.focal * (sx.min() + sx.max()) / 2
        camera.cy = height / 2 + camera.focal * (sy.min() + sy.max()) / 2
        return camera

    def view(self, points: np.ndarray) -> np.ndarray:
        """Camera coordinates: right, up, depth along the view direction."""
        d = points - self.position
        return np.stack([d @ self.right, d @ self.up, d @ self.forward], axis=-1)

    def project(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (x right, y down) and 1/depth of points (..., 3)."""
        view = self.view(xyz)
        inv = 1.0 / view[..., 2]
        return np.stack([self.cx + self.focal * view[..., 0] * inv, self.cy - self.focal * view[..., 1] * inv],
                        axis=-1), inv


@dataclass
class _Frame:
    """The z-buffer's result: per pixel the visible triangle (-1 = none) and barycentrics l1, l2."""

    triangle: np.ndarray
    l1: np.ndarray
    l2: np.ndarray
    screen: np.ndarray  # (n, 3, 2) pixel coordinates of the triangles
    inv_depth: np.ndarray  # (n, 3)


def _rasterise(camera: _Camera, xyz: np.ndarray, feedback: Feedback) -> _Frame:
    """Z-buffer every triangle; chunks of equally sized pixel boxes are processed at once."""
    w, h = camera.width, camera.height
    screen, inv = camera.project(xyz)
    x, y = screen[..., 0], screen[..., 1]
    x0 = np.clip(np.ceil(x.min(axis=1) - 0.5), 0, w).astype(np.int64)
    x1 = np.clip(np.floor(x.max(axis=1) - 0.5), -1, w - 1).astype(np.int64)
    y0 = np.clip(np.ceil(y.min(axis=1) - 0.5), 0, h).astype(np.int64)
    y1 = np.clip(np.floor(y.max(axis=1) - 0.5), -1, h - 1).astype(np.int64)
    area2 = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    live = np.flatnonzero((x1 >= x0) & (y1 >= y0) & (np.abs(area2) > 1e-12) & (inv.min(axis=1) > 0))
    bw = 1 << np.ceil(np.log2(x1[live] - x0[live] + 1)).astype(np.int64)
    bh = 1 << np.ceil(np.log2(y1[live] - y0[live] + 1)).astype(np.int64)
    order = np.lexsort((bh, bw))
    live, bw, bh = live[order], bw[order], bh[order]
    # l1 = a1·gx + b1·gy + c1 over the box's pixel offsets gx, gy (centres at +0.5); likewise l2
    ox, oy = x[:, 0] - x0 - 0.5, y[:, 0] - y0 - 0.5
    ex1, ey1, ex2, ey2 = x[:, 1] - x[:, 0], y[:, 1] - y[:, 0], x[:, 2] - x[:, 0], y[:, 2] - y[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        coef = np.stack([ey2, -ex2, -(ox * ey2 - oy * ex2), -ey1, ex1, -(ex1 * oy - ey1 * ox)], axis=1) / area2[:, None]
    coef = coef.astype(np.float32)
    inv_lo, inv_hi = float(inv.min()), float(inv.max())
    iz = ((inv - inv_lo) / max(inv_hi - inv_lo, 1e-30)).astype(np.float32)  # 0 far … 1 near

    zbuf = np.full(w * h, _FAR, dtype=np.uint32)
    tbuf = np.full(w * h, -1, dtype=np.int32)
    l1buf = np.zeros(w * h, np.float32)
    l2buf = np.zeros(w * h, np.float32)
    groups = np.flatnonzero(np.diff(np.concatenate([[-1], bw * 65536 + bh, [-1]])))
    done, total = 0, max(len(live), 1)
    for g0, g1 in itertools.pairwise(groups):
        gw, gh = int(bw[g0]), int(bh[g0])
        step = max(1, CELL_BUDGET // (gw * gh))
        gx = np.arange(gw, dtype=np.float32)[None, None, :]
        gy = np.arange(gh, dtype=np.float32)[None, :, None]
        for c0 in range(g0, g1, step):
            feedback.check_canceled()
            t = live[c0:min(c0 + step, g1)]
            k = coef[t][:, :, None, None]
            l1 = k[:, 0] * gx + k[:, 1] * gy + k[:, 2]
            l2 = k[:, 3] * gx + k[:, 4] * gy + k[:, 5]
            eps = np.float32(-1e-5)
            inside = (l1 >= eps) & (l2 >= eps) & (l1 + l2 <= 1 - eps)
            inside &= (gx < (x1[t] - x0[t] + 1)[:, None, None]) & (gy < (y1[t] - y0[t] + 1)[:, None, None])
            ti, yy, xx = np.nonzero(inside)
            l1, l2 = l1[ti, yy, xx], l2[ti, yy, xx]
            tri = t[ti]
            z = iz[tri, 0] + l1 * (iz[tri, 1] - iz[tri, 0]) + l2 * (iz[tri, 2] - iz[tri, 0])
            depth = ((1.0 - np.clip(z, 0.0, 1.0)) * np.float32(4.29e9)).astype(np.uint32)  # 0 = nearest
            pixel = (y0[tri] + yy) * w + x0[tri] + xx
            _resolve(pixel, depth, tri, l1, l2, zbuf, tbuf, l1buf, l2buf)
            done += len(t)
            feedback.progress(100.0 * done / total)
    return _Frame(tbuf.reshape(h, w), l1buf.reshape(h, w), l2buf.reshape(h, w), screen, inv)


def _resolve(pixel: np.ndarray, depth: np.ndarray, tri: np.ndarray, l1: np.ndarray, l2: np.ndarray,
             zbuf: np.ndarray, tbuf: np.ndarray, l1buf: np.ndarray, l2buf: np.ndarray) -> None:
    """Keep, per pixel, the nearest fragment if it is nearer than the buffer's."""
    order = np.argsort((pixel.astype(np.int64) << 32) | depth.astype(np.int64))
    p = pixel[order]
    first = np.ones(len(p), dtype=bool)
    first[1:] = p[1:] != p[:-1]
    sel = order[first]
    p = pixel[sel]
    nearer = depth[sel] < zbuf[p]
    sel, p = sel[nearer], p[nearer]
    zbuf[p], tbuf[p], l1buf[p], l2buf[p] = depth[sel], tri[sel], l1[sel], l2[sel]
