"""The texture step's images in the tileset: copied once, shared by every tile, mip levels on demand.

Full-detail tiles reference the atlases and ground images of ``wit:wittexture`` as they are (same
files, same texture coordinates: nothing is re-cut). Coarser tiles reference mip level k of the same
atlas (``<image>_mip<k>.<ext>``, the texture step's naming): taken from the texture folder when it
wrote its mip chain, else computed with ``texture.images.mip_chain`` (the same box filter) and written
here. Texture coordinates are relative, so they hold for every level. Each image is decoded once
while it and its smaller levels stay cached (they serve the coarse terrain's sampling and the mip
files); the caches are bounded in bytes, so memory does not grow with the model.
"""
from __future__ import annotations

import shutil
from collections import OrderedDict
from pathlib import Path

import numpy as np
from osgeo import gdal

from ..infra.errors import InputError
from ..texture.images import mip_chain

TEXTURE_DIR = "textures"
_CACHE_BYTES = 96 * 2 ** 20


def encode_image(pixels: np.ndarray, fmt: str = "JPEG", quality: int = 85) -> bytes:
    """RGB pixels (rows × columns × 3, uint8) as JPEG or PNG bytes (GDAL, through /vsimem)."""
    h, w, bands = pixels.shape
    mem = gdal.GetDriverByName("MEM").Create("", w, h, bands, gdal.GDT_Byte)
    mem.WriteArray(np.ascontiguousarray(pixels), interleave="pixel")
    name = f"/vsimem/wit-tiles3d-{id(pixels)}.{'jpg' if fmt == 'JPEG' else 'png'}"
    options = [f"QUALITY={quality}"] if fmt == "JPEG" else ["ZLEVEL=6"]
    gdal.GetDriverByName(fmt).CreateCopy(name, mem, options=options)
    try:
        handle = gdal.VSIFOpenL(name, "rb")
        gdal.VSIFSeekL(handle, 0, 2)
        size = gdal.VSIFTellL(handle)
        gdal.VSIFSeekL(handle, 0, 0)
        data = gdal.VSIFReadL(1, size, handle)
        gdal.VSIFCloseL(handle)
    finally:
        gdal.Unlink(name)
    return bytes(data)


def read_rgb(path: Path) -> np.ndarray:
    """An image file as rows × columns × 3 uint8 (grey repeated, alpha dropped), read pixel-interleaved."""
    ds = gdal.Open(str(path))
    if ds is None:
        raise InputError(f"Cannot read the texture image {path}: re-run wit:wittexture.")
    bands = min(ds.RasterCount, 3) if ds.RasterCount != 2 else 1
    pixels = ds.ReadAsArray(band_list=list(range(1, bands + 1)), interleave="pixel")
    pixels = pixels.reshape(pixels.shape[0], pixels.shape[1], -1)
    if pixels.shape[2] == 1:
        pixels = np.repeat(pixels, 3, axis=2)
    return np.ascontiguousarray(pixels, dtype=np.uint8)


class TextureSet:
    """The texture folder's images (by number, as in the staging store) written into the tileset."""

    def __init__(self, folder: Path | None, names: list[str], output: Path, jpeg_quality: int):
        self.folder, self.names, self.output = folder, names, output / TEXTURE_DIR
        self.quality = jpeg_quality
        self.written: dict[str, int] = {}  # file name → bytes
        self._mips: OrderedDict[int, list[np.ndarray]] = OrderedDict()  # levels 1… of each image, by use
        self._full: OrderedDict[int, np.ndarray] = OrderedDict()  # levels 0 asked for, by use
        self._shapes: dict[int, tuple[int, int]] = {}

    def uri(self, number: int, level: int = 0) -> str:
        """Relative URI (from the tileset's root) of image ``number`` at mip ``level``, written on first use."""
        name = self.names[number]
        stem, _dot, ext = name.rpartition(".")
        file = name if level == 0 else f"{stem}_mip{level}.{ext}"
        if file not in self.written:
            target = self.output / file
            target.parent.mkdir(parents=True, exist_ok=True)
            source = self.folder / file if self.folder else None
            if source is not None and source.is_file():
                shutil.copyfile(source, target)
            elif level == 0:
                raise InputError(f"The texture image {source} is missing: re-run wit:wittexture.")
            else:
                fmt = "PNG" if ext.lower() == "png" else "JPEG"
                target.write_bytes(encode_image(self.level(number, level), fmt, self.quality))
            self.written[file] = target.stat().st_size
        return f"{TEXTURE_DIR}/{file}"

    def _path(self, number: int) -> Path:
        """Where image ``number`` is read from (decoding and headers need the texture folder)."""
        if self.folder is None:
            raise InputError(f"No texture folder was given: the image {self.names[number]} cannot be read.")
        return self.folder / self.names[number]

    def shape(self, number: int) -> tuple[int, int]:
        """Rows and columns of image ``number`` (read once from its header, not decoded)."""
        if number not in self._shapes:
            path = self._path(number)
            ds = gdal.Open(str(path))
            if ds is None:
                raise InputError(f"Cannot read the texture image {path}: re-run wit:wittexture.")
            self._shapes[number] = ds.RasterYSize, ds.RasterXSize
        return self._shapes[number]

    def level(self, number: int, level: int) -> np.ndarray:
        """Mip ``level`` of image ``number`` (the last level when the chain is shorter), decoded.

        Each image is decoded and its chain computed once while it stays cached: levels 0 and the smaller
        levels each in a cache of ``_CACHE_BYTES``, least recently used dropped beyond it (a leaf samples its
        ground images and the roof atlases over it, in turn), so memory does not grow with the model."""
        if level <= 0:
            if number in self._full:
                self._full.move_to_end(number)
            else:
                self._full[number] = read_rgb(self._path(number))
                _bound(self._full)
            return self._full[number]
        if number in self._mips:
            self._mips.move_to_end(number)
        else:
            chain = mip_chain(self._full[number] if number in self._full
                              else read_rgb(self._path(number)))
            self._mips[number] = chain[1:]
            _bound(self._mips)
        mips = self._mips[number]
        return mips[min(level, len(mips)) - 1] if mips else self.level(number, 0)


def _bound(cache: OrderedDict) -> None:
    """Drop the least recently used entries (all but the newest) while the cache holds over ``_CACHE_BYTES``."""
    def size(entry) -> int:
        return sum(a.nbytes for a in entry) if isinstance(entry, list) else entry.nbytes

    while len(cache) > 1 and sum(size(e) for e in cache.values()) > _CACHE_BYTES:
        cache.popitem(last=False)
