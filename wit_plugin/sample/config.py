"""What to generate (both modes of the sample generator) and the checks every mode shares."""
from __future__ import annotations

from dataclasses import dataclass

from ..infra.errors import InputError

MANIFEST = "sample_manifest.json"


@dataclass
class SampleConfig:
    """What to generate. ``n_buildings``, when given, overrides ``radius_m``.

    The centre, radius and building count apply to the synthetic city only; drawing from given
    layers (``draw_from_layers``) takes its area from the layers and uses the rest.
    """

    center_lon: float = 127.1020  # Suseo station (EPSG:4737 degrees)
    center_lat: float = 37.4876
    radius_m: float = 1000.0  # half-side of the square study area
    n_buildings: int | None = None
    seed: int = 42
    ortho_pixel_size: float = 0.5
    dem_cell_size: float = 5.0
    with_ortho: bool = True
    with_dem: bool = True


def check_rasters(config: SampleConfig) -> None:
    """The raster settings both modes use; InputError naming the one out of range."""
    if not 0.05 <= config.ortho_pixel_size <= 50.0:
        raise InputError(f"orthoimage pixel size {config.ortho_pixel_size} m is out of range (0.05–50 m)")
    if not 0.5 <= config.dem_cell_size <= 500.0:
        raise InputError(f"DEM cell size {config.dem_cell_size} m is out of range (0.5–500 m)")
