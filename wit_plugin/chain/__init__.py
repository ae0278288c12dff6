"""The whole chain as one core call (``run_city_model``), and its coverage checks."""
from .citymodel import (
    OUTSIDE_ORTHO_CHOICES,
    ChainInputs,
    ChainOptions,
    ChainReport,
    PreparedLayers,
    PrepareLayers,
    run_city_model,
)

__all__ = ["OUTSIDE_ORTHO_CHOICES", "ChainInputs", "ChainOptions", "ChainReport", "PrepareLayers", "PreparedLayers",
           "run_city_model"]
