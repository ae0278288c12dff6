"""Parameters several algorithms share (study area, building heights, the chain's step outputs): declared
and read in one place, so the algorithms that take them take them alike."""
from __future__ import annotations

from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterEnum,
    QgsProcessingParameterExpression,
    QgsProcessingParameterField,
    QgsProcessingParameterFile,
    QgsProcessingParameterNumber,
    QgsProcessingParameterPoint,
    QgsProcessingParameterString,
    QgsProcessingParameterVectorLayer,
)

from .expressions import checked_expression
from .qgis_compat import FieldDataType, FileBehavior, NumberType, ParameterFlag, SourceType
from .translation import tr, translatable

WGS84 = QgsCoordinateReferenceSystem("EPSG:4326")

CENTER, RADIUS, AREA_LAYER = "CENTER", "RADIUS", "AREA_LAYER"
DISTRICT_CODE, DISTRICT_CODE_FIELD, DISTRICT_NAME_FIELD = "DISTRICT_CODE", "DISTRICT_CODE_FIELD", "DISTRICT_NAME_FIELD"
STOREY_HEIGHT, HEIGHT_FIELD, HEIGHT_EXPRESSION, DEFAULT_HEIGHT = (
    "STOREY_HEIGHT", "HEIGHT_FIELD", "HEIGHT_EXPRESSION", "DEFAULT_HEIGHT")
LOD1, TIN = "LOD1", "TIN"
ROADS, DISTRICTS, TEXTURES = "ROADS", "DISTRICTS", "TEXTURES"  # the model writers' other inputs
#: the raw road layer: centre lines (buffered by their width) or road polygons (the road surfaces as they are)
ROADS_TYPES = [SourceType.VectorLine, SourceType.VectorPolygon]
ROADS_LABEL = translatable("Roads: centre lines or road polygons (TL_SPRD_MANAGE, NGII N3L_A0020000 or N3A_A0010000, "
                           "OpenStreetMap…)")
TRIANGULATOR = "TRIANGULATOR"
MAX_EDGE, TOLERANCE = "MAX_EDGE", "TOLERANCE"
#: the TRIANGULATOR options, in the order of wit_plugin.terrain.triangulators.BACKENDS (a test holds them equal)
TRIANGULATOR_OPTIONS = (translatable("Triangle (non-commercial licence)"), translatable("CDT (MPL-2.0)"))
WEB_PROFILE = "WEB_PROFILE"
CITYJSON = "CITYJSON"
REBUILD = "REBUILD"
FACADES = "FACADES"
#: the FACADES options, in the order of wit_plugin.texture.config.FACADE_CHOICES (a test holds them equal)
FACADE_OPTIONS = (translatable("None: plain walls"),
                  translatable("Generated from each building's use and storeys (marked as generated)"))


def _advanced(parameter: QgsProcessingParameterDefinition) -> QgsProcessingParameterDefinition:
    parameter.setFlags(parameter.flags() | ParameterFlag.Advanced)
    return parameter


def add_area_parameters(algorithm, radius: float = 1000.0) -> None:
    """Centre + radius (default), or a polygon layer, or a legal dong by code or name."""
    # Optional with a default: QGIS 3.22 does not fill a missing mandatory point with its default.
    algorithm.addParameter(QgsProcessingParameterPoint(
        CENTER, tr("Centre of the study area"), defaultValue="127.1020,37.4876 [EPSG:4326]", optional=True))
    algorithm.addParameter(QgsProcessingParameterNumber(
        RADIUS, tr("Radius of the study area (m)"), NumberType.Double, defaultValue=radius,
        minValue=1.0))
    algorithm.addParameter(QgsProcessingParameterVectorLayer(
        AREA_LAYER, tr("Study area polygons (instead of centre and radius)"), [SourceType.VectorPolygon],
        optional=True))
    algorithm.addParameter(QgsProcessingParameterString(
        DISTRICT_CODE, tr("Legal dong: code (EMD_CD) or name, e.g. 11680101 or 역삼동 (instead of centre and radius)"),
        optional=True))
    algorithm.addParameter(_advanced(QgsProcessingParameterString(
        DISTRICT_CODE_FIELD, tr("Code field of the district layer (empty = EMD_CD)"), optional=True)))
    algorithm.addParameter(_advanced(QgsProcessingParameterString(
        DISTRICT_NAME_FIELD, tr("Name field of the district layer (empty = EMD_KOR_NM, EMD_ENG_NM)"), optional=True)))


def study_area(algorithm, parameters: dict, context, feedback=None):
    """The core's StudyArea: a district if one is named, else the area layer, else the circle."""
    from ..wit_plugin.prepare.area import StudyArea

    code = algorithm.parameterAsString(parameters, DISTRICT_CODE, context).strip()
    if code:
        return StudyArea.from_district_code(
            code, algorithm.parameterAsString(parameters, DISTRICT_CODE_FIELD, context).strip() or None,
            algorithm.parameterAsString(parameters, DISTRICT_NAME_FIELD, context).strip() or None)
    area_layer = algorithm.vector_source(parameters, AREA_LAYER, context, feedback)
    if area_layer is not None:
        return StudyArea.from_layer(area_layer)
    point = algorithm.parameterAsPoint(parameters, CENTER, context, WGS84)
    return StudyArea.circle(point.x(), point.y(), algorithm.parameterAsDouble(parameters, RADIUS, context))


def add_triangulator_parameter(algorithm) -> None:
    """The terrain's triangulation library; by default Triangle where it is installed, else CDT."""
    from ..wit_plugin.terrain import triangulators

    algorithm.addParameter(QgsProcessingParameterEnum(
        TRIANGULATOR, tr("Triangulator (licence: Triangle is free for non-commercial use only)"),
        options=[tr(label) for label in TRIANGULATOR_OPTIONS], defaultValue=triangulators.default_key()))


def add_mesh_parameters(algorithm) -> None:
    """The terrain mesh's maximum edge length and vertical tolerance (defaults: the core's)."""
    from ..wit_plugin.terrain import triangulators

    algorithm.addParameter(QgsProcessingParameterNumber(
        MAX_EDGE, tr("Maximum edge length (m)"), NumberType.Double, defaultValue=triangulators.MAX_EDGE,
        minValue=0.5))
    algorithm.addParameter(QgsProcessingParameterNumber(
        TOLERANCE, tr("Vertical tolerance (m)"), NumberType.Double,
        defaultValue=triangulators.VERTICAL_TOLERANCE, minValue=0.01))


def triangulator(algorithm, parameters: dict, context, feedback) -> int:
    """The TRIANGULATOR chosen; says so when Triangle is not installed and CDT is used instead."""
    from ..wit_plugin.terrain import triangulators

    key = algorithm.parameterAsEnum(parameters, TRIANGULATOR, context)
    if key != triangulators.TRIANGLE and not triangulators.available(triangulators.BACKENDS[triangulators.TRIANGLE]):
        feedback.info(tr("Triangle (package 'triangle') is not installed: the terrain is meshed with CDT "
                         "(MPL-2.0)."))
    return key


def add_height_parameters(algorithm, parent: str) -> None:
    """Storey height, height field, height expression and default height (the rules: wit_plugin.buildings.heights)."""
    algorithm.addParameter(QgsProcessingParameterNumber(
        STOREY_HEIGHT, tr("Storey height (m)"), NumberType.Double, defaultValue=3.0, minValue=0.5))
    algorithm.addParameter(QgsProcessingParameterField(
        HEIGHT_FIELD, tr("Height field (m), when floors are unknown (empty = recognised by name)"),
        parentLayerParameterName=parent, type=FieldDataType.Any, optional=True))
    algorithm.addParameter(QgsProcessingParameterExpression(
        HEIGHT_EXPRESSION, tr("Height expression (m), when floors and field are unknown"),
        parentLayerParameterName=parent, optional=True))
    algorithm.addParameter(QgsProcessingParameterNumber(
        DEFAULT_HEIGHT, tr("Default height (m)"), NumberType.Double, defaultValue=3.0, minValue=0.1))


def height_options(algorithm, parameters: dict, context, layer):
    """The core's HeightOptions, with the expression checked against ``layer`` (see expressions.py).

    Returns (options, the checked expression or None) so the caller can warn about failures after the run.
    """
    from ..wit_plugin.buildings.heights import HeightOptions

    fields = algorithm.parameterAsFields(parameters, HEIGHT_FIELD, context)
    expression = checked_expression(algorithm, parameters, HEIGHT_EXPRESSION, layer, context)
    return HeightOptions(
        height_field=fields[0] if fields else None,
        expression_text=expression.text if expression else None,
        expression=expression,
        storey_height=algorithm.parameterAsDouble(parameters, STOREY_HEIGHT, context),
        default_height=algorithm.parameterAsDouble(parameters, DEFAULT_HEIGHT, context),
    ), expression


SCHEMA_SETTING = "wit_citymodel/schema_dir"


def schema_choice(algorithm, parameters: dict, name: str, context) -> tuple[str | None, str]:
    """(the folder overriding the shipped schemas — parameter, else QGIS setting — or None, the download cache)."""
    from pathlib import Path

    from qgis.core import QgsApplication, QgsSettings

    configured = (algorithm.parameterAsFile(parameters, name, context)
                  or QgsSettings().value(SCHEMA_SETTING, "", type=str))
    return configured or None, str(Path(QgsApplication.qgisSettingsDirPath()) / "cache" / "wit_citymodel")


def add_model_layer_parameters(algorithm, lod1_optional: bool = True) -> None:
    """The chain's step outputs an algorithm reads: the LoD1 buildings and the terrain TIN (optional)."""
    algorithm.addParameter(QgsProcessingParameterVectorLayer(
        LOD1, tr("LoD1 buildings (wit:extrudebuildings)"), [SourceType.VectorPolygon], optional=lod1_optional))
    algorithm.addParameter(QgsProcessingParameterVectorLayer(
        TIN, tr("Terrain TIN (wit:triangulateterrain)"), [SourceType.VectorPolygon], optional=True))


def add_model_parameters(algorithm) -> None:
    """What the model writers (wit:writecitygml, wit:exportcityjson) read: the LoD1 buildings, the TIN, the
    prepared roads and dongs and the texture folder."""
    add_model_layer_parameters(algorithm, lod1_optional=False)
    algorithm.addParameter(QgsProcessingParameterVectorLayer(
        ROADS, tr("Road polygons (wit:preparevectors)"), [SourceType.VectorPolygon], optional=True))
    algorithm.addParameter(QgsProcessingParameterVectorLayer(
        DISTRICTS, tr("Legal dongs (wit:preparevectors)"), [SourceType.VectorPolygon], optional=True))
    algorithm.addParameter(QgsProcessingParameterFile(
        TEXTURES, tr("Texture folder (wit:wittexture)"), behavior=FileBehavior.Folder, optional=True))


def model_inputs(algorithm, parameters: dict, context, feedback):
    """The core's ``CityGMLInputs`` from ``add_model_parameters``'s parameters."""
    from ..wit_plugin.citygml.inputs import CityGMLInputs

    return CityGMLInputs(
        lod1=algorithm.vector_source(parameters, LOD1, context, feedback),
        tin=algorithm.vector_source(parameters, TIN, context, feedback),
        roads=algorithm.vector_source(parameters, ROADS, context, feedback),
        districts=algorithm.vector_source(parameters, DISTRICTS, context, feedback),
        textures=algorithm.parameterAsFile(parameters, TEXTURES, context) or None)


def add_facade_parameter(algorithm) -> None:
    """Wall textures: none, or generated facades (the core's default)."""
    from ..wit_plugin.infra.step_layers import DEFAULT_FACADES, FACADE_CHOICES

    algorithm.addParameter(QgsProcessingParameterEnum(
        FACADES, tr("Wall textures (an orthoimage sees no facades)"), options=[tr(o) for o in FACADE_OPTIONS],
        defaultValue=FACADE_CHOICES.index(DEFAULT_FACADES)))


def facade_choice(algorithm, parameters: dict, context) -> str:
    """The FACADES parameter as ``TextureConfig.facades`` takes it."""
    from ..wit_plugin.infra.step_layers import FACADE_CHOICES

    return FACADE_CHOICES[algorithm.parameterAsEnum(parameters, FACADES, context)]


def add_web_profile_parameter(algorithm, advanced: bool = False) -> None:
    """The 3D Tiles web profile (off by default: QGIS's 3D Tiles layer cannot read it)."""
    parameter = QgsProcessingParameterBoolean(
        WEB_PROFILE, tr("3D Tiles web profile: compressed geometry for browsers (QGIS cannot read it)"),
        defaultValue=False)
    algorithm.addParameter(_advanced(parameter) if advanced else parameter)


def add_cityjson_parameter(algorithm) -> None:
    """CityJSON beside the CityGML (off by default): model.city.json, or a tiled run's CityJSONSeq."""
    algorithm.addParameter(QgsProcessingParameterBoolean(
        CITYJSON, tr("Write CityJSON 2.0 beside the CityGML (model.city.json; a tiled run: a CityJSONSeq per tile "
                     "and index.city.jsonl)"), defaultValue=False))


def add_rebuild_parameter(algorithm) -> None:
    """Build everything again into an existing output, even what has not changed (off: an update)."""
    algorithm.addParameter(QgsProcessingParameterBoolean(
        REBUILD, tr("Build everything again, even what has not changed since the last run into this folder"),
        defaultValue=False))
