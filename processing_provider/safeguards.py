"""Checks every ``wit`` algorithm makes before it touches anything, so that nothing is lost: no input is
written over, and bad input is refused up front with its real problem.

Generic over the parameter definitions, so every algorithm (the chain and future ones too) gets
them without code of its own:

* a vector or raster input file that cannot work (missing, empty, a shapefile without its .shx or
  .dbf, a truncated GeoTIFF…) is named with its real problem, not QGIS's "Incorrect parameter value";
* a vector layer of the wrong geometry type (points given as buildings) is refused up front:
  ``QgsProcessingParameterVectorLayer`` type filters are not enforced for file paths;
* an output that would replace or share a file with an input (links, ``|layername=`` sources and
  sidecars resolved, see ``wit_plugin.infra.io.fileio``) is refused before anything is written.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from qgis.core import (
    QgsProcessing,
    QgsProcessingOutputLayerDefinition,
    QgsProcessingParameterDefinition,
    QgsProperty,
    QgsProviderRegistry,
    QgsWkbTypes,
)

from ..wit_plugin.infra.io import fileio
from ..wit_plugin.infra.io.layersource import LayerSource
from ..wit_plugin.infra.io.raster_io import raster_file_problem
from .qgis_compat import GeometryType, SourceType, code
from .translation import tr, translatable

VECTOR_TYPES = ("vector", "source")
LAYER_TYPES = (*VECTOR_TYPES, "raster", "layer")
#: Processing layer type filter (its integer: ``dataTypes()`` gives integers) → the geometry type it asks for
WANTED_GEOMETRY = {
    code(SourceType.VectorPoint): GeometryType.Point,
    code(SourceType.VectorLine): GeometryType.Line,
    code(SourceType.VectorPolygon): GeometryType.Polygon,
}
GEOMETRY_NAMES = {
    GeometryType.Point: translatable("points"),
    GeometryType.Line: translatable("lines"),
    GeometryType.Polygon: translatable("polygons"),
    GeometryType.Null: translatable("no geometry"),
}


@dataclass(frozen=True)
class Endpoint:
    """An input or output of a run: the parameter's label and the path (a folder for folder outputs)."""

    label: str
    path: str
    folder: bool = False


def _given(parameters: dict, name: str) -> bool:
    value = parameters.get(name)
    return value is not None and value != "" and value != []


def _layer_file(layer) -> str:
    """The file behind a layer ('' for a memory or database layer, which no output can overwrite)."""
    return QgsProviderRegistry.instance().decodeUri(layer.providerType(), layer.source()).get("path") or ""


def _layer_sources(algorithm, definition: QgsProcessingParameterDefinition, parameters: dict, context) -> list[str]:
    name = definition.name()
    kind = definition.type()
    if kind in LAYER_TYPES:
        layer = algorithm.parameterAsLayer(parameters, name, context)
        return [_layer_file(layer)] if layer is not None else []
    if kind == "multilayer":
        if code(definition.layerType()) == code(SourceType.File):
            return algorithm.parameterAsFileList(parameters, name, context)
        return [_layer_file(layer) for layer in algorithm.parameterAsLayerList(parameters, name, context)]
    if kind == "file" or (kind == "string" and name in algorithm.path_parameters):
        return [algorithm.parameterAsString(parameters, name, context)]
    return []


def inputs(algorithm, parameters: dict, context) -> list[Endpoint]:
    """Every file or folder the run reads, from its layer, file and path parameters."""
    found = []
    for definition in algorithm.parameterDefinitions():
        if definition.isDestination() or not _given(parameters, definition.name()):
            continue
        found += [Endpoint(definition.description(), str(fileio.source_file(source)))
                  for source in _layer_sources(algorithm, definition, parameters, context) if source]
    return found


def _sink_path(value, context) -> str:
    """The file behind a feature-sink value (``ogr:dbname='x.gpkg' table=…``, a path), '' for none."""
    if isinstance(value, QgsProcessingOutputLayerDefinition):
        value = value.sink
    if isinstance(value, QgsProperty):
        value = value.valueAsString(context.expressionContext())[0]
    text = str(value or "")
    if text == QgsProcessing.TEMPORARY_OUTPUT or text.startswith(("memory:", "postgres:", "postgis:")):
        return ""
    match = re.match(r"ogr:dbname='([^']*)'", text)
    return match.group(1) if match else str(fileio.source_file(text))


def outputs(algorithm, parameters: dict, context) -> list[Endpoint]:
    """Every file or folder the run writes, from its destination parameters (and ``extra_outputs``)."""
    found = []
    for definition in algorithm.destinationParameterDefinitions():
        name, kind = definition.name(), definition.type()
        if not _given(parameters, name):
            continue
        if kind == "sink":
            path = _sink_path(parameters[name], context)
        elif kind in ("rasterDestination", "vectorDestination"):
            path = algorithm.parameterAsOutputLayer(parameters, name, context)
        else:
            path = algorithm.parameterAsFileOutput(parameters, name, context)
        if path:
            found.append(Endpoint(definition.description(), str(fileio.source_file(path)),
                                  kind == "folderDestination"))
    return found + algorithm.extra_outputs(parameters, context)


def overlap_problem(algorithm, parameters: dict, context) -> str | None:
    """The message for the first output that would replace or share a file with an input, else None."""
    read = inputs(algorithm, parameters, context)
    for output in outputs(algorithm, parameters, context):
        for source in read:
            clash = fileio.overlap(output.path, source.path, output.folder)
            if clash is None:
                continue
            if output.folder:
                return tr("The output folder '{output}' ({output_path}) holds the input '{input}' ({input_path}): "
                          "choose an output folder that holds none of the inputs. Nothing was written.").format(
                    output=output.label, output_path=output.path, input=source.label, input_path=source.path)
            via = "" if fileio.same_file(clash, source.path) else tr(" (through {file})").format(file=clash)
            return tr("The output '{output}' ({output_path}) would overwrite the input '{input}' ({input_path})"
                      "{via}: choose another output name or folder. Nothing was written.").format(
                output=output.label, output_path=output.path, input=source.label, input_path=source.path, via=via)
    return None


def _raster_files(definition: QgsProcessingParameterDefinition, value) -> list[str]:
    """The file names given to a raster parameter (layer ids, names and URIs are left to QGIS)."""
    is_raster = definition.type() == "raster" or (
        definition.type() == "multilayer" and code(definition.layerType()) == code(SourceType.Raster))
    values = value if isinstance(value, (list, tuple)) else [value]
    paths = [LayerSource.parse(v).path for v in values if is_raster and isinstance(v, str)]
    return [p for p in paths if Path(p).suffix and "://" not in p and not p.startswith("/vsi")]


def file_problem(algorithm, parameters: dict, context) -> str | None:
    """What is wrong with a vector or raster input file (missing, empty, truncated, damaged…), before
    QGIS tries (and fails) to load it."""
    for definition in algorithm.parameterDefinitions():
        value = parameters.get(definition.name())
        problem = None
        if definition.type() in VECTOR_TYPES and isinstance(value, str) and value:
            problem = fileio.vector_file_problem(value)
        for path in _raster_files(definition, value):
            problem = problem or raster_file_problem(path)
        if problem:
            return f"{definition.description()}: {problem}"
    return None


def geometry_problem(algorithm, parameters: dict, context) -> str | None:
    """A vector input whose geometry type is not one its parameter asks for, named with both."""
    for definition in algorithm.parameterDefinitions():
        if definition.type() not in VECTOR_TYPES or not _given(parameters, definition.name()):
            continue
        wanted = {WANTED_GEOMETRY[code(t)] for t in definition.dataTypes() if code(t) in WANTED_GEOMETRY}
        if not wanted or len(wanted) < len(definition.dataTypes()):
            continue  # any geometry (or no filter) accepted
        layer = algorithm.parameterAsVectorLayer(parameters, definition.name(), context)
        if layer is None:
            continue  # QGIS's own check names a layer it cannot load
        found = QgsWkbTypes.geometryType(layer.wkbType())
        if found == GeometryType.Unknown or found in wanted:
            continue  # mixed types are sorted feature by feature, with counts
        return tr("{label}: the layer '{layer}' ({source}) has {found} ({wkb}); expected {wanted}.").format(
            label=definition.description(), layer=layer.name(), source=layer.source(),
            found=tr(GEOMETRY_NAMES.get(found, translatable("unknown geometries"))),
            wkb=QgsWkbTypes.displayString(layer.wkbType()),
            wanted=tr(" or ").join(tr(GEOMETRY_NAMES[g]) for g in sorted(wanted, key=code)))
    return None
