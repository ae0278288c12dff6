"""wit:export3dtiles — the city model as a 3D Tiles 1.1 tileset (CesiumJS, QGIS ≥ 3.34, any 3D Tiles viewer)."""
from qgis.core import (
    QgsProcessingOutputFile,
    QgsProcessingOutputNumber,
    QgsProcessingParameterCrs,
    QgsProcessingParameterFile,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterNumber,
)

from .base import WitAlgorithm, crs_string
from .load_results import load_results
from .qgis_compat import FileBehavior, NumberType, ParameterFlag
from .shared_parameters import (
    LOD1,
    TIN,
    WEB_PROFILE,
    add_model_layer_parameters,
    add_web_profile_parameter,
)


class Export3DTiles(WitAlgorithm):
    algorithm_id = "export3dtiles"
    display_name = "Export 3D Tiles"
    group_name = "CityGML"
    help_text = (
        "Writes the city model as an OGC 3D Tiles 1.1 tileset (tileset.json, glTF binary tiles and the "
        "texture images) for CesiumJS, QGIS 3.34 or later (3D Tiles layer) and other 3D Tiles viewers. "
        "Full-detail tiles hold the LoD1 buildings (roofs with the texture atlases of wit:wittexture, "
        "plain lit walls) and the terrain and roads of the TIN with their ground images, reused as they "
        "are; coarser tiles above them hold a terrain grid with its own image and the larger buildings "
        "on smaller mip levels of the atlases, so a large area streams. Coordinates are Earth-centred "
        "(from the model CRS), each tile in its own local frame. Every building carries its id and "
        "attributes (name, height, storeys, height source, source fields) as 3D Tiles metadata "
        "(EXT_mesh_features and EXT_structural_metadata): a click in a viewer shows them. The output "
        "folder is replaced whole; it must be new, empty or an earlier tileset. The web profile (off by "
        "default) quantizes the tiles' geometry and compresses it with meshoptimizer (KHR_mesh_quantization, "
        "EXT_meshopt_compression) for browsers such as CesiumJS: smaller and faster to load, but QGIS's 3D Tiles "
        "layer cannot read it; it needs the Python package meshoptimizer."
    )
    requirements = ("shapely", "pyproj", "pygltflib")

    LOD1, TIN, WEB_PROFILE = LOD1, TIN, WEB_PROFILE
    TEXTURES = "TEXTURES"
    TARGET_CRS = "TARGET_CRS"
    LEAF_SIZE = "LEAF_SIZE"
    OUTPUT = "OUTPUT"

    def initAlgorithm(self, config=None):  # noqa: N802
        add_model_layer_parameters(self)
        self.addParameter(QgsProcessingParameterFile(
            self.TEXTURES, self.tr("Texture folder (wit:wittexture)"),
            behavior=FileBehavior.Folder, optional=True))
        self.addParameter(QgsProcessingParameterCrs(
            self.TARGET_CRS, self.tr("Model CRS (when the layers carry none)"), defaultValue="EPSG:5186",
            optional=True))
        leaf = QgsProcessingParameterNumber(
            self.LEAF_SIZE, self.tr("Side of a full-detail tile (m)"), NumberType.Double,
            defaultValue=256.0, minValue=16.0, maxValue=10000.0)
        leaf.setFlags(leaf.flags() | ParameterFlag.Advanced)
        self.addParameter(leaf)
        add_web_profile_parameter(self)
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTPUT, self.tr("Tileset folder")))
        self.addOutput(QgsProcessingOutputFile("TILESET", self.tr("tileset.json")))
        for name, label in (("TILES", self.tr("Tiles written")), ("BUILDINGS", self.tr("Buildings written")),
                            ("MEGABYTES", self.tr("Size of the tileset (MB)"))):
            self.addOutput(QgsProcessingOutputNumber(name, label))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.tiles3d import TilesetConfig, export_tileset

        lod1 = self.parameterAsVectorLayer(parameters, self.LOD1, context)
        tin = self.parameterAsVectorLayer(parameters, self.TIN, context)
        layer = lod1 or tin
        crs = layer.crs() if layer is not None and layer.crs().isValid() else \
            self.parameterAsCrs(parameters, self.TARGET_CRS, context)
        output = self.parameterAsString(parameters, self.OUTPUT, context)
        web = self.parameterAsBool(parameters, self.WEB_PROFILE, context)
        report = export_tileset(
            self.vector_source(parameters, self.LOD1, context, feedback),
            self.vector_source(parameters, self.TIN, context, feedback),
            self.parameterAsFile(parameters, self.TEXTURES, context) or None,
            output, crs_string(crs), feedback,
            TilesetConfig(leaf_size=self.parameterAsDouble(parameters, self.LEAF_SIZE, context), web=web))
        if not web:  # QGIS cannot read the web profile
            load_results(context, tileset=report.tileset)  # a 3D Tiles layer on QGIS ≥ 3.34, from the GUI
        return {self.OUTPUT: output, "TILESET": report.tileset, "TILES": report.tiles,
                "BUILDINGS": report.buildings, "MEGABYTES": round(report.bytes_written / 1e6, 3)}
