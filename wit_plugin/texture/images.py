"""What the texture step writes: images and their mip chains, roof atlases, the texture-coordinate table."""
from __future__ import annotations

from collections import Counter
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import numpy as np
from osgeo import gdal, ogr

from ..infra import step_layers
from ..infra.errors import InputError
from ..infra.io.gpkg_bulk import BulkTable
from ..infra.io.vector_io import FieldDef
from ..infra.numtext import ring_texts
from .config import TEXCOORDS_FILE, TextureConfig, TextureReport
from .sources import _Patch, _Rings

_BACKGROUND = 128  # grey for unused atlas space: neutral under JPEG ringing


UV_PAIR = "%.12f %.12f"  # 12 decimals of u and v: 1e-12 of an image side, far below a texel of any atlas


def mip_chain(image: np.ndarray) -> list[np.ndarray]:
    """The mip levels of ``image`` (rows × columns [× bands]) from itself down to 1 × 1.

    Each level halves the previous one's sides (floored, at least 1: the OpenGL rule for
    non-power-of-two sizes) by area-weighted box filtering, so an odd side still weighs every
    source texel by its covered area. Levels are computed from the unrounded previous level (in
    float32, float64 for float64 images) and returned in the input's dtype.
    """
    if image.ndim < 2 or image.shape[0] < 1 or image.shape[1] < 1:
        raise ValueError(f"mip_chain needs an image of at least 1 × 1, got shape {image.shape}")
    work = np.result_type(image.dtype, np.float32)
    levels = [image]
    # bands first (rows, columns in the last two axes): halving the columns of interleaved bands ran numpy's loops
    # over the 3 values of one texel at a time; the same values
    planar = image.ndim == 3
    current = np.ascontiguousarray(np.moveaxis(image, -1, 0)) if planar else image
    rows = 1 if planar else 0
    while current.shape[rows] > 1 or current.shape[rows + 1] > 1:
        current = _halve(_halve(current, rows, work), rows + 1, work)
        level = _as_dtype(current, image.dtype)
        levels.append(np.ascontiguousarray(np.moveaxis(level, 0, -1)) if planar else level)
    return levels


def _halve(a: np.ndarray, axis: int, work: np.dtype) -> np.ndarray:
    """Box-filter ``a`` to half its size (floored, ≥ 1) along ``axis``, in the ``work`` dtype."""
    n = a.shape[axis]
    m = max(1, n // 2)
    if n == 2 * m:  # (even + odd texel) / 2: what mean over a reshaped pair gives, bit for bit, 3-8x faster
        even = a[(slice(None),) * axis + (slice(0, None, 2),)]
        odd = a[(slice(None),) * axis + (slice(1, None, 2),)]
        return (even.astype(work) + odd) / work.type(2)
    if n == 1:
        return a.astype(work, copy=False)
    # odd n: out[j] = mean of a over [j·n/m, (j+1)·n/m), a span of 2 + 1/m ≤ 3 texels, so it
    # overlaps at most 4 of them: a weighted sum of 4 shifted takes (no full-size temporaries)
    span = n / m
    edges = np.arange(m + 1) * span
    first = np.floor(edges[:-1]).astype(int)
    every_other = np.array_equal(first, 2 * np.arange(m))  # (as it is: j·n/m = 2j + j/m, j/m < 1)
    finite = np.issubdtype(a.dtype, np.integer)
    shape = (-1,) + (1,) * (a.ndim - axis - 1)
    out = np.zeros(a.shape[:axis] + (m,) + a.shape[axis + 1:], dtype=work)
    for t in range(4):
        index = first + t
        overlap = np.minimum(edges[1:], index + 1) - np.maximum(edges[:-1], index)
        weight = (np.clip(overlap, 0.0, None) / span).astype(work).reshape(shape)
        if finite and not weight.any():  # (the 4th texel is all but never reached: adding 0 changes nothing)
            continue
        if every_other and t < 3:  # texels t, t + 2, …, t + 2(m − 1): a strided view, not a gathered copy
            taps = a[(slice(None),) * axis + (slice(t, t + 2 * m - 1, 2),)]
        else:
            taps = np.take(a, np.minimum(index, n - 1), axis=axis)
        out += weight * taps
    return out


def _as_dtype(a: np.ndarray, dtype: np.dtype) -> np.ndarray:
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        return np.clip(np.rint(a), info.min, info.max).astype(dtype)
    return a.astype(dtype, copy=False)


def _uv(xy: np.ndarray, placements: np.ndarray, image_w: int, image_h: int) -> np.ndarray:
    """(u, v) per point over its placement's extent (the UV mapping of the package docstring), in the
    image's texture space (v up).

    ``placements`` has one row per point: x, y, width, height, xmin, ymin, xmax, ymax.
    """
    x, y, width, height, xmin, ymin, xmax, ymax = placements.T
    u = (x + (xy[:, 0] - xmin) / (xmax - xmin) * width) / image_w
    v = 1.0 - (y + (ymax - xy[:, 1]) / (ymax - ymin) * height) / image_h
    return np.column_stack([u, v])


class _Output:
    """Images (and their mips) plus the texture-coordinate table, in the staging folder.

    OGR creates the GeoPackage and its attribute table; the rows (one per surface, ~600,000 for
    the 1 km demo) then go in through SQLite, a batch per image, as OGR's feature-at-a-time
    writing took most of this step's time. Images are encoded and rows inserted by one worker
    thread, an image behind the main thread (GDAL's encoders and SQLite release the GIL), while
    the main thread reads the ortho and formats the next image's rows: the two cores overlap.
    """

    _FIELDS = [FieldDef(step_layers.TEX_TARGET, ogr.OFTString), FieldDef(step_layers.TEX_FEATURE, ogr.OFTString),
               FieldDef(step_layers.TEX_FACE, ogr.OFTInteger), FieldDef(step_layers.TEX_IMAGE, ogr.OFTString),
               FieldDef(step_layers.TEX_COORDS, ogr.OFTString)]

    def __init__(self, folder: Path, ext: str, config: TextureConfig, report: TextureReport):
        self.folder, self.ext, self.config, self.report = folder, ext, config, report
        self._options = {"jpg": [f"QUALITY={config.jpeg_quality}"], "png": ["ZLEVEL=6"]}
        self._table = BulkTable(folder / TEXCOORDS_FILE, step_layers.TEXCOORD_TABLE, self._FIELDS, threaded=True)
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="wit-texture-output")
        self._pending: Future | None = None

    def write(self, stem: str, pixels: np.ndarray, rings: _Rings, placements: np.ndarray) -> None:
        """Write one image and the rows of the rings placed in it (``placements``: one row per ring,
        or one for all, of x, y, width, height, xmin, ymin, xmax, ymax; see ``_uv``).

        ``pixels`` must not change afterwards: the worker encodes it later.
        """
        name = f"{stem}.{self.ext}"
        counts = np.diff(rings.starts)
        per_point = placements if len(placements) == 1 else np.repeat(placements, counts, axis=0)
        uv = ring_texts(_uv(rings.xy, per_point, pixels.shape[1], pixels.shape[0]), counts, UV_PAIR)
        rows = list(zip(rings.targets.tolist(), map(str, rings.features.tolist()), rings.faces.tolist(),
                        [name] * len(uv), uv))
        self.submit(rows, (name, pixels))

    def submit(self, rows: list[tuple], image: tuple[str, np.ndarray] | None = None) -> None:
        """Write table rows (target, feature, face, image, uv text) and the ``image`` (name, pixels) if given, in
        the worker."""
        if image is not None:
            self.report.images.append(image[0])
        for target, count in Counter(row[0] for row in rows).items():
            self.report.surfaces[target] += count
        self._wait()  # at most one image in the worker's hands: memory stays at two images' rows
        self._pending = self._worker.submit(self._store, rows, image)

    def _store(self, rows: list[tuple], image: tuple[str, np.ndarray] | None) -> None:
        """In the worker: the image, its mips and its rows."""
        if image is not None:
            name, pixels = image
            self._save(name, pixels)
            if self.config.write_mipmaps:
                stem, ext = name.rsplit(".", 1)
                for k, level in enumerate(mip_chain(pixels)[1:], start=1):
                    self._save(f"{stem}_mip{k}.{ext}", level)
                    self.report.mip_files += 1
        self._table.insert(rows)

    def _wait(self) -> None:
        """Let the worker finish its image; its error, if any, is raised here."""
        pending, self._pending = self._pending, None
        if pending is not None:
            pending.result()

    def _save(self, name: str, pixels: np.ndarray) -> None:
        h, w, bands = pixels.shape
        mem = gdal.GetDriverByName("MEM").Create("", w, h, bands, gdal.GDT_Byte)
        mem.WriteArray(pixels, interleave="pixel")
        ext = name.rsplit(".", 1)[1]
        driver = gdal.GetDriverByName("JPEG" if ext == "jpg" else "PNG")
        if driver.CreateCopy(str(self.folder / name), mem, options=self._options[ext]) is None:
            raise InputError(f"Cannot write the texture image {self.folder / name}: {gdal.GetLastErrorMsg()}")

    def finish(self) -> None:
        """Index the table in the order the CityGML writer reads it (image, target, feature, face)."""
        self._wait()
        order = (step_layers.TEX_IMAGE, step_layers.TEX_TARGET, step_layers.TEX_FEATURE, step_layers.TEX_FACE)
        columns = ", ".join(f'"{c}"' for c in order)
        table = step_layers.TEXCOORD_TABLE
        self._table.db.execute(f'CREATE INDEX "{table}_order" ON "{table}" ({columns})')

    def close(self) -> None:
        """Stop the worker (after its current image) and close the table; on success after ``finish``."""
        self._worker.shutdown(wait=True)
        self._table.close()


class _AtlasPacker:
    """Shelf packing of padded roof islands into atlases, each written when the next island does not fit."""

    def __init__(self, config: TextureConfig, out: _Output):
        self.size, self.gutter, self.out = config.atlas_size, config.gutter, out
        self.align = 1 << (config.gutter.bit_length() - 1) if config.gutter else 1  # largest 2^k ≤ gutter
        self.count = 0
        self._reset()

    def _reset(self) -> None:
        self.pixels = np.full((self.size, self.size, 3), _BACKGROUND, dtype=np.uint8)
        self.items: list[_Rings] = []  # one ring each
        self.placements: list[tuple[float, ...]] = []  # as _Output.write takes them
        self.x = self.y = self.shelf = self.used_w = 0

    def add(self, ring: _Rings, patch: _Patch) -> None:
        h, w = patch.pixels.shape[:2]
        g, a = self.gutter, self.align
        sw, sh = -(-(w + 2 * g) // a) * a, -(-(h + 2 * g) // a) * a
        if self.x + sw > self.size:  # next shelf
            self.x, self.y, self.shelf = 0, self.y + self.shelf, 0
        if self.y + sh > self.size:
            self.flush()
        self.pixels[self.y:self.y + sh, self.x:self.x + sw] = np.pad(
            patch.pixels, ((g, sh - h - g), (g, sw - w - g), (0, 0)), mode="edge")
        self.items.append(ring)
        self.placements.append((self.x + g, self.y + g, w, h, *patch.extent))
        self.x += sw
        self.shelf = max(self.shelf, sh)
        self.used_w = max(self.used_w, self.x)

    def flush(self) -> None:
        """Write the current atlas, cropped to powers of two around the used area, and start a new one."""
        if self.items:
            w, h = _pow2_ceil(self.used_w), _pow2_ceil(self.y + self.shelf)
            self.out.write(f"roof_atlas_{self.count:04d}", self.pixels[:h, :w], _Rings.concat(self.items),
                           np.array(self.placements, dtype=np.float64))
            self.out.report.atlases += 1
            self.count += 1
        self._reset()


def _pow2_ceil(n: int) -> int:
    return 1 << max(0, n - 1).bit_length()
