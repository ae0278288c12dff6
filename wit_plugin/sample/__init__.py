"""Deterministic sample data that looks like Korea's national data, for the demo, tests and benchmarks.

There is no open building layer or NGII orthoimage for Gangnam at hand, so we generate them:
road-name-address shapefiles (TL_SPBD_BULD, TL_SPRD_MANAGE, TL_SCCO_EMD) in CP949 without
``.cpg`` and in EPSG:5179, a DEM in EPSG:5186 with undeclared -9999 holes, and unreferenced
orthoimage TIFs named by their 1:5,000 sheet number, all from one seed. A few buildings carry
the defects real files have; ``sample_manifest.json`` says which.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from pyproj import Transformer

from .. import mapsheet
from ..errors import InputError
from ..feedback import SILENT, Feedback
from ..fileio import atomic_files
from .layout import CityLayout
from .rasters import Rasteriser, Terrain, build_scene, noise_tables, render_tile, write_dem
from .vectors import add_defects, build_roads, building_columns, select, write_layers

ORTHO_MARGIN = 50.0  # NGII tiles cover the sheet envelope plus 50 m on every side
DEM_MARGIN = 250.0
MANIFEST = "sample_manifest.json"
ORTHO_DIR = "ortho"  # the tiles in a folder of their own, as wit:georeferencemapsheets takes them
_DENSITY = 1.1e-3  # buildings per m² of the square, a first guess for ``n_buildings``
_MAX_BUILDINGS = 2_000_000


@dataclass
class SampleConfig:
    """What to generate. ``n_buildings``, when given, overrides ``radius_m``."""

    center_lon: float = 127.1020  # Suseo station (EPSG:4737 degrees)
    center_lat: float = 37.4876
    radius_m: float = 1000.0  # half-side of the square study area
    n_buildings: int | None = None
    seed: int = 42
    ortho_pixel_size: float = 0.5
    dem_cell_size: float = 5.0
    with_ortho: bool = True
    with_dem: bool = True


@dataclass
class SampleResult:
    """Where the files are and what they hold (defects: kind → BUL_MAN_NO values)."""

    folder: Path
    buildings: Path
    roads: Path
    districts: Path
    dem: Path | None
    ortho_tiles: list[Path]
    radius_m: float
    counts: dict[str, int]
    defects: dict[str, list[int]]
    manifest: Path
    tile_gains: dict[str, list[float]] = field(default_factory=dict)


def _check(config: SampleConfig) -> None:
    if not (124.0 <= config.center_lon < 132.0 and 33.0 <= config.center_lat < 43.0):
        raise InputError(f"centre {config.center_lon}, {config.center_lat} is outside Korea; NGII sheet "
                         "numbers exist only for 124–132°E, 33–43°N")
    if config.n_buildings is None and not 100.0 <= config.radius_m <= 30000.0:
        raise InputError(f"radius {config.radius_m} m is out of range: use 100–30,000 m")
    if config.n_buildings is not None and not 50 <= config.n_buildings <= _MAX_BUILDINGS:
        raise InputError(f"n_buildings {config.n_buildings} is out of range: use 50–{_MAX_BUILDINGS:,}")
    if not 0.05 <= config.ortho_pixel_size <= 50.0:
        raise InputError(f"orthoimage pixel size {config.ortho_pixel_size} m is out of range (0.05–50 m)")
    if not 0.5 <= config.dem_cell_size <= 500.0:
        raise InputError(f"DEM cell size {config.dem_cell_size} m is out of range (0.5–500 m)")


def _square_in(target: str, center: np.ndarray, half: float) -> tuple[float, float, float, float]:
    """Bounding box in ``target`` of the EPSG:5179 square (edges densified: projections bend them)."""
    t = np.linspace(-half, half, 41)
    xs = np.concatenate([t, np.full_like(t, half), t[::-1], np.full_like(t, -half)]) + center[0]
    ys = np.concatenate([np.full_like(t, -half), t, np.full_like(t, half), t[::-1]]) + center[1]
    x, y = Transformer.from_crs("EPSG:5179", target, always_xy=True).transform(xs, ys)
    return float(np.min(x)), float(np.min(y)), float(np.max(x)), float(np.max(y))


def _tile_gain(sheet: mapsheet.MapSheet, seed: int) -> np.ndarray:
    """Exposure and white balance of a tile: checkerboard of darker/brighter sheets (0.85–1.15)."""
    col, row = round(sheet.west / 0.025), round(sheet.south / 0.025)
    rng = np.random.default_rng([seed, 31, col, row])
    base = rng.uniform(0.85, 0.96) if (col + row) % 2 == 0 else rng.uniform(1.04, 1.15)
    return (base * rng.uniform(0.97, 1.03, 3)).astype(np.float32)


def tile_name(sheet: mapsheet.MapSheet) -> str:
    """NGII-style file name, e.g. ``(B060)정사영상_2022_37709005.tif``."""
    return f"(B060)정사영상_2022_{sheet.number}.tif"


def generate_sample(output_dir: str | Path, config: SampleConfig = SampleConfig(),
                    feedback: Feedback = SILENT) -> SampleResult:
    """Generate the sample into ``output_dir``; nothing appears there unless every file is complete."""
    _check(config)
    folder = Path(output_dir)
    lon_lat = Transformer.from_crs("EPSG:4737", "EPSG:5179", always_xy=True)
    center = np.array(lon_lat.transform(config.center_lon, config.center_lat))
    terrain = Terrain(config.seed)
    layout = CityLayout(tuple(center), config.seed, terrain)

    feedback.info("Laying out streets, blocks and buildings")
    data = select(layout, config.radius_m if config.n_buildings is None else None, config.n_buildings, _DENSITY)
    feedback.check_canceled()
    build_roads(layout, data)
    building_columns(data, np.random.default_rng([config.seed, 60]))
    add_defects(data, np.random.default_rng([config.seed, 40]))
    feedback.progress(20.0)

    lon0, lat0, lon1, lat1 = _square_in("EPSG:4737", center, data.half)
    sheets = mapsheet.sheets_covering(lon0, lat0, lon1, lat1) if config.with_ortho else []
    names = {"buildings": "TL_SPBD_BULD.shp", "roads": "TL_SPRD_MANAGE.shp", "districts": "TL_SCCO_EMD.shp"}
    dem_name = "dem_5186.tif" if config.with_dem else None
    targets = [folder / n for n in names.values()] + [folder / MANIFEST]
    manifest: dict = {"generator": "wit_plugin.sample", "config": asdict(config), "radius_m": data.half,
                      "center_5179": [float(c) for c in center], "vector_crs": "EPSG:5179",
                      "vector_encoding": "CP949", "raster_crs": "EPSG:5186"}
    if sheets:
        targets.append(folder / ORTHO_DIR)
    with atomic_files(targets) as tmp:
        counts = write_layers(tmp, data, np.random.default_rng([config.seed, 61]))
        if dem_name:
            feedback.info("Writing the DEM")
            x0, y0, x1, y1 = _square_in("EPSG:5186", center, data.half)
            bounds = (x0 - DEM_MARGIN, y0 - DEM_MARGIN, x1 + DEM_MARGIN, y1 + DEM_MARGIN)
            manifest["dem_holes"] = write_dem(tmp / dem_name, bounds, config.dem_cell_size, terrain,
                                              np.random.default_rng([config.seed, 70]), feedback.scaled(20, 30))
        tiles, gains = [], {}
        if sheets:
            feedback.info(f"Rendering {len(sheets)} orthoimage tile(s)")
            envelopes = [mapsheet.projected_envelope(s, "EPSG:5186", margin=ORTHO_MARGIN) for s in sheets]
            to_5179 = Transformer.from_crs("EPSG:5186", "EPSG:5179", always_xy=True)
            xs, ys = to_5179.transform([e[i] for e in envelopes for i in (0, 2)],
                                       [e[i] for e in envelopes for i in (1, 3)])
            scene = build_scene(layout, (min(xs) - 100, min(ys) - 100, max(xs) + 100, max(ys) + 100), config.seed)
            rasteriser = Rasteriser(scene)
            tables = noise_tables(config.seed, 32, 3)
            (tmp / ORTHO_DIR).mkdir()
            for k, (sheet, envelope) in enumerate(zip(sheets, envelopes)):
                name = f"{ORTHO_DIR}/{tile_name(sheet)}"
                gain = _tile_gain(sheet, config.seed)
                render_tile(tmp / name, envelope, config.ortho_pixel_size, scene, rasteriser, gain, config.seed,
                            tables, feedback.scaled(30 + 70 * k / len(sheets), 30 + 70 * (k + 1) / len(sheets)))
                tiles.append(name)
                gains[name] = [round(float(g), 4) for g in gain]
            manifest["tiles"] = [{"file": n, "sheet": s.number, "envelope_5186": [round(v, 3) for v in e],
                                  "gain": gains[n]} for n, s, e in zip(tiles, sheets, envelopes)]
        counts["tiles"] = len(tiles)
        manifest.update(files={**names, "dem": dem_name, "ortho": tiles}, counts=counts, defects=data.defects)
        (tmp / MANIFEST).write_text(json.dumps(manifest, ensure_ascii=False, indent=1, sort_keys=True),
                                    encoding="utf-8")
    feedback.progress(100.0)
    return SampleResult(folder, folder / names["buildings"], folder / names["roads"], folder / names["districts"],
                        folder / dem_name if dem_name else None, [folder / t for t in tiles], data.half, counts,
                        data.defects, folder / MANIFEST, gains)
