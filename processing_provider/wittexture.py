"""wit:wittexture — texture roofs, terrain and roads from the merged orthoimage (WIT)."""
from qgis.core import (
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterLayer,
)

from .base import WitAlgorithm
from .qgis_compat import NumberType
from .shared_parameters import LOD1, TIN, add_facade_parameter, add_model_layer_parameters, facade_choice

IMAGE_FORMATS = ("JPEG", "PNG")


class WitTexture(WitAlgorithm):
    algorithm_id = "wittexture"
    display_name = "WIT texturing"
    group_name = "Texture"
    help_text = (
        "Cuts textures for roofs (LoD1 roof faces), terrain and road triangles (TIN) from the merged "
        "orthoimage. Texture coordinates follow U = (x − xmin)/(xmax − xmin), V = (y − ymin)/(ymax − "
        "ymin) over each image's ground extent with the half-pixel correction, so a vertex at a "
        "pixel centre lands on that pixel's texel centre. Roofs are packed into atlases with gutters "
        "(edge pixels repeated) so that mipmaps do not bleed neighbours in; terrain and roads use one "
        "image per ground square. An orthoimage sees no facades: walls get generated facades (FACADES, the "
        "default), storey modules drawn by the plugin for each building's use (the national use code "
        "BDTYP_CD, NGII's 용도/종류, AL_D010, OpenStreetMap's building tag, else its storeys) with one image "
        "row per storey (the layer's floor count, else its height), kept apart and marked as generated "
        "(facades.gpkg, the CityGML theme generatedFacade); or none. Scale S "
        "(0 < S ≤ 1) sets the resolution; the mip chain down to 1×1 can be written too. The "
        "orthoimage is read in windows, never whole; one in another CRS than the layers is reprojected "
        "as it is read (bilinear). Output: a folder of images and texcoords.gpkg, "
        "the input of wit:writecitygml."
    )
    requirements = ("shapely",)

    ORTHO = "ORTHO"
    LOD1, TIN = LOD1, TIN
    SCALE = "SCALE"
    FORMAT = "FORMAT"
    JPEG_QUALITY = "JPEG_QUALITY"
    ATLAS_SIZE = "ATLAS_SIZE"
    GUTTER = "GUTTER"
    MIPMAPS = "MIPMAPS"
    OUTPUT = "OUTPUT"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterRasterLayer(self.ORTHO, self.tr("Merged orthoimage")))
        add_model_layer_parameters(self)
        self.addParameter(QgsProcessingParameterNumber(
            self.SCALE, self.tr("Texture scale S (0 < S ≤ 1)"), NumberType.Double,
            defaultValue=1.0, minValue=0.01, maxValue=1.0))
        self.addParameter(QgsProcessingParameterEnum(
            self.FORMAT, self.tr("Image format"), options=list(IMAGE_FORMATS), defaultValue=0))
        self.addParameter(QgsProcessingParameterNumber(
            self.JPEG_QUALITY, self.tr("JPEG quality"), defaultValue=90, minValue=10, maxValue=100))
        self.addParameter(QgsProcessingParameterEnum(
            self.ATLAS_SIZE, self.tr("Atlas size limit (px)"), options=["1024", "2048", "4096", "8192"],
            defaultValue=1))
        self.addParameter(QgsProcessingParameterNumber(
            self.GUTTER, self.tr("Gutter width (px)"), defaultValue=4, minValue=0, maxValue=64))
        self.addParameter(QgsProcessingParameterBoolean(
            self.MIPMAPS, self.tr("Write the mip chain (to 1×1)"), defaultValue=False))
        add_facade_parameter(self)
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTPUT, self.tr("Texture folder")))
        self.addOutput(QgsProcessingOutputNumber("IMAGES", self.tr("Images written")))
        self.addOutput(QgsProcessingOutputNumber("TEXTURED_SURFACES", self.tr("Textured surfaces")))
        self.addOutput(QgsProcessingOutputNumber("FACADES_GENERATED", self.tr("Buildings with a generated facade")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.texture import TextureConfig, texture_model

        lod1 = self.vector_source(parameters, self.LOD1, context, feedback)
        tin = self.vector_source(parameters, self.TIN, context, feedback)
        if not (lod1 or tin):
            raise QgsProcessingException(self.tr("Give the LoD1 buildings, the TIN, or both."))
        config = TextureConfig(
            scale=self.parameterAsDouble(parameters, self.SCALE, context),
            image_format=IMAGE_FORMATS[self.parameterAsEnum(parameters, self.FORMAT, context)],
            jpeg_quality=self.parameterAsInt(parameters, self.JPEG_QUALITY, context),
            atlas_size=1024 << self.parameterAsEnum(parameters, self.ATLAS_SIZE, context),
            gutter=self.parameterAsInt(parameters, self.GUTTER, context),
            write_mipmaps=self.parameterAsBool(parameters, self.MIPMAPS, context),
            facades=facade_choice(self, parameters, context),
        )
        output = self.parameterAsString(parameters, self.OUTPUT, context)
        ortho = self.parameterAsRasterLayer(parameters, self.ORTHO, context).source()
        report = texture_model(ortho, lod1, tin, output, config, feedback)
        feedback.info(f"Textured {report.surfaces}; untextured {report.untextured}; "
                      f"{len(report.images)} images, {report.bytes_written / 1e6:.1f} MB")
        return {self.OUTPUT: output, "IMAGES": len(report.images),
                "TEXTURED_SURFACES": sum(report.surfaces.values()), "FACADES_GENERATED": sum(report.facades.values())}
