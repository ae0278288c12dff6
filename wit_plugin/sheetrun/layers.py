"""Prepared layers for one tile, so that neighbouring tiles agree where they meet.

* Roads and legal dongs are prepared once for the whole run (``prepare_context``): a road is
  simplified and buffered as one line whatever tile it crosses; each tile takes the same polygons
  (``clip_context``) and its terrain cuts them along the same border.
* Buildings are prepared per tile (``prepare_vectors`` with a ``TileOwner``): the tile keeps the
  buildings it owns, simplified together with their neighbours within ``CONTEXT_MARGIN`` so walls
  shared across the border are simplified alike in both tiles, and writes the neighbours' buildings
  that cross into it as ``foreign_buildings`` (holes in its terrain).
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pyproj
import shapely
from shapely.geometry.base import BaseGeometry

from ..infra import step_layers
from ..infra.feedback import SILENT, Feedback
from ..infra.io.fileio import atomic_file
from ..infra.io.layersource import LayerSource
from ..infra.io.vector_io import OutputLayer, open_layer, read_prepared, write_gpkg
from ..prepare.area import StudyArea
from ..prepare.vectors import PrepareConfig, prepare_vectors
from .plan import TileOwner

#: neighbours within this distance of a tile take part in simplifying its buildings (m)
CONTEXT_MARGIN = 100.0
CONTEXT_LAYERS = (step_layers.PREPARED_ROADS, step_layers.PREPARED_DISTRICTS)


def prepare_context(roads: str | None, districts: str | None, area: BaseGeometry, target_crs: str, output: str,
                    encoding: str | None = None, feedback: Feedback = SILENT) -> list[str]:
    """Roads and legal dongs for the whole run's ``area`` into ``output``; the layers written."""
    if not (roads or districts):
        return []
    report = prepare_vectors(None, roads, districts, StudyArea.polygon(area, target_crs), output,
                             PrepareConfig(target_crs=target_crs, encoding=encoding,
                                           stats_csv=str(Path(output).with_suffix(".csv"))), feedback)
    return [name for name in report.layers if name in CONTEXT_LAYERS]


def clip_context(context: str, layers: Sequence[str], area: BaseGeometry, output: str) -> list[str]:
    """The run's road and dong polygons that meet the tile's ``area``, into ``output``; the layers written.

    They are not cut here: the terrain cuts them at the tile's border on the 1 mm grid as it cuts the
    area itself, so a road edge along the border is the border (a cut made here would run a fraction
    of a millimetre beside it and bend the border on one side only).
    """
    written = []
    out_layers = []
    crs = None
    shapely.prepare(area)
    for name in layers:
        source = read_prepared(LayerSource(context, name), name)
        crs = source.crs
        near = np.flatnonzero(shapely.intersects(area, source.geoms))
        if not len(near):
            continue
        piece = source.take(near)
        out_layers.append(OutputLayer(name, piece.fields, piece.columns, piece.geoms))
        written.append(name)
    if out_layers and crs is not None:  # (a layer was written: crs is set)
        with atomic_file(output) as tmp:
            write_gpkg(tmp, out_layers, crs)
    return written


def prepare_tile_buildings(buildings: str, tile_area: BaseGeometry, owner: TileOwner, output: str,
                           encoding: str | None = None, feedback: Feedback = SILENT) -> list[str]:
    """The buildings ``owner`` accepts (and the foreign ones crossing in) into ``output``; layers written
    (without ``PREPARED_BUILDINGS`` when the tile owns no building: its model is then the ground alone)."""
    config = PrepareConfig(target_crs=owner.target_crs, encoding=encoding, owner=owner,
                           context_margin=CONTEXT_MARGIN, stats_csv=str(Path(output).with_suffix(".csv")))
    report = prepare_vectors(buildings, None, None, StudyArea.polygon(tile_area, owner.target_crs), output, config,
                             feedback)
    owned = any(s.layer == step_layers.PREPARED_BUILDINGS and s.features_out for s in report.stats)
    return [name for name in report.layers if owned or name != step_layers.PREPARED_BUILDINGS]


def area_of_layer(path: str, target_crs: str) -> BaseGeometry:
    """The box of a layer's extent in ``target_crs`` ("everything the buildings layer covers")."""
    _ds, layer, _ = open_layer(path)  # the dataset outlives the layer
    xmin, xmax, ymin, ymax = layer.GetExtent()
    srs = layer.GetSpatialRef()
    source = pyproj.CRS.from_wkt(srs.ExportToWkt()) if srs is not None else pyproj.CRS.from_user_input(target_crs)
    box = shapely.segmentize(shapely.box(xmin, ymin, xmax, ymax), max(xmax - xmin, ymax - ymin) / 64 or 1.0)
    transformer = pyproj.Transformer.from_crs(source, target_crs, always_xy=True)
    return shapely.transform(box, lambda xy: np.column_stack(transformer.transform(xy[:, 0], xy[:, 1]))).envelope
