"""What the texture step reads: the textured layers in bulk, square by square, and the orthoimage window by window."""
from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pyproj
import shapely
from osgeo import gdal, osr
from shapely.geometry.base import BaseGeometry

from ..infra.errors import InputError
from ..infra.feedback import Feedback
from ..infra.io import bulk_read
from ..infra.io.layersource import LayerSource
from ..infra.io.raster_io import open_raster, read_window
from ..infra.io.vector_io import open_layer, open_step_layer
from ..infra.raster_crs import aligned, cell_size, crs_name, foreign_crs, transform_geometry, warp
from .config import TextureConfig

_POINTS_IN_MEMORY = 4_000_000  # ring points read at a time (~100 MB with their rings' data): a run of squares


_SQUARE_FILL = 0.875  # share of the image side given to a ground square; the rest takes triangle overhang


@dataclass(frozen=True)
class _Rings:
    """Rings to texture, as arrays: per ring its TEX_TARGET, TEX_FEATURE (as any value ``str`` turns
    into it) and TEX_FACE; the 2D points of all rings one after another (closing points included)
    and where each ring starts (one more entry: the end)."""

    targets: np.ndarray
    features: np.ndarray
    faces: np.ndarray
    xy: np.ndarray
    starts: np.ndarray

    def __len__(self) -> int:
        return len(self.targets)

    def bbox(self, i: int) -> tuple[float, float, float, float]:
        xy = self.xy[self.starts[i]:self.starts[i + 1]]
        return (*xy.min(axis=0), *xy.max(axis=0))

    def bboxes(self) -> np.ndarray:
        """(xmin, ymin, xmax, ymax) of every ring, as rows."""
        first = self.starts[:-1]
        return np.hstack([np.minimum.reduceat(self.xy, first), np.maximum.reduceat(self.xy, first)])

    def take(self, index: np.ndarray) -> _Rings:
        """The rings at ``index``, in that order."""
        counts = self.starts[1:][index] - self.starts[:-1][index]
        starts = np.concatenate([[0], np.cumsum(counts)])
        points = np.repeat(self.starts[:-1][index] - starts[:-1], counts) + np.arange(starts[-1])
        return _Rings(self.targets[index], self.features[index], self.faces[index], self.xy[points], starts)

    @staticmethod
    def concat(parts: list[_Rings]) -> _Rings:
        if not parts:
            return _Rings(*(np.empty(0, dtype=object),) * 3, np.empty((0, 2)), np.zeros(1, dtype=np.int64))
        counts = np.concatenate([np.diff(part.starts) for part in parts])
        targets, features, faces, xy = (np.concatenate([getattr(part, name) for part in parts])
                                        for name in ("targets", "features", "faces", "xy"))
        return _Rings(targets, features, faces, xy, np.concatenate([[0], np.cumsum(counts)]))


class _Layer:
    """A textured layer: the faces of the given kinds, read in bulk square by square (``squares``)."""

    def __init__(self, path: str, name: str, kind_field: str, fields: tuple[str, ...], kinds: tuple[str, ...],
                 role: str):
        self._ds, self.layer, self._fields = open_step_layer(path, name, role, fields)
        self.path, self.name = LayerSource.parse(path).path, self.layer.GetName()
        self.kind_field, self.kinds = kind_field, kinds
        xmin, xmax, ymin, ymax = self.layer.GetExtent()
        self.extent = (xmin, ymin, xmax, ymax)
        srs = self.layer.GetSpatialRef()
        self.srs = srs.Clone() if srs is not None else None  # the layer owns its SRS; keep our own
        self.surfaces = self.count(kinds)

    def close(self) -> None:
        self.layer = self._ds = None

    def _where(self, kinds: tuple[str, ...]) -> str:
        return f"\"{self.kind_field}\" IN ({', '.join(repr(k) for k in kinds)})"

    def count(self, kinds: tuple[str, ...]) -> int:
        """Number of features whose kind field is one of ``kinds``."""
        self.layer.SetAttributeFilter(self._where(kinds))
        return self.layer.GetFeatureCount()

    def squares(self, grid: _Grid, columns: tuple[str, ...],
              describe: Callable[[list[np.ndarray]], tuple[np.ndarray, np.ndarray, np.ndarray]]
              ) -> Iterator[tuple[tuple[int, int], _Rings]]:
        """Each ground square over the layer's extent (row by row from the north-west) with the rings whose
        first point lies in it, in the layer's order: every ring comes exactly once.

        Read in bulk (``bulk_read``): once to place every ring in its square (an int per feature
        kept), then once per run of squares whose points fit in memory together (one run for the 1
        km demo); OGR spatial filters would read the whole layer per square when it has no
        spatial index (the chain's intermediate files have none). ``describe`` turns a batch's
        ``columns`` into the rings' targets, features and faces.
        """
        keys = grid.keys(self.extent)
        (r0, c0), (_, c1) = keys[0], keys[-1]

        def square_of(xy: np.ndarray, counts: np.ndarray) -> np.ndarray:
            row, col = grid.key_arrays(*xy[np.cumsum(counts) - counts].T)
            return (row - r0) * (c1 - c0 + 1) + (col - c0)

        placed = [(square_of(xy, counts), counts) for xy, counts, _ in self._read(columns[:1])]
        square = np.concatenate([s for s, _ in placed] or [np.empty(0, dtype=np.int64)]).astype(np.int32)
        points = np.bincount(square, weights=np.concatenate([c for _, c in placed] or [np.empty(0)]),
                             minlength=len(keys))
        del placed
        first = 0
        while first < len(keys):
            last = first + max(1, int(np.searchsorted(np.cumsum(points[first:]), _POINTS_IN_MEMORY, side="right")))
            wanted = (square >= first) & (square < last)
            parts = []
            for xy, counts, batch in self._read(columns, wanted):
                starts = np.concatenate([[0], np.cumsum(counts)])
                parts.append(_Rings(*describe([batch[c] for c in columns]), xy, starts))
            rings = _Rings.concat(parts)
            del parts
            mine = square[wanted]
            order = np.argsort(mine, kind="stable")
            bounds = np.searchsorted(mine[order], np.arange(first, last + 1))
            for n in range(first, last):
                yield keys[n], rings.take(order[bounds[n - first]:bounds[n - first + 1]])
            first = last

    def _read(self, columns: tuple[str, ...], wanted: np.ndarray | None = None
              ) -> Iterator[tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]]:
        """(2D points, points per ring, the batch's columns) of the layer's surfaces, batch by batch,
        only the ``wanted`` ones (a mask over all of them, in order) if given.

        Each pass reads through a handle of its own: GDAL allows one Arrow stream per layer at a time, and
        the previous pass's may outlive it (a profiler, e.g. Dask's, keeps the frames it samples for a moment).
        """
        ds, layer, _ = open_layer(self.path, self.name)
        layer.SetAttributeFilter(self._where(self.kinds))
        bulk_read.ignore_fields(layer, [f for f in self._fields if f not in columns])
        start = 0
        try:
            for batch in bulk_read.batches(layer, fid=True):
                size = len(batch["geometry"])
                if wanted is not None:
                    keep = wanted[start:start + size]
                    batch = {name: column[keep] for name, column in batch.items()}
                start += size
                points, counts, rings = bulk_read.exterior_rings(batch["geometry"])
                if not rings.all():
                    bad = int(np.argmin(rings))
                    raise InputError(f"Feature {batch['fid'][bad]} of layer {self.name!r} in {self.path} is "
                                     f"{bulk_read.geometry_name(batch['geometry'][bad])}, not a polygon face: use "
                                     "the unmodified output of the previous step.")
                yield np.ascontiguousarray(points[:, :2]), counts, batch
        finally:
            del layer, ds


@dataclass(frozen=True)
class _Patch:
    """Texels cut from the ortho and the ground extent (outer texel edges) they cover."""

    pixels: np.ndarray  # rows × columns × 3, uint8
    extent: tuple[float, float, float, float]  # xmin, ymin, xmax, ymax
    downscaled: bool


class _Ortho:
    """The merged orthoimage, read window by window."""

    def __init__(self, path: str, config: TextureConfig):
        self.path, self.scale = path, config.scale
        self.ds = open_raster(path, "orthoimage")
        self.footprint: BaseGeometry | None = None  # where a reprojected ortho has pixels
        self.source: gdal.Dataset | None = None  # the file behind a reprojected ortho's warped VRT
        ds = self.ds
        if ds.RasterCount < 3 or any(ds.GetRasterBand(b).DataType != gdal.GDT_Byte for b in (1, 2, 3)):
            raise InputError(f"The orthoimage {path} must be RGB with 8-bit bands (it has {ds.RasterCount} band(s)): "
                             "use the output of wit:mergerasters.")
        gt = ds.GetGeoTransform(can_return_null=True)
        if gt is None or gt[2] or gt[4] or gt[5] >= 0:
            raise InputError(f"The orthoimage {path} is not georeferenced north-up: georeference it "
                             "(wit:georeferencemapsheets) and merge it (wit:mergerasters) first.")
        self._grid(ds)
        wkt = ds.GetProjection()
        self.srs = osr.SpatialReference(wkt) if wkt else None

    def _grid(self, ds: gdal.Dataset) -> None:
        gt = ds.GetGeoTransform()
        self.x0, self.px, self.y0, self.py = gt[0], gt[1], gt[3], -gt[5]
        self.width, self.height = ds.RasterXSize, ds.RasterYSize
        self.extent = (self.x0, self.y0 - self.height * self.py, self.x0 + self.width * self.px, self.y0)
        self.step = max(1, round(1.0 / self.scale))
        self.texel_size = max(self.px, self.py) / self.scale

    def reproject_to(self, layers: list[_Layer], feedback: Feedback) -> None:
        """An ortho in another CRS than the layers': read from then on through a warped VRT (in memory,
        bilinear, its pixel size in metres) over the layers' extent, so only the pixels needed are warped."""
        wkt = next((layer.srs.ExportToWkt() for layer in layers if layer.srs is not None), None)
        source = foreign_crs(self.ds, wkt) if wkt else None
        if source is None or wkt is None:  # (no WKT: no source either)
            return
        target = pyproj.CRS.from_wkt(wkt)
        size = cell_size(self.ds, source, target)
        self.footprint = transform_geometry(shapely.box(*self.extent), source, target)
        boxes = [layer.extent for layer in layers]
        needed = (min(b[0] for b in boxes), min(b[1] for b in boxes),
                  max(b[2] for b in boxes), max(b[3] for b in boxes))
        self.source, self.ds = self.ds, warp(self.ds, source, target, aligned(needed, size, 8), size, fmt="VRT",
                                             exact=False)
        self._grid(self.ds)
        self.srs = osr.SpatialReference(wkt)
        feedback.info(f"The orthoimage {Path(self.path).name} is in {crs_name(source)}: its pixels over the layers are "
                      f"reprojected as they are read to {crs_name(target)} (bilinear, {size:g} m pixels).")

    def close(self) -> None:
        self.ds = self.source = None

    def check_covers(self, layer: _Layer, extent: bool = True) -> None:
        """Refuse a layer whose CRS differs or (``extent``) whose extent reaches beyond the ortho."""
        if self.srs is not None and layer.srs is not None and not self.srs.IsSame(
                layer.srs, ["IGNORE_DATA_AXIS_TO_SRS_AXIS_MAPPING=YES"]):
            raise InputError(f"Layer {layer.name!r} ({layer.srs.GetName()}) and the orthoimage "
                             f"({self.srs.GetName()}) have different CRSs: produce both in the same CRS.")
        if not extent:
            return
        lx0, ly0, lx1, ly1 = layer.extent
        ox0, oy0, ox1, oy1 = self.footprint.bounds if self.footprint is not None else self.extent
        if lx0 < ox0 or ly0 < oy0 or lx1 > ox1 or ly1 > oy1 or (
                self.footprint is not None and not self.footprint.contains(shapely.box(*layer.extent))):
            raise InputError(
                f"Layer {layer.name!r} in {layer.path} reaches beyond the orthoimage, whose pixels are needed for "
                f"every textured surface: layer x {lx0:.2f}–{lx1:.2f}, y {ly0:.2f}–{ly1:.2f}; ortho x "
                f"{ox0:.2f}–{ox1:.2f}, y {oy0:.2f}–{oy1:.2f}. Merge the orthoimage sheets that cover the whole study "
                "area (wit:mergerasters) or make the study area smaller.")

    def patch(self, bbox: tuple[float, float, float, float], limit: int, margin: int = 0) -> _Patch:
        """The texels over ``bbox`` (+ ``margin`` texels, within the ortho), at most ``limit`` a side."""
        xmin, ymin, xmax, ymax = bbox
        pad = margin * self.texel_size
        step = self.step
        c0 = math.floor((xmin - pad - self.x0) / self.px) // step * step
        c1 = -(-(math.floor((xmax + pad - self.x0) / self.px) + 1) // step) * step
        r0 = math.floor((self.y0 - ymax - pad) / self.py) // step * step
        r1 = -(-(math.floor((self.y0 - ymin + pad) / self.py) + 1) // step) * step
        c0, r0 = max(c0, 0), max(r0, 0)
        c1, r1 = min(c1, self.width), min(r1, self.height)
        w, h = c1 - c0, r1 - r0
        tw, th = max(1, round(w * self.scale)), max(1, round(h * self.scale))
        shrink = min(1.0, limit / tw, limit / th)
        if shrink < 1.0:
            tw, th = max(1, math.floor(tw * shrink)), max(1, math.floor(th * shrink))
        resample = gdal.GRIORA_Average if (tw, th) != (w, h) else gdal.GRIORA_NearestNeighbour
        data = read_window(self.ds, c0, r0, w, h, f"the orthoimage {self.path}", buf_xsize=tw, buf_ysize=th,
                           band_list=[1, 2, 3], interleave="pixel", resample_alg=resample)
        extent = (self.x0 + c0 * self.px, self.y0 - r1 * self.py, self.x0 + c1 * self.px, self.y0 - r0 * self.py)
        return _Patch(data, extent, shrink < 1.0)


class _Grid:
    """The ground squares (each one image of terrain and roads; the roofs are read square by square too),
    anchored on the ortho's top-left corner, rows going south."""

    def __init__(self, ortho: _Ortho, config: TextureConfig):
        self.x0, self.y0 = ortho.x0, ortho.y0
        self.side = math.floor(config.atlas_size * _SQUARE_FILL) * ortho.texel_size
        self._eps = 1e-6 * self.side

    def key(self, x: float, y: float) -> tuple[int, int]:
        return math.floor((self.y0 - y) / self.side), math.floor((x - self.x0) / self.side)

    def key_arrays(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``key`` for arrays of points: (rows, columns)."""
        return (np.floor((self.y0 - y) / self.side).astype(np.int64),
                np.floor((x - self.x0) / self.side).astype(np.int64))

    def rect(self, key: tuple[int, int]) -> tuple[float, float, float, float]:
        """The square's xmin, ymin, xmax, ymax, widened by a hair so rounding cannot drop a boundary vertex."""
        r, c = key
        e = self._eps
        return (self.x0 + c * self.side - e, self.y0 - (r + 1) * self.side - e,
                self.x0 + (c + 1) * self.side + e, self.y0 - r * self.side + e)

    def keys(self, extent: tuple[float, float, float, float]) -> list[tuple[int, int]]:
        """The squares over ``extent``, row by row from the north-west."""
        (r0, c0), (r1, c1) = self.key(extent[0], extent[3]), self.key(extent[2], extent[1])
        return [(r, c) for r in range(r0, r1 + 1) for c in range(c0, c1 + 1)]
