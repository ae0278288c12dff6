"""wit:generatesample — realistic sample data in the national formats (demo, tests, benchmarks)."""
from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsProcessingOutputFile,
    QgsProcessingOutputFolder,
    QgsProcessingOutputNumber,
    QgsProcessingOutputRasterLayer,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterPoint,
)

from .base import WitAlgorithm

WGS84 = QgsCoordinateReferenceSystem("EPSG:4326")


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
        "Set either the radius or the number of buildings (0 = from the radius)."
    )
    requirements = ("shapely", "pyproj")

    OUTPUT = "OUTPUT"
    CENTER = "CENTER"
    RADIUS = "RADIUS"
    BUILDING_COUNT = "BUILDING_COUNT"
    SEED = "SEED"
    ORTHO_PIXEL_SIZE = "ORTHO_PIXEL_SIZE"
    DEM_CELL_SIZE = "DEM_CELL_SIZE"
    WITH_ORTHO = "WITH_ORTHO"

    def initAlgorithm(self, config=None):  # noqa: N802
        # Optional with a default: QGIS 3.22 does not fill a missing mandatory point with its default.
        self.addParameter(QgsProcessingParameterPoint(
            self.CENTER, self.tr("Centre of the study area"), defaultValue="127.1020,37.4876 [EPSG:4326]",
            optional=True))
        self.addParameter(QgsProcessingParameterNumber(
            self.RADIUS, self.tr("Radius of the study area (m)"),
            QgsProcessingParameterNumber.Double, defaultValue=1000.0, minValue=50.0))
        self.addParameter(QgsProcessingParameterNumber(
            self.BUILDING_COUNT, self.tr("Number of buildings (0 = from the radius)"),
            defaultValue=0, minValue=0, maxValue=10_000_000))
        self.addParameter(QgsProcessingParameterNumber(
            self.SEED, self.tr("Random seed"), defaultValue=42, minValue=0))
        self.addParameter(QgsProcessingParameterNumber(
            self.ORTHO_PIXEL_SIZE, self.tr("Orthoimage pixel size (m)"),
            QgsProcessingParameterNumber.Double, defaultValue=0.5, minValue=0.05, maxValue=50.0))
        self.addParameter(QgsProcessingParameterNumber(
            self.DEM_CELL_SIZE, self.tr("DEM cell size (m)"),
            QgsProcessingParameterNumber.Double, defaultValue=5.0, minValue=0.5, maxValue=500.0))
        self.addParameter(QgsProcessingParameterBoolean(
            self.WITH_ORTHO, self.tr("Generate orthoimage tiles"), defaultValue=True))
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTPUT, self.tr("Output folder")))
        self.addOutput(QgsProcessingOutputVectorLayer("BUILDINGS", self.tr("Buildings (TL_SPBD_BULD)")))
        self.addOutput(QgsProcessingOutputVectorLayer("ROADS", self.tr("Roads (TL_SPRD_MANAGE)")))
        self.addOutput(QgsProcessingOutputVectorLayer("DISTRICTS", self.tr("Legal dongs (TL_SCCO_EMD)")))
        self.addOutput(QgsProcessingOutputRasterLayer("DEM", self.tr("DEM")))
        self.addOutput(QgsProcessingOutputFolder("ORTHO_FOLDER", self.tr("Orthoimage tile folder")))
        self.addOutput(QgsProcessingOutputFile("MANIFEST", self.tr("Sample manifest (JSON)")))
        self.addOutput(QgsProcessingOutputNumber("BUILDINGS_WRITTEN", self.tr("Buildings written")))
        self.addOutput(QgsProcessingOutputNumber("TILES_WRITTEN", self.tr("Orthoimage tiles written")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.sample import SampleConfig, generate_sample

        point = self.parameterAsPoint(parameters, self.CENTER, context, WGS84)
        count = self.parameterAsInt(parameters, self.BUILDING_COUNT, context)
        config = SampleConfig(
            center_lon=point.x(),
            center_lat=point.y(),
            radius_m=self.parameterAsDouble(parameters, self.RADIUS, context),
            n_buildings=count or None,
            seed=self.parameterAsInt(parameters, self.SEED, context),
            ortho_pixel_size=self.parameterAsDouble(parameters, self.ORTHO_PIXEL_SIZE, context),
            dem_cell_size=self.parameterAsDouble(parameters, self.DEM_CELL_SIZE, context),
            with_ortho=self.parameterAsBool(parameters, self.WITH_ORTHO, context),
        )
        folder = self.parameterAsString(parameters, self.OUTPUT, context)
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
            "TILES_WRITTEN": len(result.ortho_tiles),
        }
