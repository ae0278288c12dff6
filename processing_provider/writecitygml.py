"""wit:writecitygml — stream the model's layers into one CityGML 3.0 file."""
from pathlib import Path

from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterFileDestination,
)

from .base import WitAlgorithm, crs_string
from .qgis_compat import AlgorithmFlag
from .safeguards import Endpoint
from .shared_parameters import DISTRICTS, LOD1, ROADS, TEXTURES, TIN, add_model_parameters, model_inputs


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

    LOD1, TIN, ROADS, DISTRICTS, TEXTURES = LOD1, TIN, ROADS, DISTRICTS, TEXTURES
    COPY_TEXTURES = "COPY_TEXTURES"
    OUTPUT = "OUTPUT"

    def flags(self):
        # lxml from a Processing background thread has crashed QGIS on Windows (qgis/QGIS#54751):
        # the writer runs in the main thread.
        return super().flags() | AlgorithmFlag.NoThreading

    def initAlgorithm(self, config=None):  # noqa: N802
        add_model_parameters(self)
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
        output = Path(self.parameterAsFileOutput(parameters, self.OUTPUT, context))
        if not self.parameterAsBool(parameters, self.COPY_TEXTURES, context):
            return []
        return [Endpoint(self.tr("Texture images beside the CityGML file"),
                         str(output.parent / f"{output.stem}_textures"), folder=True)]

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.citygml.writer import write_citygml

        lod1 = self.parameterAsVectorLayer(parameters, self.LOD1, context)
        inputs = model_inputs(self, parameters, context, feedback)
        output = self.parameterAsFileOutput(parameters, self.OUTPUT, context)
        report = write_citygml(inputs, output, srs_name=crs_string(lod1.crs()), feedback=feedback,
                               copy_textures=self.parameterAsBool(parameters, self.COPY_TEXTURES, context))
        return {self.OUTPUT: output, "BUILDINGS": report.buildings, "ROADS_WRITTEN": report.roads,
                "TRIANGLES": report.triangles, "TEXTURED_SURFACES": report.textured_surfaces,
                "GROUPS": report.groups}
