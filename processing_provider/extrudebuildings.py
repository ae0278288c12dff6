"""wit:extrudebuildings — closed LoD1 solids from footprints, floors and the DEM."""

from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterVectorLayer,
)

from .base import WitAlgorithm
from .qgis_compat import SourceType
from .shared_parameters import add_height_parameters, height_options

BASES = ("min", "median")


class ExtrudeBuildings(WitAlgorithm):
    algorithm_id = "extrudebuildings"
    display_name = "Extrude LoD1 buildings"
    group_name = "Geometry"
    help_text = (
        "Builds a closed, outward-oriented LoD1 solid per building: ground face, roof and one wall per "
        "footprint edge (courtyards included). The base is one height per building: the minimum of the "
        "DEM (bilinear; a DEM in another CRS is reprojected on the fly) over the footprint, so no building "
        "floats, or the median. Height: GRO_FLO_CO × "
        "storey height when the road-name-address floor count is known, else the height field, else the "
        "expression; with neither given, the height and floor fields of common layers are recognised by "
        "name (NGII digital map BFLR_CO, or 층수 as NGII ships it; building-integrated information AL_D010 A16 "
        "height, A26 floors; "
        "OpenStreetMap height, building:levels; Korean 높이, 지상층수); else the default height, which is "
        "a warning with the count. The log says which rule was used, and every building records it "
        "(wit_height_src, wit_height_rule). Output: PolygonZ faces with the building id (wit_id), face "
        "type, face number, base height, height, storeys (all derived fields named wit_…) and every "
        "source attribute under its own name."
    )
    requirements = ("shapely", "pyproj")

    BUILDINGS = "BUILDINGS"
    DEM = "DEM"
    BASE = "BASE"
    OUTPUT = "OUTPUT"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.BUILDINGS, self.tr("Building footprints (any polygon layer, e.g. of wit:preparevectors)"),
            [SourceType.VectorPolygon]))
        self.addParameter(QgsProcessingParameterRasterLayer(self.DEM, self.tr("DEM")))
        add_height_parameters(self, self.BUILDINGS)
        self.addParameter(QgsProcessingParameterEnum(
            self.BASE, self.tr("Base height from the DEM"),
            options=[self.tr("Minimum on the footprint"), self.tr("Median on the footprint")], defaultValue=0))
        self.add_spatial_index_parameter()
        self.addParameter(QgsProcessingParameterFileDestination(
            self.OUTPUT, self.tr("LoD1 solids (GeoPackage)"), self.tr("GeoPackage (*.gpkg)")))
        self.addOutput(QgsProcessingOutputVectorLayer("LOD1", self.tr("LoD1 faces")))
        self.addOutput(QgsProcessingOutputNumber("SOLIDS", self.tr("Solids")))
        self.addOutput(QgsProcessingOutputNumber("DEFAULT_HEIGHTS", self.tr("Buildings with the default height")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.buildings.extrude import extrude_buildings
        from ..wit_plugin.infra import step_layers
        from ..wit_plugin.infra.io.layersource import LayerSource

        buildings = self.parameterAsVectorLayer(parameters, self.BUILDINGS, context)
        heights, expression = height_options(self, parameters, context, buildings)
        output = self.parameterAsFileOutput(parameters, self.OUTPUT, context)
        stats = extrude_buildings(
            self.vector_source(parameters, self.BUILDINGS, context, feedback),
            self.parameterAsRasterLayer(parameters, self.DEM, context).source(), output,
            heights, BASES[self.parameterAsEnum(parameters, self.BASE, context)],
            self.parameterAsBoolean(parameters, self.SPATIAL_INDEX, context), feedback)
        if expression is not None and expression.failure_warning():
            feedback.warning(expression.failure_warning())
        return {self.OUTPUT: output, "LOD1": str(LayerSource(output, step_layers.LOD1_LAYER)), "SOLIDS": stats.solids,
                "DEFAULT_HEIGHTS": stats.height_sources.get("default", 0)}
