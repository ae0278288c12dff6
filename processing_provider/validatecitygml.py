"""wit:validatecitygml — offline CityGML 3.0 (and CityJSON 2.0) validation: schema, ids, references, geometry,
textures."""
from pathlib import Path

from qgis.core import (
    QgsApplication,
    QgsFeature,
    QgsFeatureSink,
    QgsField,
    QgsFields,
    QgsProcessingOutputBoolean,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
    QgsProcessingParameterFeatureSink,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterMultipleLayers,
    QgsProcessingUtils,
    QgsSettings,
)

from .base import WitAlgorithm
from .qgis_compat import AlgorithmFlag, FieldType, FileBehavior, SourceType, WkbType

#: QgsSettings key of the user's schema folder (used when SCHEMA_DIR is empty)
SCHEMA_SETTING = "wit_citymodel/schema_dir"


class ValidateCityGML(WitAlgorithm):
    algorithm_id = "validatecitygml"
    display_name = "Validate CityGML 3.0"
    group_name = "CityGML"
    help_text = (
        "Validates CityGML 3.0 files offline and reports every problem with file, line and gml:id: "
        "XSD validity against all CityGML 3.0 modules (a file using an ADE whose schema is missing "
        "is reported as such), unique gml:id, every #id / xlink:href reference resolves, building "
        "solids closed, consistently outward-oriented, with planar and non-self-intersecting faces, "
        "TIN triangles non-degenerate, all positions 3D, texture images present and texture "
        "coordinates matching their rings. Geometric tolerances are in metres whatever the CRS: coordinates in "
        "degrees (e.g. EPSG:4326, EPSG:6697) are measured in local metres; an unknown CRS is read as metres, with a "
        "warning. Axis order as GDAL reads it: the short form EPSG:n is longitude (easting) first, the URN and "
        "URL forms follow EPSG's order (latitude or northing first for EPSG:4326, 6697, 5186…); latitudes beyond "
        "±90° are read swapped, with a warning. A file that is empty, not XML, not CityGML 3.0 or "
        "truncated gets one message saying so. CityJSON 2.0 files (.city.json) and CityJSONSeq files "
        "(.city.jsonl) are validated alike: against the official CityJSON 2.0 schemas the plugin ships, and "
        "with the same checks and tolerances (ids, parents and children, vertex indices, solids, TIN triangles, "
        "texture images and values); a tile's sequence of a tiled run finds its images from the run's folder. "
        "Large files are streamed. External entities and network "
        "access are disabled while parsing. Schemas: the SCHEMA_DIR folder (an override, e.g. for an "
        "ADE), else the folder set in the plugin settings, else the CityGML 3.0 schemas the plugin "
        "ships (no network needed); the log says which was used. Results: VALID, ERROR_COUNT and a "
        "per-file table (file, status, details) as in the paper's Table 13, plus HTML and CSV reports (the HTML "
        "report goes to a temporary file when none is chosen)."
    )
    requirements = ("lxml", "shapely")

    INPUT = "INPUT"
    SCHEMA_DIR = "SCHEMA_DIR"
    OUTPUT = "OUTPUT"
    OUTPUT_CSV = "OUTPUT_CSV"
    OUTPUT_TABLE = "OUTPUT_TABLE"

    def flags(self):
        # lxml from a Processing background thread has crashed QGIS on Windows (qgis/QGIS#54751)
        return super().flags() | AlgorithmFlag.NoThreading

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterMultipleLayers(
            self.INPUT, self.tr("CityGML or CityJSON files"), SourceType.File))
        self.addParameter(QgsProcessingParameterFile(
            self.SCHEMA_DIR, self.tr("Schema folder (with citygml3-all.xsd)"),
            behavior=FileBehavior.Folder, optional=True))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.OUTPUT, self.tr("HTML report"), self.tr("HTML files (*.html)"), optional=True, createByDefault=True))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.OUTPUT_CSV, self.tr("CSV report (one row per problem)"), self.tr("CSV files (*.csv)"),
            optional=True, createByDefault=False))
        self.addParameter(QgsProcessingParameterFeatureSink(
            self.OUTPUT_TABLE, self.tr("Validation table"), SourceType.Vector, optional=True))
        self.addOutput(QgsProcessingOutputBoolean("VALID", self.tr("All files valid")))
        self.addOutput(QgsProcessingOutputNumber("ERROR_COUNT", self.tr("Number of errors")))
        self.addOutput(QgsProcessingOutputString("SCHEMA_SOURCE", self.tr("Schemas used")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.citygml.schemas import find_schema_dir
        from ..wit_plugin.citygml.validate import validate_files, write_report_csv, write_report_html
        from ..wit_plugin.cityjson.validate import is_cityjson, validate_cityjson_files

        configured = (self.parameterAsFile(parameters, self.SCHEMA_DIR, context)
                      or QgsSettings().value(SCHEMA_SETTING, "", type=str))
        cache = Path(QgsApplication.qgisSettingsDirPath()) / "cache" / "wit_citymodel"
        schema_dir, source = find_schema_dir(configured or None, str(cache), allow_download=True,
                                             feedback=feedback)
        feedback.info(self.tr("Schemas: {source} ({folder})").format(source=source, folder=schema_dir))
        files = self.parameterAsFileList(parameters, self.INPUT, context)
        cityjson = [path for path in files if is_cityjson(path)]
        citygml = [path for path in files if path not in cityjson]
        reports = validate_files(citygml, schema_dir, feedback=feedback) if citygml or not cityjson else []
        reports += validate_cityjson_files(cityjson, feedback) if cityjson else []
        # optional (batch users only want VALID): a temporary file then, as QGIS does for temporary outputs
        html = (self.parameterAsFileOutput(parameters, self.OUTPUT, context)
                or QgsProcessingUtils.generateTempFilename("validation_report.html"))
        write_report_html(reports, html)
        results = {self.OUTPUT: html}
        csv = self.parameterAsFileOutput(parameters, self.OUTPUT_CSV, context)
        if csv:
            write_report_csv(reports, csv)
            results[self.OUTPUT_CSV] = csv
        fields = QgsFields()
        for name, kind in (("file", FieldType.QString), ("status", FieldType.QString),
                           ("details", FieldType.QString), ("errors", FieldType.Int), ("warnings", FieldType.Int)):
            fields.append(QgsField(name, kind))
        sink, table_id = self.parameterAsSink(parameters, self.OUTPUT_TABLE, context, fields, WkbType.NoGeometry)
        errors = 0
        for report in reports:
            counts = [sum(i.severity == s for i in report.issues) for s in ("error", "warning")]
            errors += counts[0]
            feedback.info(f"{report.file}: {report.status} — {report.details}")
            if sink is not None:
                feature = QgsFeature(fields)
                feature.setAttributes([report.file, report.status, report.details, *counts])
                sink.addFeature(feature, QgsFeatureSink.Flag.FastInsert)
        if sink is not None:
            results[self.OUTPUT_TABLE] = table_id
        results.update(VALID=all(r.valid for r in reports), ERROR_COUNT=errors, SCHEMA_SOURCE=source)
        return results
