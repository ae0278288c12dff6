"""wit:citymodel — the whole chain in one call, from raw national data to validated CityGML 3.0."""
import json

from qgis.core import (
    QgsProcessingOutputBoolean,
    QgsProcessingOutputFile,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterCrs,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFile,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterMultipleLayers,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterVectorLayer,
)

from .base import WitAlgorithm, crs_string
from .load_results import load_results
from .qgis_compat import AlgorithmFlag, FileBehavior, NumberType, SourceType
from .shared_parameters import (
    CITYJSON,
    MAX_EDGE,
    REBUILD,
    ROADS_LABEL,
    ROADS_TYPES,
    TOLERANCE,
    WEB_PROFILE,
    add_area_parameters,
    add_cityjson_parameter,
    add_facade_parameter,
    add_height_parameters,
    add_mesh_parameters,
    add_rebuild_parameter,
    add_triangulator_parameter,
    add_web_profile_parameter,
    facade_choice,
    height_options,
    schema_choice,
    study_area,
    triangulator,
)


class CityModel(WitAlgorithm):
    algorithm_id = "citymodel"
    display_name = "City model (whole chain)"
    group_name = "Chain"
    help_text = (
        "Runs the whole chain in one call, with one progress bar and Cancel honoured in every step: prepare "
        "the building, road and legal-dong layers for the study area; check, in seconds and before any heavy "
        "work, that the DEM and the orthoimage sheets (from their sheet numbers) cover it, naming the missing "
        "sheets (a DEM, or sheets georeferenced in another CRS than the target, are reprojected on the fly, "
        "bilinear); georeference and merge only the sheets it needs (WIT feather + gain); triangulate the "
        "terrain (it also covers the buildings that cross the area's edge); extrude LoD1 buildings (heights "
        "as in wit:extrudebuildings: floors, a height field or expression, or the height and floor fields of "
        "the common layers recognised by name; buildings given the default height are a warning and the "
        "DEFAULT_HEIGHTS output); texture them from the orthoimage (walls: generated facades from each "
        "building's use and storeys, marked as generated; FACADES); write CityGML 3.0, validate it and "
        "measure its quality. The output folder receives model.gml with its textures (and, with CITYJSON, the same "
        "model as CityJSON 2.0: model.city.json, validated alike), validation.html, "
        "metrics.csv (and metrics.html), the LoD1 and TIN GeoPackages, a 3D Tiles 1.1 tileset (3dtiles/, "
        "for CesiumJS or QGIS ≥ 3.34) and steps.json (time per step); from the QGIS window the layers load "
        "into the project as a group for the 3D map view. Everything appears at the end, so "
        "a failed or cancelled run leaves nothing. Intermediate files are deleted unless kept (then in "
        "<output>/work). Study area: a legal dong (code or name) if given, else the polygon layer, else the "
        "centre point and radius. Run again into the same folder, it compares what the model was built from "
        "(build.json: every setting, the plugin's version, the triangulator, and the inputs as the run reads "
        "them, by content) and builds it again only if something changed, saying what (REBUILT, "
        "REBUILD_REASON); otherwise it does no work and reports the result recorded. REBUILD builds it again "
        "anyway."
    )
    requirements = ("shapely", "pythoncdt", "pyproj", "lxml")

    ORTHO_INPUT = "ORTHO_INPUT"
    DEM = "DEM"
    BUILDINGS = "BUILDINGS"
    ROADS = "ROADS"
    DISTRICTS = "DISTRICTS"
    TARGET_CRS = "TARGET_CRS"
    TEXTURE_SCALE = "TEXTURE_SCALE"
    OUTSIDE_ORTHO = "OUTSIDE_ORTHO"
    SCHEMA_DIR = "SCHEMA_DIR"
    TILES3D = "TILES3D"
    KEEP_WORK = "KEEP_WORK"
    OUTPUT = "OUTPUT"

    def flags(self):
        # writing and validating CityGML use lxml, which has crashed QGIS from a background thread on
        # Windows (qgis/QGIS#54751): the chain runs in the main thread
        return super().flags() | AlgorithmFlag.NoThreading

    def initAlgorithm(self, config=None):  # noqa: N802
        self.add_chain_parameters()
        self.addParameter(QgsProcessingParameterBoolean(
            self.TILES3D, self.tr("Write a 3D Tiles 1.1 tileset for viewers (3dtiles/)"), defaultValue=True))
        add_web_profile_parameter(self, advanced=True)
        self.addParameter(QgsProcessingParameterBoolean(
            self.KEEP_WORK, self.tr("Keep the intermediate files"), defaultValue=False))
        add_rebuild_parameter(self)
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTPUT, self.tr("Output folder")))
        self.addOutput(QgsProcessingOutputFile("GML", self.tr("CityGML file")))
        self.addOutput(QgsProcessingOutputFile("CITYJSON_FILE", self.tr("CityJSON file (model.city.json)")))
        self.addOutput(QgsProcessingOutputFile("VALIDATION_REPORT", self.tr("Validation report (HTML)")))
        self.addOutput(QgsProcessingOutputFile("METRICS", self.tr("Metrics table (CSV)")))
        self.addOutput(QgsProcessingOutputBoolean("VALID", self.tr("All files valid")))
        self.addOutput(QgsProcessingOutputNumber("ERROR_COUNT", self.tr("Number of errors")))
        self.addOutput(QgsProcessingOutputNumber("BUILDINGS_WRITTEN", self.tr("Buildings written")))
        self.addOutput(QgsProcessingOutputNumber("DEFAULT_HEIGHTS", self.tr("Buildings with the default height")))
        self.addOutput(QgsProcessingOutputNumber("UNTEXTURED", self.tr("Surfaces left untextured outside the "
                                                                       "orthoimage")))
        self.addOutput(QgsProcessingOutputFile("TILESET", self.tr("3D Tiles tileset (tileset.json)")))
        self.addOutput(QgsProcessingOutputString("STEP_TIMES", self.tr("Seconds per step (JSON)")))
        self.addOutput(QgsProcessingOutputBoolean("REBUILT", self.tr("Built by this run (false: nothing had changed "
                                                                     "since the last run into the folder)")))
        self.addOutput(QgsProcessingOutputString("REBUILD_REASON", self.tr("Why it was built (what changed)")))

    def add_chain_parameters(self) -> None:
        """The inputs and options of the chain (wit:citymodeltiles takes the same)."""
        self.addParameter(QgsProcessingParameterMultipleLayers(
            self.ORTHO_INPUT, self.tr("Orthoimage TIFs or folders"), SourceType.File))
        self.addParameter(QgsProcessingParameterRasterLayer(self.DEM, self.tr("DEM")))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.BUILDINGS, self.tr("Buildings (TL_SPBD_BULD, NGII, AL_D010, OpenStreetMap…)"),
            [SourceType.VectorPolygon]))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.ROADS, self.tr(ROADS_LABEL), ROADS_TYPES, optional=True))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.DISTRICTS, self.tr("Legal dongs (TL_SCCO_EMD)"), [SourceType.VectorPolygon], optional=True))
        add_area_parameters(self)
        self.addParameter(QgsProcessingParameterCrs(
            self.TARGET_CRS, self.tr("Target CRS"), defaultValue="EPSG:5186", optional=True))
        add_height_parameters(self, self.BUILDINGS)
        add_mesh_parameters(self)
        add_triangulator_parameter(self)
        self.addParameter(QgsProcessingParameterNumber(
            self.TEXTURE_SCALE, self.tr("Texture scale S (0 < S ≤ 1)"), NumberType.Double,
            defaultValue=1.0, minValue=0.01, maxValue=1.0))
        self.addParameter(QgsProcessingParameterEnum(
            self.OUTSIDE_ORTHO, self.tr("Surfaces outside the orthoimage"),
            options=[self.tr("Fail and name the missing sheets"), self.tr("Leave them untextured (warning)")],
            defaultValue=0))
        add_facade_parameter(self)
        add_cityjson_parameter(self)
        self.addParameter(QgsProcessingParameterFile(
            self.SCHEMA_DIR, self.tr("Schema folder overriding the shipped schemas (with citygml3-all.xsd)"),
            behavior=FileBehavior.Folder, optional=True))

    def chain_settings(self, parameters, context, feedback):
        """(ChainInputs, ChainOptions, checked height expression) from the parameters."""
        from ..wit_plugin.chain import OUTSIDE_ORTHO_CHOICES, ChainInputs, ChainOptions

        def source(name):
            return self.vector_source(parameters, name, context, feedback)

        buildings = self.parameterAsVectorLayer(parameters, self.BUILDINGS, context)
        heights, expression = height_options(self, parameters, context, buildings)
        configured, cache = schema_choice(self, parameters, self.SCHEMA_DIR, context)
        inputs = ChainInputs(
            ortho=self.parameterAsFileList(parameters, self.ORTHO_INPUT, context),
            dem=self.parameterAsRasterLayer(parameters, self.DEM, context).source(),
            buildings=source(self.BUILDINGS), roads=source(self.ROADS), districts=source(self.DISTRICTS))
        options = ChainOptions(
            area=study_area(self, parameters, context, feedback),
            target_crs=crs_string(self.parameterAsCrs(parameters, self.TARGET_CRS, context)),
            max_edge=self.parameterAsDouble(parameters, MAX_EDGE, context),
            tolerance=self.parameterAsDouble(parameters, TOLERANCE, context),
            triangulator=triangulator(self, parameters, context, feedback),
            texture_scale=self.parameterAsDouble(parameters, self.TEXTURE_SCALE, context),
            facades=facade_choice(self, parameters, context),
            heights=heights,
            outside_ortho=OUTSIDE_ORTHO_CHOICES[self.parameterAsEnum(parameters, self.OUTSIDE_ORTHO, context)],
            schema_dir=configured, schema_cache=cache,
            tiles3d_web=self.parameterAsBool(parameters, WEB_PROFILE, context),
            cityjson=self.parameterAsBool(parameters, CITYJSON, context))
        return inputs, options, expression

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.chain.rerun import update_city_model

        inputs, options, expression = self.chain_settings(parameters, context, feedback)
        options.keep_work = self.parameterAsBool(parameters, self.KEEP_WORK, context)
        options.tiles3d = self.parameterAsBool(parameters, self.TILES3D, context)
        update = update_city_model(inputs, options, self.parameterAsString(parameters, self.OUTPUT, context),
                                   self.parameterAsBool(parameters, REBUILD, context), feedback, apart=True)
        report = update.report
        load_results(context, lod1=report.lod1, tin=report.tin,  # QGIS cannot read the web profile
                     tileset=None if options.tiles3d_web else report.tileset)
        if expression is not None and expression.failure_warning():
            feedback.warning(expression.failure_warning())
        return {
            self.OUTPUT: report.output, "GML": report.gml, "CITYJSON_FILE": report.cityjson,
            "VALIDATION_REPORT": report.validation_report,
            "METRICS": report.metrics, "VALID": report.valid, "ERROR_COUNT": report.errors,
            "BUILDINGS_WRITTEN": report.buildings, "DEFAULT_HEIGHTS": report.default_heights,
            "UNTEXTURED": report.untextured_outside, "TILESET": report.tileset,
            "STEP_TIMES": json.dumps(report.seconds), "REBUILT": update.rebuilt, "REBUILD_REASON": update.reason,
        }
