"""wit:georeferencemapsheets — georeference NGII orthoimage TIFs from their map-sheet numbers."""
from qgis.core import (
    QgsFeature,
    QgsFeatureSink,
    QgsField,
    QgsFields,
    QgsGeometry,
    QgsProcessingOutputMultipleLayers,
    QgsProcessingOutputNumber,
    QgsProcessingParameterCrs,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFeatureSink,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterMultipleLayers,
    QgsProcessingParameterNumber,
    QgsRectangle,
)

from .base import WitAlgorithm, crs_string
from .qgis_compat import FieldType, NumberType, SourceType, WkbType

FORMATS = ("GTiff", "VRT")


class GeoreferenceMapSheets(WitAlgorithm):
    algorithm_id = "georeferencemapsheets"
    display_name = "Georeference map-sheet orthoimages"
    group_name = "Rasters"
    help_text = (
        "Reads the NGII map-sheet number (도엽번호, 1:50,000 to 1:1,000) anywhere in each TIF's file "
        "name, computes the sheet's envelope in the target CRS from the sheet's degree bounds on "
        "the source datum (Korea 2000 / GRS80, EPSG:4737, by default) plus a margin (NGII tiles "
        "cover the sheet + about 50 m), and writes a georeferenced, tiled, compressed GeoTIFF — or "
        "a VRT that points at the untouched pixels. A TIF that already carries a georeference in another "
        "CRS than the target is reprojected from it instead (bilinear, its pixel size in metres). "
        "Names without a valid sheet number and files "
        "GDAL cannot open are skipped with the reason in the log and in the footprint index; "
        "nothing is guessed. Input: TIF files and/or folders (their *.tif, not recursive)."
    )

    INPUT = "INPUT"
    TARGET_CRS = "TARGET_CRS"
    SOURCE_CRS = "SOURCE_CRS"
    MARGIN = "MARGIN"
    FORMAT = "FORMAT"
    OUTPUT = "OUTPUT"
    OUTPUT_INDEX = "OUTPUT_INDEX"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterMultipleLayers(
            self.INPUT, self.tr("Orthoimage TIFs or folders"), SourceType.File))
        # Optional with a default: QGIS 3.22 does not fill a missing mandatory CRS with its default
        # (qgis_process reports it as "not specified"); parameterAsCrs falls back to the default.
        self.addParameter(QgsProcessingParameterCrs(
            self.TARGET_CRS, self.tr("Target CRS"), defaultValue="EPSG:5186", optional=True))
        self.addParameter(QgsProcessingParameterCrs(
            self.SOURCE_CRS, self.tr("Datum of the sheet degrees"), defaultValue="EPSG:4737", optional=True))
        self.addParameter(QgsProcessingParameterNumber(
            self.MARGIN, self.tr("Margin around the sheet (m)"),
            NumberType.Double, defaultValue=50.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterEnum(
            self.FORMAT, self.tr("Output format"), options=[self.tr("GeoTIFF"), self.tr("VRT")],
            defaultValue=0))
        self.addParameter(QgsProcessingParameterFolderDestination(self.OUTPUT, self.tr("Output folder")))
        # Optional (qgis_process needs no value), created by default in the dialog.
        self.addParameter(QgsProcessingParameterFeatureSink(
            self.OUTPUT_INDEX, self.tr("Footprint index"), SourceType.VectorPolygon, optional=True,
            createByDefault=True))
        self.addOutput(QgsProcessingOutputMultipleLayers("OUTPUT_LAYERS", self.tr("Georeferenced rasters")))
        self.addOutput(QgsProcessingOutputNumber("GEOREFERENCED", self.tr("Sheets georeferenced")))
        self.addOutput(QgsProcessingOutputNumber("SKIPPED", self.tr("Files skipped")))
        self.addOutput(QgsProcessingOutputNumber("FAILED", self.tr("Files failed")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.mosaic.georef import FAILED, OK, SKIPPED, georeference_sheets, list_tifs

        target_crs = self.parameterAsCrs(parameters, self.TARGET_CRS, context)
        results = georeference_sheets(
            list_tifs(self.parameterAsFileList(parameters, self.INPUT, context)),
            self.parameterAsString(parameters, self.OUTPUT, context),
            target_crs=crs_string(target_crs),
            source_crs=crs_string(self.parameterAsCrs(parameters, self.SOURCE_CRS, context)),
            margin=self.parameterAsDouble(parameters, self.MARGIN, context),
            fmt=FORMATS[self.parameterAsEnum(parameters, self.FORMAT, context)],
            feedback=feedback,
        )
        fields = index_fields()
        sink, index_id = self.parameterAsSink(parameters, self.OUTPUT_INDEX, context, fields,
                                              WkbType.Polygon, target_crs)
        for result in results if sink is not None else ():
            feature = QgsFeature(fields)
            feature.setAttributes([getattr(result, name) for name in fields.names()])
            if result.bounds:
                feature.setGeometry(QgsGeometry.fromRect(QgsRectangle(*result.bounds)))
            sink.addFeature(feature, QgsFeatureSink.Flag.FastInsert)
        outputs = {self.OUTPUT_INDEX: index_id} if sink is not None else {}
        return {
            **outputs,
            self.OUTPUT: self.parameterAsString(parameters, self.OUTPUT, context),
            "OUTPUT_LAYERS": [r.output for r in results if r.status == OK],
            "GEOREFERENCED": sum(r.status == OK for r in results),
            "SKIPPED": sum(r.status == SKIPPED for r in results),
            "FAILED": sum(r.status == FAILED for r in results),
        }


def index_fields() -> QgsFields:
    """The footprint index's columns, as the core's ``write_footprint_index`` writes them."""
    from ..wit_plugin.mosaic.georef import INDEX_FIELDS

    fields = QgsFields()
    for name, kind in INDEX_FIELDS:
        fields.append(QgsField(name, FieldType.Int if kind is int else FieldType.QString))
    return fields
