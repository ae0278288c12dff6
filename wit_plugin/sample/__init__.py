"""Deterministic sample data that looks like Korea's national data, for the demo, tests and benchmarks.

There is no open building layer or NGII orthoimage for Gangnam at hand, so we generate them:
road-name-address shapefiles (TL_SPBD_BULD, TL_SPRD_MANAGE, TL_SCCO_EMD) in CP949 without
``.cpg`` and in EPSG:5179, a DEM in EPSG:5186 with undeclared -9999 holes, and unreferenced
orthoimage TIFs named by their 1:5,000 sheet number, all from one seed. A few buildings carry
the defects real files have; ``sample_manifest.json`` says which.

With real building and road layers at hand, :func:`draw_from_layers` draws the orthoimage (and
the DEM) for them instead (``given.py``), so that a run on real vectors has an image that matches.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from pyproj import Transformer

from ..infra import mapsheet
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io import jsontext
from ..infra.io.fileio import atomic_files
from .config import MANIFEST, SampleConfig, check_rasters
from .given import DrawnSample, GivenLayers, draw_from_layers
from .layout import CityLayout
from .ortho import DEM_NAME, ORTHO_DIR, render_tiles, sheet_envelopes, tile_name, write_sample_dem
from .rasters import Terrain, build_scene
from .vectors import add_defects, build_roads, building_columns, select, write_layers

__all__ = ["MANIFEST", "ORTHO_DIR", "DrawnSample", "GivenLayers", "SampleConfig", "SampleResult",
           "draw_from_layers", "generate_sample", "tile_name"]
_DENSITY = 1.1e-3  # buildings per m² of the square, a first guess for ``n_buildings``
_MAX_BUILDINGS = 2_000_000


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
    check_rasters(config)


def _square_in(target: str, center: np.ndarray, half: float) -> tuple[float, float, float, float]:
    """Bounding box in ``target`` of the EPSG:5179 square (edges densified: projections bend them)."""
    t = np.linspace(-half, half, 41)
    xs = np.concatenate([t, np.full_like(t, half), t[::-1], np.full_like(t, -half)]) + center[0]
    ys = np.concatenate([np.full_like(t, -half), t, np.full_like(t, half), t[::-1]]) + center[1]
    x, y = Transformer.from_crs("EPSG:5179", target, always_xy=True).transform(xs, ys)
    return float(np.min(x)), float(np.min(y)), float(np.max(x)), float(np.max(y))


def generate_sample(output_dir: str | Path, config: SampleConfig | None = None,
                    feedback: Feedback = SILENT) -> SampleResult:
    """Generate the sample into ``output_dir``; nothing appears there unless every file is complete."""
    config = config or SampleConfig()
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
    dem_name = DEM_NAME if config.with_dem else None
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
            manifest["dem_holes"] = write_sample_dem(tmp / dem_name, _square_in("EPSG:5186", center, data.half),
                                                     config.dem_cell_size, terrain, config.seed,
                                                     feedback.scaled(20, 30))
        tiles, gains = [], {}
        if sheets:
            feedback.info(f"Rendering {len(sheets)} orthoimage tile(s)")
            envelopes = sheet_envelopes(sheets)
            to_5179 = Transformer.from_crs("EPSG:5186", "EPSG:5179", always_xy=True)
            xs, ys = to_5179.transform([e[i] for e in envelopes for i in (0, 2)],
                                       [e[i] for e in envelopes for i in (1, 3)])
            scene = build_scene(layout, (min(xs) - 100, min(ys) - 100, max(xs) + 100, max(ys) + 100), config.seed)
            manifest["tiles"] = render_tiles(tmp, sheets, scene, config.ortho_pixel_size, config.seed,
                                             feedback.scaled(30, 100))
            tiles = [row["file"] for row in manifest["tiles"]]
            gains = {row["file"]: row["gain"] for row in manifest["tiles"]}
        counts["tiles"] = len(tiles)
        manifest.update(files={**names, "dem": dem_name, "ortho": tiles}, counts=counts, defects=data.defects)
        (tmp / MANIFEST).write_text(jsontext.dumps(manifest, ensure_ascii=False, indent=1, sort_keys=True),
                                    encoding="utf-8")
    feedback.progress(100.0)
    return SampleResult(folder, folder / names["buildings"], folder / names["roads"], folder / names["districts"],
                        folder / dem_name if dem_name else None, [folder / t for t in tiles], data.half, counts,
                        data.defects, folder / MANIFEST, gains)
