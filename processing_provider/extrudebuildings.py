"""wit:extrudebuildings — closed LoD1 solids from footprints, floors and the DEM."""

from qgis.core import (
    QgsProcessing,
    QgsProcessingOutputNumber,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterEnum,
    QgsProcessingParameterExpression,
    QgsProcessingParameterField,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterVectorLayer,
)

from .base import WitAlgorithm
from .expressions import checked_expression

BASES = ("min", "median")


class ExtrudeBuildings(WitAlgorithm):
    algorithm_id = "extrudebuildings"
    display_name = "Extrude LoD1 buildings"
    group_name = "Geometry"
    help_text = (
        "Builds a closed, outward-oriented LoD1 solid per building: ground face, roof and one wall per "
        "footprint edge (courtyards included). The base is one height per building: the minimum of the "
        "DEM (bilinear) over the footprint, so no building floats, or the median. Height: GRO_FLO_CO × "
        "storey height when the road-name-address floor count is known, else the height field, else the "
        "expression; with neither given, the height and floor fields of common layers are recognised by "
        "name (NGII digital map BFLR_CO; building-integrated information AL_D010 A16 height, A26 floors; "
        "OpenStreetMap height, building:levels; Korean 높이, 지상층수); else the default height, which is "
        "a warning with the count. The log says which rule was used, and every building records it "
        "(wit_height_src, wit_height_rule). Output: PolygonZ faces with the building id (wit_id), face "
        "type, face number, base height, height, storeys (all derived fields named wit_…) and every "
        "source attribute under its own name."
    )
    requirements = ("shapely", "pyproj")

    BUILDINGS = "BUILDINGS"
    DEM = "DEM"
    STOREY_HEIGHT = "STOREY_HEIGHT"
    HEIGHT_FIELD = "HEIGHT_FIELD"
    HEIGHT_EXPRESSION = "HEIGHT_EXPRESSION"
    DEFAULT_HEIGHT = "DEFAULT_HEIGHT"
    BASE = "BASE"
    OUTPUT = "OUTPUT"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.BUILDINGS, self.tr("Building footprints (wit:preparevectors)"), [QgsProcessing.TypeVectorPolygon]))
        self.addParameter(QgsProcessingParameterRasterLayer(self.DEM, self.tr("DEM")))
        self.addParameter(QgsProcessingParameterNumber(
            self.STOREY_HEIGHT, self.tr("Storey height (m)"), QgsProcessingParameterNumber.Double,
            defaultValue=3.0, minValue=0.5))
        self.addParameter(QgsProcessingParameterField(
            self.HEIGHT_FIELD, self.tr("Height field (m), when floors are unknown"),
            parentLayerParameterName=self.BUILDINGS, type=QgsProcessingParameterField.Numeric, optional=True))
        self.addParameter(QgsProcessingParameterExpression(
            self.HEIGHT_EXPRESSION, self.tr("Height expression (m), when floors and field are unknown"),
            parentLayerParameterName=self.BUILDINGS, optional=True))
        self.addParameter(QgsProcessingParameterNumber(
            self.DEFAULT_HEIGHT, self.tr("Default height (m)"), QgsProcessingParameterNumber.Double,
            defaultValue=3.0, minValue=0.1))
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
        from ..wit_plugin import model
        from ..wit_plugin.extrude import run
        from ..wit_plugin.heights import HeightOptions

        buildings = self.parameterAsVectorLayer(parameters, self.BUILDINGS, context)
        fields = self.parameterAsFields(parameters, self.HEIGHT_FIELD, context)
        expression = checked_expression(self, parameters, self.HEIGHT_EXPRESSION, buildings, context)
        heights = HeightOptions(
            height_field=fields[0] if fields else None,
            expression_text=expression.text if expression else None,
            expression=expression,
            storey_height=self.parameterAsDouble(parameters, self.STOREY_HEIGHT, context),
            default_height=self.parameterAsDouble(parameters, self.DEFAULT_HEIGHT, context),
        )
        output = self.parameterAsFileOutput(parameters, self.OUTPUT, context)
        stats = run(buildings.source(), self.parameterAsRasterLayer(parameters, self.DEM, context).source(), output,
                    heights, BASES[self.parameterAsEnum(parameters, self.BASE, context)],
                    self.parameterAsBoolean(parameters, self.SPATIAL_INDEX, context), feedback)
        if expression is not None and expression.failure_warning():
            feedback.warning(expression.failure_warning())
        return {self.OUTPUT: output, "LOD1": f"{output}|layername={model.LOD1_LAYER}", "SOLIDS": stats.solids,
                "DEFAULT_HEIGHTS": stats.height_sources.get("default", 0)}
