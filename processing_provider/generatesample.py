"""wit:generatesample — realistic sample data in the national formats (demo, tests, benchmarks), or an
orthoimage and DEM drawn from given building and road layers."""
from qgis.core import (
    QgsProcessingException,
    QgsProcessingOutputFile,
    QgsProcessingOutputFolder,
    QgsProcessingOutputNumber,
    QgsProcessingOutputRasterLayer,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterVectorLayer,
)

from .base import WitAlgorithm
from .qgis_compat import NumberType, SourceType
from .shared_parameters import AREA_LAYER, CENTER, DISTRICT_CODE, RADIUS, WGS84, add_area_parameters, study_area


class GenerateSample(WitAlgorithm):
    algorithm_id = "generatesample"
    display_name = "Generate sample data"
    group_name = "Data"
    help_text = (
        "Generates a deterministic sample of the Korean national data around a centre point: "
        "buildings (TL_SPBD_BULD), roads (TL_SPRD_MANAGE) and legal dongs (TL_SCCO_EMD) as CP949 "
        "shapefiles without .cpg in EPSG:5179 with a few real-world defects, a DEM GeoTIFF in "
        "EPSG:5186 with -9999 cells and no NoData flag, and unreferenced orthoimage TIFs named by "
        "NGII 1:5,000 map-sheet number (sheet envelope + 50 m, one brightness per tile). "
        "Set either the radius or the number of buildings (0 = from the radius).<br><br>"
        "With a building and/or road layer given (any CRS and schema: road-name-address, NGII, "
        "OpenStreetMap; roads as centre lines, buffered by ROAD_BT / 2, else by their class width or 6 m, "
        "or as polygons), it draws the orthoimage tiles from them instead, and the DEM over their area: roofs "
        "where the footprints are, roads where the roads are, paving, lawn and forest elsewhere. The tiles are the "
        "NGII sheets that cover the study area (centre and radius, a polygon layer, or a legal dong of the "
        "district layer) clipped to the layers' extent, or that whole extent. The given layers are only "
        "read; the output folder receives the tiles, the DEM and sample_manifest.json, which names the "
        "layers they were drawn from."
    )
    requirements = ("shapely", "pyproj")

    OUTPUT = "OUTPUT"
    BUILDINGS = "BUILDINGS"
    ROADS = "ROADS"
    DISTRICTS = "DISTRICTS"
    WHOLE_EXTENT = "WHOLE_EXTENT"
    BUILDING_COUNT = "BUILDING_COUNT"
    SEED = "SEED"
    ORTHO_PIXEL_SIZE = "ORTHO_PIXEL_SIZE"
    DEM_CELL_SIZE = "DEM_CELL_SIZE"
    WITH_ORTHO = "WITH_ORTHO"
    WITH_DEM = "WITH_DEM"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.BUILDINGS, self.tr("Buildings to draw the orthoimage from (empty = a synthetic city)"),
            [SourceType.VectorPolygon], optional=True))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.ROADS, self.tr("Roads to draw the orthoimage from: centre lines or polygons"),
            [SourceType.VectorLine, SourceType.VectorPolygon], optional=True))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.DISTRICTS, self.tr("Legal dongs (TL_SCCO_EMD), to name a district as the area"),
            [SourceType.VectorPolygon], optional=True))
        add_area_parameters(self)
        self.addParameter(QgsProcessingParameterBoolean(
            self.WHOLE_EXTENT, self.tr("Draw over the whole extent of the given layers (instead of the study area)"),
            defaultValue=False))
        self.addParameter(QgsProcessingParameterNumber(
            self.BUILDING_COUNT, self.tr("Number of buildings (0 = from the radius)"),
            defaultValue=0, minValue=0, maxValue=10_000_000))
        self.addParameter(QgsProcessingParameterNumber(
            self.SEED, self.tr("Random seed"), defaultValue=42, minValue=0))
        self.addParameter(QgsProcessingParameterNumber(
            self.ORTHO_PIXEL_SIZE, self.tr("Orthoimage pixel size (m)"),
            NumberType.Double, defaultValue=0.5, minValue=0.05, maxValue=50.0))
        self.addParameter(QgsProcessingParameterNumber(
            self.DEM_CELL_SIZE, self.tr("DEM cell size (m)"),
            NumberType.Double, defaultValue=5.0, minValue=0.5, maxValue=500.0))
        self.addParameter(QgsProcessingParameterBoolean(
            self.WITH_ORTHO, self.tr("Generate orthoimage tiles"), defaultValue=True))
        self.addParameter(QgsProcessingParameterBoolean(
            self.WITH_DEM, self.tr("Generate the DEM"), defaultValue=True))
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTPUT, self.tr("Output folder")))
        self.addOutput(QgsProcessingOutputVectorLayer("BUILDINGS", self.tr("Buildings (TL_SPBD_BULD)")))
        self.addOutput(QgsProcessingOutputVectorLayer("ROADS", self.tr("Roads (TL_SPRD_MANAGE)")))
        self.addOutput(QgsProcessingOutputVectorLayer("DISTRICTS", self.tr("Legal dongs (TL_SCCO_EMD)")))
        self.addOutput(QgsProcessingOutputRasterLayer("DEM", self.tr("DEM")))
        self.addOutput(QgsProcessingOutputFolder("ORTHO_FOLDER", self.tr("Orthoimage tile folder")))
        self.addOutput(QgsProcessingOutputFile("MANIFEST", self.tr("Sample manifest (JSON)")))
        self.addOutput(QgsProcessingOutputNumber("BUILDINGS_WRITTEN", self.tr("Buildings written")))
        self.addOutput(QgsProcessingOutputNumber("BUILDINGS_DRAWN", self.tr("Given buildings drawn")))
        self.addOutput(QgsProcessingOutputNumber("ROADS_DRAWN", self.tr("Given roads drawn")))
        self.addOutput(QgsProcessingOutputNumber("TILES_WRITTEN", self.tr("Orthoimage tiles written")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.sample import SampleConfig

        count = self.parameterAsInt(parameters, self.BUILDING_COUNT, context)
        point = self.parameterAsPoint(parameters, CENTER, context, WGS84)
        config = SampleConfig(
            center_lon=point.x(),
            center_lat=point.y(),
            radius_m=self.parameterAsDouble(parameters, RADIUS, context),
            n_buildings=count or None,
            seed=self.parameterAsInt(parameters, self.SEED, context),
            ortho_pixel_size=self.parameterAsDouble(parameters, self.ORTHO_PIXEL_SIZE, context),
            dem_cell_size=self.parameterAsDouble(parameters, self.DEM_CELL_SIZE, context),
            with_ortho=self.parameterAsBool(parameters, self.WITH_ORTHO, context),
            with_dem=self.parameterAsBool(parameters, self.WITH_DEM, context),
        )
        folder = self.parameterAsString(parameters, self.OUTPUT, context)
        given = {name: self.vector_source(parameters, name, context, feedback)
                 for name in (self.BUILDINGS, self.ROADS, self.DISTRICTS)}
        whole = self.parameterAsBool(parameters, self.WHOLE_EXTENT, context)
        if given[self.BUILDINGS] or given[self.ROADS]:
            if count:
                raise QgsProcessingException(self.tr(
                    "The number of buildings applies to the synthetic city only: set it to 0 when drawing from "
                    "given layers."))
            return self._draw(parameters, context, feedback, folder, config, given, whole)
        area_given = (self.parameterAsVectorLayer(parameters, AREA_LAYER, context) is not None
                      or self.parameterAsString(parameters, DISTRICT_CODE, context).strip())
        if area_given or whole or given[self.DISTRICTS]:
            raise QgsProcessingException(self.tr(
                "A district layer, a study-area layer, a district or the whole extent apply only when drawing from a "
                "given building or road layer."))
        return self._synthetic(folder, config, feedback)

    def _synthetic(self, folder, config, feedback) -> dict:
        from ..wit_plugin.sample import generate_sample

        result = generate_sample(folder, config, feedback)
        return {
            self.OUTPUT: folder,
            "BUILDINGS": str(result.buildings),
            "ROADS": str(result.roads),
            "DISTRICTS": str(result.districts),
            "DEM": str(result.dem) if result.dem else None,
            "ORTHO_FOLDER": str(result.ortho_tiles[0].parent) if result.ortho_tiles else None,
            "MANIFEST": str(result.manifest),
            "BUILDINGS_WRITTEN": result.counts["buildings"],
            "BUILDINGS_DRAWN": 0,
            "ROADS_DRAWN": 0,
            "TILES_WRITTEN": len(result.ortho_tiles),
        }

    def _draw(self, parameters, context, feedback, folder, config, given, whole) -> dict:
        """The tiles and DEM drawn from the given layers; the layer outputs are those layers, untouched."""
        from ..wit_plugin.sample import GivenLayers, draw_from_layers

        layers = GivenLayers(buildings=given[self.BUILDINGS], roads=given[self.ROADS],
                             districts=given[self.DISTRICTS],
                             area=None if whole else study_area(self, parameters, context, feedback))
        result = draw_from_layers(folder, layers, config, feedback)
        return {
            self.OUTPUT: folder,
            **given,
            "DEM": str(result.dem) if result.dem else None,
            "ORTHO_FOLDER": str(result.ortho_tiles[0].parent) if result.ortho_tiles else None,
            "MANIFEST": str(result.manifest),
            "BUILDINGS_WRITTEN": 0,
            "BUILDINGS_DRAWN": result.counts["buildings"],
            "ROADS_DRAWN": result.counts["roads"],
            "TILES_WRITTEN": len(result.ortho_tiles),
        }
