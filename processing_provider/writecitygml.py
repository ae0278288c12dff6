"""wit:writecitygml — stream the model's layers into one CityGML 3.0 file."""
from pathlib import Path

from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterVectorLayer,
)

from .base import WitAlgorithm, crs_string
from .qgis_compat import AlgorithmFlag, FileBehavior, SourceType
from .shared_parameters import LOD1, TIN, add_model_layer_parameters


class WriteCityGML(WitAlgorithm):
    algorithm_id = "writecitygml"
    display_name = "Write CityGML 3.0"
    group_name = "CityGML"
    help_text = (
        "Writes a CityGML 3.0 city model, streaming (memory does not grow with the number of "
        "buildings): bldg:Building with a closed, outward-oriented lod1Solid, con:height, storeys and "
        "every source attribute as a typed generic attribute (from wit:extrudebuildings); tran:Road "
        "with traffic areas draped on the terrain and dem:ReliefFeature with a TIN (from "
        "wit:triangulateterrain, with the prepared roads' attributes); one grp:CityObjectGroup per "
        "legal dong (districts); and, when given, the textures of wit:wittexture as "
        "app:ParameterizedTexture (images copied beside the .gml, relative image URIs). gml:ids "
        "derive from the source ids, so the same input gives the same ids. srsName: EPSG:n, coordinates "
        "easting first, as GIS software reads that form. Runs in the main thread."
    )
    requirements = ("lxml", "shapely")

    LOD1, TIN = LOD1, TIN
    ROADS = "ROADS"
    DISTRICTS = "DISTRICTS"
    TEXTURES = "TEXTURES"
    COPY_TEXTURES = "COPY_TEXTURES"
    OUTPUT = "OUTPUT"

    def flags(self):
        # lxml from a Processing background thread has crashed QGIS on Windows (qgis/QGIS#54751):
        # the writer runs in the main thread.
        return super().flags() | AlgorithmFlag.NoThreading

    def initAlgorithm(self, config=None):  # noqa: N802
        add_model_layer_parameters(self, lod1_optional=False)
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.ROADS, self.tr("Road polygons (wit:preparevectors)"), [SourceType.VectorPolygon],
            optional=True))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.DISTRICTS, self.tr("Legal dongs (wit:preparevectors)"), [SourceType.VectorPolygon],
            optional=True))
        self.addParameter(QgsProcessingParameterFile(
            self.TEXTURES, self.tr("Texture folder (wit:wittexture)"),
            behavior=FileBehavior.Folder, optional=True))
        self.addParameter(QgsProcessingParameterBoolean(
            self.COPY_TEXTURES, self.tr("Copy texture images beside the .gml"), defaultValue=True))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.OUTPUT, self.tr("CityGML file"), self.tr("CityGML files (*.gml)")))
        for name, label in (("BUILDINGS", self.tr("Buildings written")), ("ROADS_WRITTEN", self.tr("Roads written")),
                            ("TRIANGLES", self.tr("Terrain triangles written")),
                            ("TEXTURED_SURFACES", self.tr("Textured surfaces")),
                            ("GROUPS", self.tr("District groups"))):
            self.addOutput(QgsProcessingOutputNumber(name, label))

    def extra_outputs(self, parameters, context) -> list:
        """The texture images are copied into ``<name>_textures`` beside the .gml."""
        from .safeguards import Endpoint

        output = Path(self.parameterAsFileOutput(parameters, self.OUTPUT, context))
        if not self.parameterAsBool(parameters, self.COPY_TEXTURES, context):
            return []
        return [Endpoint(self.tr("Texture images beside the CityGML file"),
                         str(output.parent / f"{output.stem}_textures"), folder=True)]

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.citygml.writer import CityGMLInputs, write_citygml

        lod1 = self.parameterAsVectorLayer(parameters, self.LOD1, context)
        inputs = CityGMLInputs(
            lod1=self.vector_source(parameters, self.LOD1, context, feedback),
            tin=self.vector_source(parameters, self.TIN, context, feedback),
            roads=self.vector_source(parameters, self.ROADS, context, feedback),
            districts=self.vector_source(parameters, self.DISTRICTS, context, feedback),
            textures=self.parameterAsFile(parameters, self.TEXTURES, context) or None,
        )
        output = self.parameterAsFileOutput(parameters, self.OUTPUT, context)
        report = write_citygml(inputs, output, srs_name=crs_string(lod1.crs()), feedback=feedback,
                               copy_textures=self.parameterAsBool(parameters, self.COPY_TEXTURES, context))
        return {self.OUTPUT: output, "BUILDINGS": report.buildings, "ROADS_WRITTEN": report.roads,
                "TRIANGLES": report.triangles, "TEXTURED_SURFACES": report.textured_surfaces,
                "GROUPS": report.groups}
