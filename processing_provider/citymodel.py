"""wit:citymodel — the whole chain in one call, from raw national data to validated CityGML 3.0."""
import json
import shutil
import tempfile
import time
from pathlib import Path

from qgis.core import (
    QgsProcessing,
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingMultiStepFeedback,
    QgsProcessingOutputBoolean,
    QgsProcessingOutputFile,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterCrs,
    QgsProcessingParameterFile,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterMultipleLayers,
    QgsProcessingParameterNumber,
    QgsProcessingParameterPoint,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
    QgsProcessingParameterVectorLayer,
)

from .base import WitAlgorithm

#: the steps in order (label shown in the log, algorithm id)
STEPS = (
    ("georeference", "wit:georeferencemapsheets"),
    ("merge", "wit:mergetiles"),
    ("prepare", "wit:preparevectors"),
    ("terrain", "wit:triangulateterrain"),
    ("extrude", "wit:extrudebuildings"),
    ("texture", "wit:wittexture"),
    ("citygml", "wit:writecitygml"),
    ("validate", "wit:validatecitygml"),
    ("metrics", "wit:qualitymetrics"),
)


class CityModel(WitAlgorithm):
    algorithm_id = "citymodel"
    display_name = "City model (whole chain)"
    group_name = "Chain"
    help_text = (
        "Runs the whole chain in one call, with one progress bar and Cancel honoured in every step: "
        "georeference the NGII map-sheet TIFs, merge them (WIT feather + gain), prepare the building, "
        "road and legal-dong layers for the study area, triangulate the terrain, extrude LoD1 "
        "buildings, texture them from the orthoimage, write CityGML 3.0, validate it and measure its "
        "quality. The output folder receives model.gml with its textures, validation.html, "
        "metrics.csv (and metrics.html) and steps.json (time per step). Intermediate files go to a "
        "work folder that is deleted at the end unless it is kept (then it is <output>/work). Study "
        "area: a legal-dong code if given, else the centre point and radius."
    )
    requirements = ("shapely", "triangle", "pyproj", "lxml")

    ORTHO_INPUT = "ORTHO_INPUT"
    DEM = "DEM"
    BUILDINGS = "BUILDINGS"
    ROADS = "ROADS"
    DISTRICTS = "DISTRICTS"
    CENTER = "CENTER"
    RADIUS = "RADIUS"
    DISTRICT_CODE = "DISTRICT_CODE"
    TARGET_CRS = "TARGET_CRS"
    MAX_EDGE = "MAX_EDGE"
    TOLERANCE = "TOLERANCE"
    TEXTURE_SCALE = "TEXTURE_SCALE"
    SCHEMA_DIR = "SCHEMA_DIR"
    KEEP_WORK = "KEEP_WORK"
    OUTPUT = "OUTPUT"

    def flags(self):
        # writing and validating CityGML use lxml, which has crashed QGIS from a background thread on
        # Windows (qgis/QGIS#54751): the chain runs in the main thread
        return super().flags() | QgsProcessingAlgorithm.FlagNoThreading

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterMultipleLayers(
            self.ORTHO_INPUT, self.tr("Orthoimage TIFs or folders"), QgsProcessing.TypeFile))
        self.addParameter(QgsProcessingParameterRasterLayer(self.DEM, self.tr("DEM")))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.BUILDINGS, self.tr("Buildings (TL_SPBD_BULD)"), [QgsProcessing.TypeVectorPolygon]))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.ROADS, self.tr("Roads (TL_SPRD_MANAGE)"), [QgsProcessing.TypeVectorLine], optional=True))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.DISTRICTS, self.tr("Legal dongs (TL_SCCO_EMD)"), [QgsProcessing.TypeVectorPolygon], optional=True))
        # Optional with defaults: QGIS 3.22 does not fill missing mandatory points/CRSs with defaults.
        self.addParameter(QgsProcessingParameterPoint(
            self.CENTER, self.tr("Centre of the study area"), defaultValue="127.1020,37.4876 [EPSG:4326]",
            optional=True))
        self.addParameter(QgsProcessingParameterNumber(
            self.RADIUS, self.tr("Radius of the study area (m)"), QgsProcessingParameterNumber.Double,
            defaultValue=1000.0, minValue=1.0))
        self.addParameter(QgsProcessingParameterString(
            self.DISTRICT_CODE, self.tr("Legal-dong code EMD_CD (instead of centre and radius)"), optional=True))
        self.addParameter(QgsProcessingParameterCrs(
            self.TARGET_CRS, self.tr("Target CRS"), defaultValue="EPSG:5186", optional=True))
        self.addParameter(QgsProcessingParameterNumber(
            self.MAX_EDGE, self.tr("Maximum edge length (m)"), QgsProcessingParameterNumber.Double,
            defaultValue=5.0, minValue=0.5))
        self.addParameter(QgsProcessingParameterNumber(
            self.TOLERANCE, self.tr("Vertical tolerance (m)"), QgsProcessingParameterNumber.Double,
            defaultValue=0.5, minValue=0.01))
        self.addParameter(QgsProcessingParameterNumber(
            self.TEXTURE_SCALE, self.tr("Texture scale S (0 < S ≤ 1)"), QgsProcessingParameterNumber.Double,
            defaultValue=1.0, minValue=0.01, maxValue=1.0))
        self.addParameter(QgsProcessingParameterFile(
            self.SCHEMA_DIR, self.tr("Schema folder (with citygml3-all.xsd)"),
            behavior=QgsProcessingParameterFile.Folder, optional=True))
        self.addParameter(QgsProcessingParameterBoolean(
            self.KEEP_WORK, self.tr("Keep the intermediate files"), defaultValue=False))
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTPUT, self.tr("Output folder")))
        self.addOutput(QgsProcessingOutputFile("GML", self.tr("CityGML file")))
        self.addOutput(QgsProcessingOutputFile("VALIDATION_REPORT", self.tr("Validation report (HTML)")))
        self.addOutput(QgsProcessingOutputFile("METRICS", self.tr("Metrics table (CSV)")))
        self.addOutput(QgsProcessingOutputBoolean("VALID", self.tr("All files valid")))
        self.addOutput(QgsProcessingOutputNumber("ERROR_COUNT", self.tr("Number of errors")))
        self.addOutput(QgsProcessingOutputNumber("BUILDINGS_WRITTEN", self.tr("Buildings written")))
        self.addOutput(QgsProcessingOutputString("STEP_TIMES", self.tr("Seconds per step (JSON)")))

    def execute(self, parameters, context, feedback):
        import processing

        output = Path(self.parameterAsString(parameters, self.OUTPUT, context))
        output.mkdir(parents=True, exist_ok=True)
        keep = self.parameterAsBool(parameters, self.KEEP_WORK, context)
        if keep:  # a fixed place the user can find: <output>/work
            work = output / "work"
            shutil.rmtree(work, ignore_errors=True)
            work.mkdir()
        else:
            work = Path(tempfile.mkdtemp(prefix="wit-work-", dir=output))
        steps = QgsProcessingMultiStepFeedback(len(STEPS), feedback.processing_feedback)
        times: dict[str, float] = {}
        results: dict[str, dict] = {}

        def run(number: int, algorithm: str, arguments: dict) -> dict:
            label = STEPS[number][0]
            steps.setCurrentStep(number)
            if steps.isCanceled():
                raise QgsProcessingException(self.tr("Cancelled: no output was written."))
            steps.pushInfo(self.tr("Step {n}/{total}: {algorithm}").format(
                n=number + 1, total=len(STEPS), algorithm=algorithm))
            start = time.perf_counter()
            result = processing.run(algorithm, arguments, context=context, feedback=steps,
                                    is_child_algorithm=True)
            times[label] = round(time.perf_counter() - start, 3)
            results[label] = result
            return result

        def layer(name):
            value = self.parameterAsVectorLayer(parameters, name, context)
            return value.source() if value is not None else None

        try:
            geo = run(0, "wit:georeferencemapsheets", {
                "INPUT": self.parameterAsFileList(parameters, self.ORTHO_INPUT, context),
                "TARGET_CRS": self.parameterAsCrs(parameters, self.TARGET_CRS, context),
                "OUTPUT": str(work / "georeferenced"), "OUTPUT_INDEX": str(work / "sheets.gpkg")})
            mosaic = run(1, "wit:mergetiles", {"INPUT": geo["OUTPUT_LAYERS"], "OVERLAP": 1, "GAIN": True,
                                               "OUTPUT": str(work / "ortho.tif")})
            prepared = run(2, "wit:preparevectors", {
                "BUILDINGS": layer(self.BUILDINGS), "ROADS": layer(self.ROADS), "DISTRICTS": layer(self.DISTRICTS),
                "CENTER": parameters.get(self.CENTER), "RADIUS": parameters.get(self.RADIUS),
                "DISTRICT_CODE": parameters.get(self.DISTRICT_CODE),
                "TARGET_CRS": self.parameterAsCrs(parameters, self.TARGET_CRS, context),
                "OUTPUT": str(work / "prepared.gpkg")})
            dem = self.parameterAsRasterLayer(parameters, self.DEM, context).source()
            tin = run(3, "wit:triangulateterrain", {
                "DEM": dem, "AREA": prepared["AREA_OUT"], "BUILDINGS": prepared["BUILDINGS_OUT"],
                "ROADS": prepared["ROADS_OUT"], "MAX_EDGE": parameters.get(self.MAX_EDGE),
                "TOLERANCE": parameters.get(self.TOLERANCE), "SPATIAL_INDEX": keep, "OUTPUT": str(work / "tin.gpkg")})
            lod1 = run(4, "wit:extrudebuildings", {"BUILDINGS": prepared["BUILDINGS_OUT"], "DEM": dem,
                                                   "SPATIAL_INDEX": keep, "OUTPUT": str(work / "lod1.gpkg")})
            textures = run(5, "wit:wittexture", {
                "ORTHO": mosaic["OUTPUT"], "LOD1": lod1["LOD1"], "TIN": tin["TIN"],
                "SCALE": parameters.get(self.TEXTURE_SCALE), "OUTPUT": str(work / "textures")})
            gml = run(6, "wit:writecitygml", {
                "LOD1": lod1["LOD1"], "TIN": tin["TIN"], "ROADS": prepared["ROADS_OUT"],
                "DISTRICTS": prepared["DISTRICTS_OUT"], "TEXTURES": textures["OUTPUT"],
                "OUTPUT": str(output / "model.gml")})
            validation = run(7, "wit:validatecitygml", {
                "INPUT": [gml["OUTPUT"]], "SCHEMA_DIR": parameters.get(self.SCHEMA_DIR),
                "OUTPUT": str(output / "validation.html")})
            metrics = run(8, "wit:qualitymetrics", {
                "MODEL": gml["OUTPUT"], "SOURCE_BUILDINGS": prepared["BUILDINGS_OUT"],
                "TEXTURES": textures["OUTPUT"], "ORTHO": mosaic["OUTPUT"], "MOSAIC": mosaic["OUTPUT"],
                "FOOTPRINTS": str(work / "sheets.gpkg"), "OUTPUT": str(output / "metrics.csv"),
                "OUTPUT_HTML": str(output / "metrics.html")})
        finally:
            if not keep:
                shutil.rmtree(work, ignore_errors=True)
        (output / "steps.json").write_text(json.dumps({"seconds": times}, indent=1), encoding="utf-8")
        feedback.info(self.tr("Seconds per step: {times}").format(times=times))
        return {
            self.OUTPUT: str(output), "GML": gml["OUTPUT"], "VALIDATION_REPORT": validation["OUTPUT"],
            "METRICS": metrics["OUTPUT"], "VALID": validation["VALID"], "ERROR_COUNT": validation["ERROR_COUNT"],
            "BUILDINGS_WRITTEN": gml["BUILDINGS"], "STEP_TIMES": json.dumps(times),
        }
