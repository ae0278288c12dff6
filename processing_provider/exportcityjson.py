"""wit:exportcityjson — the model's layers into one CityJSON 2.0 file, or a CityJSONSeq."""
from pathlib import Path

from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterFileDestination,
    QgsProcessingUtils,
)

from .base import WitAlgorithm, crs_string
from .safeguards import Endpoint
from .shared_parameters import DISTRICTS, LOD1, ROADS, TEXTURES, TIN, add_model_parameters, model_inputs


class ExportCityJSON(WitAlgorithm):
    algorithm_id = "exportcityjson"
    display_name = "Export CityJSON 2.0"
    group_name = "CityGML"
    help_text = (
        "Writes the model's layers as CityJSON 2.0 (.city.json), or as a CityJSONSeq (.city.jsonl: a header line, "
        "then one feature a line): the same objects, ids, attributes and textures as wit:writecitygml. Buildings "
        "with a LoD1 Solid whose surfaces are GroundSurface, RoofSurface and WallSurface, every source attribute, "
        "height (with heightStatus: measured or estimated) and storeys; roads as their draped triangles "
        "(TrafficArea); the other TIN triangles as one TINRelief; one CityObjectGroup per legal dong, its "
        "buildings naming it as their parent. Textures: the same images and texture coordinates, in the themes "
        "of the CityGML (rgbTexture: the orthoimage; generatedFacade: the walls' generated facades, which repeat "
        "along the wall: wrapMode wrap). Vertices are integers on the millimetre grid (transform); the CRS is the "
        "metadata's referenceSystem (an OGC CRS URL, coordinates easting first). Streaming: memory does not grow "
        "with the number of buildings. The file is written whole or not at all. Validate it with "
        "wit:validatecitygml (schemas and geometry)."
    )
    requirements = ("shapely",)

    LOD1, TIN, ROADS, DISTRICTS, TEXTURES = LOD1, TIN, ROADS, DISTRICTS, TEXTURES
    COPY_TEXTURES = "COPY_TEXTURES"
    OUTPUT = "OUTPUT"

    def initAlgorithm(self, config=None):  # noqa: N802
        add_model_parameters(self)
        self.addParameter(QgsProcessingParameterBoolean(
            self.COPY_TEXTURES, self.tr("Copy texture images beside the CityJSON file"), defaultValue=True))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.OUTPUT, self.tr("CityJSON file"),
            self.tr("CityJSON files (*.city.json);;CityJSONSeq files (*.city.jsonl)"), optional=True,
            createByDefault=True))
        for name, label in (("BUILDINGS", self.tr("Buildings written")), ("ROADS_WRITTEN", self.tr("Roads written")),
                            ("TRIANGLES", self.tr("Terrain triangles written")),
                            ("GROUPS", self.tr("District groups")), ("VERTICES", self.tr("Vertices written"))):
            self.addOutput(QgsProcessingOutputNumber(name, label))

    def output_file(self, parameters, context) -> str:
        """The file chosen, else a temporary one (qgis_process 3.22 needs optional destinations)."""
        return (self.parameterAsFileOutput(parameters, self.OUTPUT, context)
                or QgsProcessingUtils.generateTempFilename("model.city.json"))

    def extra_outputs(self, parameters, context) -> list:
        """The texture images are copied into ``<name>_textures`` beside the file."""
        from ..wit_plugin.cityjson.writer import texture_folder_of

        if not self.parameterAsBool(parameters, self.COPY_TEXTURES, context):
            return []
        output = self.parameterAsFileOutput(parameters, self.OUTPUT, context)
        return [Endpoint(self.tr("Texture images beside the CityJSON file"),
                         str(texture_folder_of(Path(output))), folder=True)] if output else []

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.cityjson.writer import write_cityjson

        lod1 = self.parameterAsVectorLayer(parameters, self.LOD1, context)
        inputs = model_inputs(self, parameters, context, feedback)
        output = self.output_file(parameters, context)
        report = write_cityjson(inputs, output, srs_name=crs_string(lod1.crs()), feedback=feedback,
                                copy_textures=self.parameterAsBool(parameters, self.COPY_TEXTURES, context))
        return {self.OUTPUT: output, "BUILDINGS": report.buildings, "ROADS_WRITTEN": report.roads,
                "TRIANGLES": report.triangles, "GROUPS": report.groups, "VERTICES": report.vertices}
