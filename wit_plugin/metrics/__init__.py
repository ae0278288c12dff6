"""The paper's quality measures (Tables 17 and 19) and the seam step of the mosaic: ``wit:qualitymetrics``.

By responsibility: ``geometry`` (the model against its 2D sources, Table 17), ``texture`` (sharpness
and contrast, Table 19), ``seam`` (the colour step across tile borders of a merged orthoimage) and
``report`` (``quality_report``: the measures run together, the CSV, GeoPackage and HTML outputs).
"""
from __future__ import annotations

from .geometry import (
    MATCHED,
    MODEL_ONLY,
    SOURCE_ONLY,
    BuildingMetrics,
    GeometryMetrics,
    geometry_metrics,
    shape_similarity,
)
from .report import (
    BUILDINGS_LAYER,
    METRICS_TABLE,
    PAPER_TABLE17,
    PAPER_TABLE19,
    MetricRow,
    QualityReport,
    metric_rows,
    quality_report,
)
from .seam import SeamEdge, SeamMetrics, seam_metrics, seam_step, tile_footprints
from .texture import (
    BORDERS,
    IMAGE_SUFFIXES,
    ImageQuality,
    TextureMetrics,
    contrast,
    grayscale,
    laplacian_variance,
    texture_metrics,
)

__all__ = [
    "BORDERS", "BUILDINGS_LAYER", "IMAGE_SUFFIXES", "MATCHED", "METRICS_TABLE", "MODEL_ONLY", "PAPER_TABLE17",
    "PAPER_TABLE19", "SOURCE_ONLY", "BuildingMetrics", "GeometryMetrics", "ImageQuality", "MetricRow", "QualityReport",
    "SeamEdge", "SeamMetrics", "TextureMetrics", "contrast", "geometry_metrics", "grayscale", "laplacian_variance",
    "metric_rows", "quality_report", "seam_metrics", "seam_step", "shape_similarity", "texture_metrics",
    "tile_footprints",
]
