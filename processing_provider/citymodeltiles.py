"""wit:citymodeltiles — the whole chain over a district or a city, in NGII map-sheet tiles on Dask."""
import json
import os

from qgis.core import (
    QgsFeatureRequest,
    QgsField,
    QgsFields,
    QgsProcessingException,
    QgsProcessingOutputFile,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterEnum,
    QgsProcessingParameterExtent,
    QgsProcessingParameterFile,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterString,
    QgsVectorFileWriter,
    QgsVectorLayer,
    QgsWkbTypes,
)

from .base import crs_string
from .citymodel import CityModel
from .load_results import load_index, load_results
from .qgis_compat import FieldType, NumberType, ParameterFlag
from .shared_parameters import REBUILD, add_rebuild_parameter, add_web_profile_parameter

EXPRESSION_COLUMN = "wit_expr_height"


class CityModelTiles(CityModel):
    algorithm_id = "citymodeltiles"
    display_name = "City model in map-sheet tiles (Dask)"
    group_name = "Chain"
    help_text = (
        "The whole chain (as wit:citymodel, with the same inputs and options) over a district or a whole "
        "city, cut into tiles on the NGII map-sheet grid (1:5,000 by default, 1:1,000 for dense cities): "
        "the sheet number is the tile id, so tiles line up with the orthoimage sheets. Area: a legal dong "
        "(code or name), else a polygon layer, else a bounding box, else everything the buildings layer "
        "covers (when asked), else the centre and radius. Every building belongs to exactly one tile, the "
        "sheet of its point on surface; the terrain of neighbouring tiles shares its border vertices and "
        "heights, roads are cut along the same border, and a building crossing it lies on terrain in its "
        "own tile. Tiles run in parallel on Dask distributed: an embedded scheduler with WORKERS worker "
        "processes of a plain Python (never QGIS itself; WORKER_PYTHON to choose it), or an existing "
        "scheduler (SCHEDULER, e.g. tcp://10.0.0.5:8786: a stock dask scheduler, whose workers import the "
        "plugin's core wit_plugin and see the same files). The output folder receives tiles/<sheet>/model.gml (with "
        "textures and validation.html) per tile and index.gpkg, a map of the run (status done / failed / "
        "empty, buildings, triangles, seconds, peak memory, error, fingerprint, reason). A tile whose data "
        "cannot be made fails with its reason and the others go on; the algorithm then ends with an error "
        "giving the count and the first reasons, the tiles done kept; Cancel stops every tile. Run again into "
        "the same folder, it updates the city: each tile records what it was built from (every setting, the "
        "plugin's version, the triangulator, and its inputs as they fall in its area with the margin it reads, "
        "by content); the tiles whose inputs and settings have not changed are kept as they are, the others "
        "built again, tiles that left the area removed and new ones built, and the levels above refreshed "
        "where a child changed (TILES_KEPT, TILES_REBUILT with REBUILD_REASONS, TILES_ADDED, TILES_REMOVED). "
        "REBUILD builds every tile again. A tile that keeps no building (a park, a hill, buildings that all belong to "
        "neighbouring tiles or are too small) still gets its terrain and roads (status empty). With 3D Tiles "
        "on, each tile writes its tileset and tileset.json at the top of the output folder joins them into "
        "one, below groups by map sheet (1:5,000, 1:50,000, 1° block, as many levels as the run needs) that "
        "show the terrain and the largest buildings from afar (open it in the viewer, or as a 3D Tiles layer "
        "in QGIS 3.34 and later). With CITYJSON, each tile also writes model.city.jsonl, a CityJSONSeq in the "
        "run's one transform, and index.city.jsonl at the top is the run's header line listing them: its line and "
        "the tiles' features, joined, are one CityJSONSeq of the whole run."
    )

    TILE_SCALE = "TILE_SCALE"
    EXTENT = "EXTENT"
    ALL_BUILDINGS = "ALL_BUILDINGS"
    SCHEDULER = "SCHEDULER"
    WORKERS = "WORKERS"
    WORKER_PYTHON = "WORKER_PYTHON"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.add_chain_parameters()
        self.addParameter(QgsProcessingParameterExtent(
            self.EXTENT, self.tr("Bounding box (instead of centre and radius)"), optional=True))
        self.addParameter(QgsProcessingParameterBoolean(
            self.ALL_BUILDINGS, self.tr("Everything the buildings layer covers (instead of centre and radius)"),
            defaultValue=False))
        self.addParameter(QgsProcessingParameterEnum(
            self.TILE_SCALE, self.tr("Tile grid (NGII map sheets)"),
            options=[self.tr("1:5,000 sheets"), self.tr("1:1,000 sheets (dense cities)")],  # TILE_SCALES' order
            defaultValue=0))
        self.addParameter(QgsProcessingParameterString(
            self.SCHEDULER, self.tr("Dask scheduler address (empty = an embedded one on this computer)"),
            optional=True))
        self.addParameter(QgsProcessingParameterNumber(
            self.WORKERS, self.tr("Worker processes (embedded scheduler)"), NumberType.Integer,
            defaultValue=os.cpu_count() or 1, minValue=1))
        python = QgsProcessingParameterFile(
            self.WORKER_PYTHON, self.tr("Python interpreter of the workers (empty = found automatically)"),
            optional=True)
        python.setFlags(python.flags() | ParameterFlag.Advanced)
        self.addParameter(python)
        self.addParameter(QgsProcessingParameterBoolean(
            self.TILES3D, self.tr("Write a 3D Tiles 1.1 tileset over all tiles (tileset.json) for viewers"),
            defaultValue=True))
        add_web_profile_parameter(self, advanced=True)
        add_rebuild_parameter(self)
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTPUT, self.tr("Output folder")))
        self.addOutput(QgsProcessingOutputVectorLayer("INDEX", self.tr("Tile index")))
        self.addOutput(QgsProcessingOutputFile("CITYJSON_INDEX", self.tr("CityJSONSeq header of the run "
                                                                         "(index.city.jsonl)")))
        self.addOutput(QgsProcessingOutputFile("TILESET", self.tr("3D Tiles tileset over all tiles (tileset.json)")))
        for name, label in (("TILES_DONE", self.tr("Tiles done")), ("TILES_FAILED", self.tr("Tiles failed")),
                            ("TILES_EMPTY", self.tr("Tiles without buildings")),
                            ("TILES_KEPT", self.tr("Tiles kept as they were (nothing they read had changed)")),
                            ("TILES_RESUMED", self.tr("Tiles already done before this run (kept: as TILES_KEPT)")),
                            ("TILES_REBUILT", self.tr("Tiles built again (what they read had changed)")),
                            ("TILES_ADDED", self.tr("Tiles new to the output")),
                            ("TILES_REMOVED", self.tr("Tiles removed (they left the area)")),
                            ("BUILDINGS_WRITTEN", self.tr("Buildings written"))):
            self.addOutput(QgsProcessingOutputNumber(name, label))
        self.addOutput(QgsProcessingOutputString(
            "REBUILD_REASONS", self.tr("Why tiles were built again (JSON: reason → number of tiles)")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.prepare.area import StudyArea
        from ..wit_plugin.sheetrun.plan import TILE_SCALES
        from ..wit_plugin.sheetrun.runner import run_tiles

        inputs, options, expression = self.chain_settings(parameters, context, feedback)
        options.tiles3d = self.parameterAsBool(parameters, self.TILES3D, context)
        output = self.parameterAsString(parameters, self.OUTPUT, context)
        area = options.area
        code = self.parameterAsString(parameters, "DISTRICT_CODE", context).strip()
        if not code and self.parameterAsVectorLayer(parameters, "AREA_LAYER", context) is None:
            if parameters.get(self.EXTENT):
                target = self.parameterAsCrs(parameters, self.TARGET_CRS, context)
                box = self.parameterAsExtent(parameters, self.EXTENT, context, target)
                area = StudyArea.polygon(box.asWktPolygon(), crs_string(target))
            elif self.parameterAsBool(parameters, self.ALL_BUILDINGS, context):
                area = None
        if expression is not None:  # workers have no QGIS: the expression is evaluated here, into a copy
            inputs.buildings = self._evaluated_copy(parameters, context, expression, output, feedback)
            options.heights.expression, options.heights.expression_column = None, EXPRESSION_COLUMN
        report = run_tiles(inputs, options, output, area, TILE_SCALES[self.parameterAsEnum(
            parameters, self.TILE_SCALE, context)], self.parameterAsString(parameters, self.SCHEDULER, context).strip()
            or None, self.parameterAsInt(parameters, self.WORKERS, context),
            self.parameterAsFile(parameters, self.WORKER_PYTHON, context) or None, feedback,
            self.parameterAsBool(parameters, REBUILD, context))
        failed = [row for row in report.rows if row["status"] == "failed"]
        if failed:
            reasons = "; ".join(f"{row['sheet']}: {row['error'].splitlines()[0][:300]}" for row in failed[:3])
            raise QgsProcessingException(self.tr(
                "{failed} of {tiles} tile(s) failed. First reasons: {reasons}. The tiles done are kept in {output} "
                "(map of the run: index.gpkg); run the algorithm again on this folder to build only the others."
            ).format(failed=len(failed), tiles=len(report.rows), reasons=reasons, output=output))
        load_index(context, report.index)
        load_results(context, tileset=None if options.tiles3d_web else report.tileset)  # QGIS cannot read it
        return {self.OUTPUT: output, "INDEX": report.index, "TILESET": report.tileset,
                "CITYJSON_INDEX": report.cityjson, "TILES_DONE": report.count("done"),
                "TILES_FAILED": report.count("failed"), "TILES_EMPTY": report.count("empty"),
                "TILES_KEPT": len(report.update.kept), "TILES_RESUMED": report.resumed,
                "TILES_REBUILT": len(report.update.rebuilt), "TILES_ADDED": len(report.update.added),
                "TILES_REMOVED": len(report.update.removed), "REBUILD_REASONS": json.dumps(report.reasons()),
                "BUILDINGS_WRITTEN": report.buildings}

    def _evaluated_copy(self, parameters, context, expression, output, feedback) -> str:
        """The buildings layer with the height expression's value in EXPRESSION_COLUMN, in <output>/work."""
        from pathlib import Path

        layer = self.parameterAsVectorLayer(parameters, self.BUILDINGS, context)
        work = Path(output) / "work"
        work.mkdir(parents=True, exist_ok=True)
        target = str(work / "buildings_expression.gpkg")
        fields = QgsFields(layer.fields())
        fields.append(QgsField(EXPRESSION_COLUMN, FieldType.Double))
        memory = QgsVectorLayer(QgsWkbTypes.displayString(layer.wkbType()), "buildings", "memory")
        memory.setCrs(layer.crs())
        memory.dataProvider().addAttributes(fields.toList())
        memory.updateFields()
        rows = []
        for feature in layer.getFeatures(QgsFeatureRequest()):
            value = expression({name: feature[name] for name in layer.fields().names()})
            copy = feature.__class__(memory.fields())
            copy.setGeometry(feature.geometry())
            copy.setAttributes(list(feature.attributes()) + [value])
            rows.append(copy)
        memory.dataProvider().addFeatures(rows)
        options = QgsVectorFileWriter.SaveVectorOptions()
        options.driverName = "GPKG"
        error = QgsVectorFileWriter.writeAsVectorFormatV2(memory, target, context.transformContext(), options)
        if error[0] != QgsVectorFileWriter.WriterError.NoError:
            raise QgsProcessingException(self.tr("Cannot write {path}: {error}").format(path=target, error=error[1]))
        if expression.failure_warning():
            feedback.warning(expression.failure_warning())
        return target
