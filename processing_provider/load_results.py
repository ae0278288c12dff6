"""The chain's results into the QGIS project when a run from the GUI finishes: one layer group with
the LoD1 buildings (a 3D renderer extruding the footprints by their height), the terrain TIN (3D
polygons at their heights) and, on QGIS ≥ 3.34, the 3D Tiles tileset as a tiled-scene layer with its
3D renderer — so the 3D map view shows the city without leaving QGIS.

Processing loads the layers queued with ``context.addLayerToLoadOnCompletion`` after the algorithm
(Processing's own post-processing, in the GUI only); a post-processor per layer then moves it into
the group and sets its 3D renderer, after Processing has applied its default style.
"""
from __future__ import annotations

from qgis.core import (
    Qgis,
    QgsMapLayer,
    QgsProcessingContext,
    QgsProcessingLayerPostProcessorInterface,
    QgsProperty,
    QgsVectorLayer,
)
from qgis.PyQt.QtGui import QColor

from ..wit_plugin.infra import step_layers
from ..wit_plugin.infra.io.layersource import LayerSource
from .translation import tr, translatable

GROUP_NAME = translatable("WIT city model")
BUILDING_RGB, TERRAIN_RGB = (222, 213, 196), (128, 146, 108)
TILED_SCENE_VERSION = 33400  # QgsTiledSceneLayer ("cesiumtiles") since QGIS 3.34

_processors: list = []  # post-processors must outlive the run that queued them


class _IntoGroup(QgsProcessingLayerPostProcessorInterface):
    """Moves the loaded layer into the results group (created on top if missing) at its place in
    ``order`` (the layer names, top first: QGIS versions post-process the layers in different orders),
    then styles it."""

    def __init__(self, group_name: str, order: list[str], style=None):
        super().__init__()
        self.group_name, self.order, self.style = group_name, order, style

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802 - QGIS API
        project = context.project()
        root = project.layerTreeRoot()
        group = root.findGroup(self.group_name) or root.insertGroup(0, self.group_name)
        node = root.findLayer(layer.id())
        if node is not None and node.parent() is not group:
            parent = node.parent()
            after = self.order[self.order.index(layer.name()) + 1:] if layer.name() in self.order else []
            children = group.children()
            place = next((i for i, child in enumerate(children) if child.name() in after), len(children))
            group.insertLayer(place, layer)
            parent.removeChildNode(node)
        if self.style is not None:
            self.style(layer)


def load_results(context: QgsProcessingContext, lod1: str | None = None, tin: str | None = None,
                 tileset: str | None = None, group_name: str | None = None) -> list[str]:
    """Queue the results for loading into ``context.project()`` at the end of the run; returns the layer names.

    ``lod1``, ``tin``: GeoPackage paths (the chain's work files or kept outputs); ``tileset``: path of a
    ``tileset.json`` (loaded on QGIS ≥ 3.34 only). Call it from ``execute`` of the algorithm that made them.
    """
    group_name = group_name or tr(GROUP_NAME)
    layers: list[tuple[QgsMapLayer, object]] = []
    if lod1:
        buildings = QgsVectorLayer(str(LayerSource(lod1, step_layers.LOD1_LAYER)), tr("LoD1 buildings"), "ogr")
        buildings.setSubsetString(f"\"{step_layers.FACE_TYPE}\" = 'ground'")  # footprints, extruded by their height
        layers.append((buildings, _building_renderer))
    if tin:
        layers.append((QgsVectorLayer(str(LayerSource(tin, step_layers.TIN_LAYER)), tr("Terrain (TIN)"), "ogr"),
                       _terrain_renderer))
    if tileset and Qgis.QGIS_VERSION_INT >= TILED_SCENE_VERSION:
        from qgis.core import QgsTiledSceneLayer  # QGIS ≥ 3.34 only

        layers.append((QgsTiledSceneLayer(tileset, tr("3D Tiles"), "cesiumtiles"), _tileset_renderer))
    return _queue(context, layers, group_name)


def _queue(context: QgsProcessingContext, layers: list[tuple[QgsMapLayer, object]], group_name: str) -> list[str]:
    """Queue valid layers for loading at the end of the run, each moved into the group (in this
    order, top first) and styled."""
    valid = [(layer, style) for layer, style in layers if layer.isValid()]
    names = [layer.name() for layer, _ in valid]
    for layer, style in valid:
        context.temporaryLayerStore().addMapLayer(layer)
        details = QgsProcessingContext.LayerDetails(layer.name(), context.project(), layer.name())
        processor = _IntoGroup(group_name, names, style)
        _processors.append(processor)
        details.setPostProcessor(processor)
        context.addLayerToLoadOnCompletion(layer.id(), details)
    return names


def _polygon_symbol(rgb: tuple[int, int, int], extrusion_field: str | None = None):
    """A 3D polygon symbol at the features' own heights (absolute), optionally extruded by a field."""
    from qgis._3d import QgsPhongMaterialSettings, QgsPolygon3DSymbol
    from qgis.core import QgsAbstract3DSymbol

    symbol = QgsPolygon3DSymbol()
    if hasattr(Qgis, "AltitudeClamping"):  # QGIS ≥ 3.26
        symbol.setAltitudeClamping(Qgis.AltitudeClamping.Absolute)
    else:
        from qgis._3d import Qgs3DTypes

        symbol.setAltitudeClamping(Qgs3DTypes.AltitudeClamping.AltClampAbsolute)
    material = QgsPhongMaterialSettings()
    material.setDiffuse(QColor(*rgb))
    material.setAmbient(QColor(*rgb).darker(150))
    # QGIS 3.22's Python bindings have setMaterial only; 3.44's setMaterialSettings only
    set_material = getattr(symbol, "setMaterialSettings", None) or symbol.setMaterial
    set_material(material)
    if extrusion_field:
        properties = symbol.dataDefinedProperties()
        properties.setProperty(QgsAbstract3DSymbol.Property.PropertyExtrusionHeight,
                               QgsProperty.fromField(extrusion_field))
        symbol.setDataDefinedProperties(properties)
    return symbol


def _set_renderer(layer: QgsVectorLayer, symbol) -> None:
    from qgis._3d import QgsVectorLayer3DRenderer

    renderer = QgsVectorLayer3DRenderer()
    renderer.setSymbol(symbol)
    layer.setRenderer3D(renderer)


def _building_renderer(layer: QgsVectorLayer) -> None:
    _set_renderer(layer, _polygon_symbol(BUILDING_RGB, extrusion_field=step_layers.HEIGHT))


def _terrain_renderer(layer: QgsVectorLayer) -> None:
    _set_renderer(layer, _polygon_symbol(TERRAIN_RGB))


def _tileset_renderer(layer) -> None:
    """The tiled-scene layer's 3D renderer (QGIS ≥ 3.34): without it a 3D map view does not show the
    tileset, only the 2D map does."""
    from qgis._3d import QgsTiledSceneLayer3DRenderer

    layer.setRenderer3D(QgsTiledSceneLayer3DRenderer())


def load_index(context: QgsProcessingContext, index: str, group_name: str | None = None) -> None:
    """Queue a tiled run's index (its tiles coloured by status) for loading into the results group."""
    layer = QgsVectorLayer(str(LayerSource(index, "tiles")), tr("Tiles of the run"), "ogr")
    _queue(context, [(layer, None)], group_name or tr(GROUP_NAME))
