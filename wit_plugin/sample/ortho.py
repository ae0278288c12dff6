"""What both sample modes write: NGII-named orthoimage tiles and the DEM, one tile at a time.

The tiles are cut as NGII cuts its orthoimages (the sheet's projected envelope in EPSG:5186 plus
50 m on every side), carry no georeferencing and are named by their 1:5,000 sheet number; each has
its own exposure, so the seams show as in real flight strips.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..infra import mapsheet
from ..infra.feedback import SILENT, Feedback
from .rasters import OrthoScene, Rasteriser, Terrain, noise_tables, render_tile, write_dem

RASTER_CRS = "EPSG:5186"
ORTHO_MARGIN = 50.0  # NGII tiles cover the sheet envelope plus 50 m on every side
DEM_MARGIN = 250.0
ORTHO_DIR = "ortho"  # the tiles in a folder of their own, as wit:georeferencemapsheets takes them
DEM_NAME = "dem_5186.tif"


def tile_name(sheet: mapsheet.MapSheet) -> str:
    """NGII-style file name, e.g. ``(B060)정사영상_2022_37709005.tif``."""
    return f"(B060)정사영상_2022_{sheet.number}.tif"


def tile_gain(sheet: mapsheet.MapSheet, seed: int) -> np.ndarray:
    """Exposure and white balance of a tile: checkerboard of darker/brighter sheets (0.85–1.15)."""
    col, row = round(sheet.west / 0.025), round(sheet.south / 0.025)
    rng = np.random.default_rng([seed, 31, col, row])
    base = rng.uniform(0.85, 0.96) if (col + row) % 2 == 0 else rng.uniform(1.04, 1.15)
    return (base * rng.uniform(0.97, 1.03, 3)).astype(np.float32)


def sheet_envelopes(sheets: list[mapsheet.MapSheet]) -> list[tuple[float, float, float, float]]:
    """Each tile's extent in EPSG:5186 (sheet envelope + margin), as wit:georeferencemapsheets computes it."""
    return [mapsheet.projected_envelope(s, RASTER_CRS, margin=ORTHO_MARGIN) for s in sheets]


def render_tiles(folder: Path, sheets: list[mapsheet.MapSheet], scene: OrthoScene, pixel: float, seed: int,
                 feedback: Feedback = SILENT) -> list[dict]:
    """Render one tile per sheet into ``folder/ortho``, strip by strip; the manifest row of each tile."""
    rasteriser = Rasteriser(scene)
    tables = noise_tables(seed, 32, 3)
    (folder / ORTHO_DIR).mkdir()
    rows = []
    for k, (sheet, envelope) in enumerate(zip(sheets, sheet_envelopes(sheets))):
        name = f"{ORTHO_DIR}/{tile_name(sheet)}"
        gain = tile_gain(sheet, seed)
        render_tile(folder / name, envelope, pixel, scene, rasteriser, gain, seed, tables,
                    feedback.scaled(100.0 * k / len(sheets), 100.0 * (k + 1) / len(sheets)))
        rows.append({"file": name, "sheet": sheet.number, "envelope_5186": [round(v, 3) for v in envelope],
                     "gain": [round(float(g), 4) for g in gain]})
    return rows


def write_sample_dem(path: Path, bounds: tuple[float, float, float, float], cell: float, terrain: Terrain,
                     seed: int, feedback: Feedback = SILENT) -> int:
    """The DEM over ``bounds`` (EPSG:5186) grown by ``DEM_MARGIN``; returns its number of -9999 holes."""
    grown = (bounds[0] - DEM_MARGIN, bounds[1] - DEM_MARGIN, bounds[2] + DEM_MARGIN, bounds[3] + DEM_MARGIN)
    return write_dem(path, grown, cell, terrain, np.random.default_rng([seed, 70]), feedback)
