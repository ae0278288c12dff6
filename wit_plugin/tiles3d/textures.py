"""The texture step's images in the tileset: copied once, shared by every tile, mip levels on demand.

Full-detail tiles reference the atlases and ground images of ``wit:wittexture`` as they are (same
files, same texture coordinates: nothing is re-cut). Coarser tiles reference mip level k of the same
atlas (``<image>_mip<k>.<ext>``, the texture step's naming): taken from the texture folder when it
wrote its mip chain, else computed with ``texture.mip_chain`` (the same box filter) and written
here. Texture coordinates are relative, so they hold for every level. Decoded levels are kept for
a few images only (sampling the coarse terrain's images), so memory does not grow with the model.
"""
from __future__ import annotations

import shutil
from collections import OrderedDict
from pathlib import Path

import numpy as np
from osgeo import gdal

from ..errors import InputError
from ..texture import mip_chain

TEXTURE_DIR = "textures"
_CACHED_IMAGES = 3


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
    """An image file as rows × columns × 3 uint8 (grey repeated, alpha dropped)."""
    ds = gdal.Open(str(path))
    if ds is None:
        raise InputError(f"Cannot read the texture image {path}: re-run wit:wittexture.")
    pixels = ds.ReadAsArray()
    pixels = pixels[None] if pixels.ndim == 2 else pixels
    pixels = np.repeat(pixels, 3, axis=0) if len(pixels) == 1 else pixels[:3]
    return np.ascontiguousarray(np.moveaxis(pixels, 0, -1).astype(np.uint8))


class TextureSet:
    """The texture folder's images (by number, as in the staging store) written into the tileset."""

    def __init__(self, folder: Path | None, names: list[str], output: Path, jpeg_quality: int):
        self.folder, self.names, self.output = folder, names, output / TEXTURE_DIR
        self.quality = jpeg_quality
        self.written: dict[str, int] = {}  # file name → bytes
        self._levels: OrderedDict[int, list[np.ndarray]] = OrderedDict()

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
                chain = self.levels(number)
                fmt = "PNG" if ext.lower() == "png" else "JPEG"
                target.write_bytes(encode_image(chain[min(level, len(chain) - 1)], fmt, self.quality))
            self.written[file] = target.stat().st_size
        return f"{TEXTURE_DIR}/{file}"

    def levels(self, number: int) -> list[np.ndarray]:
        """Decoded mip chain of image ``number`` (a few kept, least recently used dropped)."""
        if number in self._levels:
            self._levels.move_to_end(number)
        else:
            self._levels[number] = mip_chain(read_rgb(self.folder / self.names[number]))
            while len(self._levels) > _CACHED_IMAGES:
                self._levels.popitem(last=False)
        return self._levels[number]
