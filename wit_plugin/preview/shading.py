"""The preview's shading: textures sampled from mip levels, flat colours, sun light, outlines, haze."""
from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np

from ..infra.feedback import Feedback
from ..infra.io.raster_io import open_raster, read_window
from ..texture.images import mip_chain
from .camera import _Camera, _Frame
from .scene import _WALL, _Mesh

SUN_OFFSET_DEG = 65.0  # sun azimuth relative to the camera's


SUN_ELEVATION_DEG = 45.0


WALL_RGB = (222, 213, 196)


ROOF_RGB = (176, 120, 100)


TERRAIN_RGB = (128, 146, 108)


ROAD_RGB = (92, 92, 98)


FOOTPRINT_RGB = (150, 150, 140)


SKY_TOP_RGB = (104, 150, 206)


SKY_HORIZON_RGB = (222, 232, 242)


HAZE_RGB = (205, 218, 232)


HAZE_MAX = 0.3  # share of haze at the farthest point of the model


_KIND_RGB = np.array([ROOF_RGB, WALL_RGB, TERRAIN_RGB, ROAD_RGB, FOOTPRINT_RGB], dtype=np.float32)


class _ImageCache:
    """Texture images read once (GDAL), with their mip levels built on demand."""

    def __init__(self, folder: Path | None, names: list[str]):
        self.folder, self.names = folder, names
        self._levels: dict[int, list[np.ndarray]] = {}

    def size(self, index: int) -> tuple[int, int]:
        """Width and height of level 0."""
        base = self.level(index, 0)
        return base.shape[1], base.shape[0]

    def level(self, index: int, level: int) -> np.ndarray:
        """Mip ``level`` (clamped to the chain) of image ``index`` as rows × columns × 3 uint8."""
        levels = self._levels.get(index)
        if levels is None:
            levels = self._levels[index] = [self._read(index)]
        if level > 0 and len(levels) == 1:
            levels.extend(mip_chain(levels[0])[1:])
        return levels[min(level, len(levels) - 1)]

    def _read(self, index: int) -> np.ndarray:
        if self.folder is None:  # (a mesh without a texture folder has no textured triangle)
            raise ValueError("No texture folder to read a texture image from.")
        path = self.folder / self.names[index]
        ds = open_raster(path, "texture image")
        bands = [1, 2, 3] if ds.RasterCount >= 3 else [1, 1, 1]
        data = np.stack([read_window(ds.GetRasterBand(b), 0, 0, ds.RasterXSize, ds.RasterYSize,
                                     f"the texture image {path}") for b in bands], axis=-1)
        return np.clip(data, 0, 255).astype(np.uint8) if data.dtype != np.uint8 else data


def _bilinear(image: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear samples (n × 3 float32) of ``image`` at texture coordinates (v from the bottom), edges clamped."""
    h, w = image.shape[:2]
    fx = np.clip(u * w - 0.5, 0, w - 1).astype(np.float32)
    fy = np.clip((1.0 - v) * h - 0.5, 0, h - 1).astype(np.float32)
    ix, iy = np.minimum(fx.astype(np.int64), max(w - 2, 0)), np.minimum(fy.astype(np.int64), max(h - 2, 0))
    ax, ay = (fx - ix)[:, None], (fy - iy)[:, None]
    jx, jy = np.minimum(ix + 1, w - 1), np.minimum(iy + 1, h - 1)
    top = image[iy, ix] * (1 - ax) + image[iy, jx] * ax
    bottom = image[jy, ix] * (1 - ax) + image[jy, jx] * ax
    return top * (1 - ay) + bottom * ay


def _shade(camera: _Camera, mesh: _Mesh, frame: _Frame, cache: _ImageCache, azimuth_deg: float,
           feedback: Feedback) -> np.ndarray:
    """Colour every pixel (float32 rows × columns × 3, 0–255): textures, light, edges, haze and sky."""
    h, w = frame.triangle.shape
    rows = np.linspace(0.0, 1.0, h, dtype=np.float32)[:, None, None]
    sky = np.array(SKY_TOP_RGB, np.float32) * (1 - rows) + np.array(SKY_HORIZON_RGB, np.float32) * rows
    rgb = np.broadcast_to(sky, (h, w, 3)).copy()
    covered = np.flatnonzero(frame.triangle.ravel() >= 0)
    t = frame.triangle.ravel()[covered]
    l1, l2 = frame.l1.ravel()[covered], frame.l2.ravel()[covered]
    lam = np.stack([1 - l1 - l2, l1, l2], axis=1) * frame.inv_depth[t].astype(np.float32)
    inv_z = lam.sum(axis=1)
    bary = lam / inv_z[:, None]  # perspective-correct barycentrics
    depth = 1.0 / inv_z

    colour = _KIND_RGB[mesh.kind[t]].copy()
    textured = np.flatnonzero(mesh.image[t] >= 0)
    if len(textured):
        tt = t[textured]
        uv = np.einsum("pk,pkc->pc", bary[textured], mesh.uv[tt])
        facade = mesh.kind[tt] == _WALL  # a generated facade repeats along the wall
        uv[facade, 0] -= np.floor(uv[facade, 0])
        level = _mip_levels(mesh, frame, cache)[tt]
        key = mesh.image[tt].astype(np.int64) * 64 + level
        order = np.argsort(key, kind="stable")
        bounds = np.flatnonzero(np.diff(np.concatenate([[-1], key[order], [-1]])))
        for b0, b1 in itertools.pairwise(bounds):
            feedback.check_canceled()
            sel = order[b0:b1]
            image = cache.level(int(key[sel[0]] // 64), int(key[sel[0]] % 64))
            colour[textured[sel]] = _bilinear(image, uv[sel, 0], uv[sel, 1])
    colour *= _light(camera, mesh, azimuth_deg)[t][:, None]

    edge = _edges(frame.triangle, mesh.group, depth, covered, w, h)
    colour *= np.where(edge, np.float32(0.72), np.float32(1.0))[:, None]
    near, far = float(depth.min()), float(depth.max())
    haze = (np.clip((depth - near) / max(far - near, 1e-9), 0, 1) ** 1.5 * HAZE_MAX)[:, None]
    colour = colour * (1 - haze) + np.array(HAZE_RGB, np.float32) * haze
    rgb.reshape(-1, 3)[covered] = colour
    feedback.progress(95.0)
    return rgb


def _mip_levels(mesh: _Mesh, frame: _Frame, cache: _ImageCache) -> np.ndarray:
    """Per triangle, the mip level whose texels are about one pixel (0 for untextured triangles)."""
    levels = np.zeros(len(mesh.image), dtype=np.int64)
    textured = np.flatnonzero(mesh.image >= 0)
    if not len(textured):
        return levels
    used = set(mesh.image[textured].tolist())
    sizes = np.array([cache.size(i) if i in used else (1, 1) for i in range(int(mesh.image.max()) + 1)],
                     dtype=np.float64)
    uv = mesh.uv[textured].astype(np.float64) * sizes[mesh.image[textured]][:, None, :]
    s = frame.screen[textured]

    def area(p: np.ndarray) -> np.ndarray:
        return np.abs((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                      - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))

    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sqrt(area(uv) / area(s))
    levels[textured] = np.clip(np.floor(np.log2(np.nan_to_num(ratio, nan=1.0, posinf=1.0))), 0, 30)
    return levels


def _light(camera: _Camera, mesh: _Mesh, azimuth_deg: float) -> np.ndarray:
    """Lambert factor per triangle: strong on walls (tinted per building), mild on roofs and terrain (1 on flat)."""
    az, el = math.radians(azimuth_deg + SUN_OFFSET_DEG), math.radians(SUN_ELEVATION_DEG)
    sun = np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])
    p = mesh.xyz
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-12)[:, None]
    facing = np.einsum("nk,nk->n", camera.position - p[:, 0], normal)
    normal[facing < 0] *= -1  # the side the camera sees
    lit = normal @ sun
    wall = mesh.kind == _WALL
    tint = 0.9 + 0.15 * ((mesh.group * 0.618034) % 1.0)  # a little variety between buildings
    return np.where(wall, tint * (0.55 + 0.5 * np.clip(lit, 0, 1)),
                    np.clip(1.0 + 0.8 * (lit - math.sin(el)), 0.6, 1.25)).astype(np.float32)


def _edges(triangle: np.ndarray, group: np.ndarray, depth: np.ndarray, covered: np.ndarray,
           w: int, h: int) -> np.ndarray:
    """Covered pixels on a building outline: next to another building or the ground, or to a farther surface."""
    g = np.full(h * w, -2, np.int64)
    g[covered] = group[triangle.ravel()[covered]]
    z = np.full(h * w, np.finfo(np.float32).max, np.float32)
    z[covered] = depth
    g, z = g.reshape(h, w), z.reshape(h, w)
    edge = np.zeros((h, w), dtype=bool)
    for axis in (0, 1):
        a = [slice(None), slice(None)]
        b = [slice(None), slice(None)]
        a[axis], b[axis] = slice(None, -1), slice(1, None)
        ga, gb, za, zb = g[tuple(a)], g[tuple(b)], z[tuple(a)], z[tuple(b)]
        differs = (ga != gb) & ((ga >= 0) | (gb >= 0))
        jump = np.abs(za - zb) > 0.01 * np.minimum(za, zb)
        mark = differs | jump
        edge[tuple(a)] |= mark & (za <= zb) & (ga >= 0)  # the nearer side of a building outline
        edge[tuple(b)] |= mark & (zb < za) & (gb >= 0)
    return edge.ravel()[covered]


def _downsample(rgb: np.ndarray, factor: int) -> np.ndarray:
    h, w = rgb.shape[0] // factor, rgb.shape[1] // factor
    small = rgb[:h * factor, :w * factor].reshape(h, factor, w, factor, 3).mean(axis=(1, 3))
    return np.clip(np.rint(small), 0, 255).astype(np.uint8)
