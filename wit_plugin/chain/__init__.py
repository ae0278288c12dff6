"""The whole chain as one core call (``run_city_model``), and its input checks (also the map-sheet runner's)."""
from .citymodel import (
    OUTSIDE_ORTHO_CHOICES,
    ChainInputs,
    ChainOptions,
    ChainReport,
    PartLayers,
    PreparedLayers,
    check_coverage,
    check_inputs,
    run_city_model,
    schema_cache_folder,
)

__all__ = ["OUTSIDE_ORTHO_CHOICES", "ChainInputs", "ChainOptions", "ChainReport", "PartLayers", "PreparedLayers",
           "check_coverage", "check_inputs", "run_city_model", "schema_cache_folder"]
