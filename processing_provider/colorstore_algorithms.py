"""wit:buildcolorstore and wit:querycolorstore — the paper's vector-based colour store (Kang et al. 2025, §4.1)."""
from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsCoordinateTransform,
    QgsFeature,
    QgsFeatureSink,
    QgsField,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingParameterExtent,
    QgsProcessingParameterFeatureSink,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterDestination,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
)

from .base import WitAlgorithm
from .qgis_compat import FieldType, NumberType, SourceType, WkbType

STORE_HELP = ("The store is a GeoPackage file, or a PostGIS table when a PostgreSQL connection string "
              "(postgresql://user@host:port/database; the password in ~/.pgpass or PGPASSWORD, which keeps it "
              "out of the Processing history) is given.")


class BuildColorStore(WitAlgorithm):
    algorithm_id = "buildcolorstore"
    display_name = "Build colour store"
    group_name = "Texture"
    help_text = (
        "Builds the paper's vector-based colour store from an RGB orthoimage: an adaptive quadtree of "
        "cells, each storing the colours at its four corners (LB, RB, RT, LT) and its level; a cell is "
        "split while bilinear reconstruction from its corners errs by more than the tolerance (RMS, in "
        "0–255 units), down to one pixel. Stored with a spatial index (R-tree in GeoPackage, GiST in "
        "PostGIS), so colours are answered by query instead of loading the image. " + STORE_HELP
    )
    requirements = ("shapely",)

    INPUT = "INPUT"
    TOLERANCE = "TOLERANCE"
    POSTGIS = "POSTGIS"
    TABLE = "TABLE"
    OUTPUT = "OUTPUT"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterRasterLayer(self.INPUT, self.tr("RGB orthoimage")))
        self.addParameter(QgsProcessingParameterNumber(
            self.TOLERANCE, self.tr("Colour tolerance (RMS, 0–255)"), NumberType.Double,
            defaultValue=12.0, minValue=0.5, maxValue=128.0))
        self.addParameter(QgsProcessingParameterString(
            self.POSTGIS, self.tr("PostGIS connection (empty = GeoPackage)"), optional=True))
        self.addParameter(QgsProcessingParameterString(self.TABLE, self.tr("Table"), defaultValue="color_cells"))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.OUTPUT, self.tr("Colour store (GeoPackage)"), self.tr("GeoPackage (*.gpkg)"), optional=True))
        self.addOutput(QgsProcessingOutputNumber("CELLS", self.tr("Cells")))
        self.addOutput(QgsProcessingOutputNumber("STORE_BYTES", self.tr("Store size (bytes)")))
        self.addOutput(QgsProcessingOutputNumber("IMAGE_BYTES", self.tr("Image size (bytes)")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.colorstore import build_color_store

        dsn = self.parameterAsString(parameters, self.POSTGIS, context).strip() or None
        output = None if dsn else self.parameterAsFileOutput(parameters, self.OUTPUT, context)
        if not dsn and not output:
            raise QgsProcessingException(self.tr("Give a GeoPackage output or a PostGIS connection."))
        report = build_color_store(self.parameterAsRasterLayer(parameters, self.INPUT, context).source(), output,
                                   tolerance=self.parameterAsDouble(parameters, self.TOLERANCE, context),
                                   feedback=feedback, postgis_dsn=dsn,
                                   table=self.parameterAsString(parameters, self.TABLE, context))
        return {self.OUTPUT: report.output, "CELLS": report.cells, "STORE_BYTES": report.store_bytes,
                "IMAGE_BYTES": report.image_bytes}


class QueryColorStore(WitAlgorithm):
    algorithm_id = "querycolorstore"
    display_name = "Query colour store"
    group_name = "Texture"
    help_text = (
        "Answers colour queries from a colour store: the RGB colour at each point of a point layer "
        "(bilinear in the leaf cell holding the point), and/or a texture patch over an extent at a "
        "requested resolution, written as an RGB GeoTIFF. " + STORE_HELP
    )
    requirements = ("shapely",)
    path_parameters = ("STORE",)

    STORE = "STORE"
    TABLE = "TABLE"
    POINTS = "POINTS"
    EXTENT = "EXTENT"
    RESOLUTION = "RESOLUTION"
    OUTPUT = "OUTPUT"
    OUTPUT_PATCH = "OUTPUT_PATCH"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterString(
            self.STORE, self.tr("Colour store (GeoPackage path or PostGIS connection)")))
        self.addParameter(QgsProcessingParameterString(self.TABLE, self.tr("Table"), defaultValue="color_cells"))
        self.addParameter(QgsProcessingParameterFeatureSource(
            self.POINTS, self.tr("Points to colour"), [SourceType.VectorPoint], optional=True))
        self.addParameter(QgsProcessingParameterExtent(self.EXTENT, self.tr("Patch extent"), optional=True))
        self.addParameter(QgsProcessingParameterNumber(
            self.RESOLUTION, self.tr("Patch resolution (m)"), NumberType.Double,
            defaultValue=0.5, minValue=0.01))
        self.addParameter(QgsProcessingParameterFeatureSink(
            self.OUTPUT, self.tr("Coloured points"), SourceType.VectorPoint, optional=True))
        self.addParameter(QgsProcessingParameterRasterDestination(
            self.OUTPUT_PATCH, self.tr("Texture patch"), optional=True))
        self.addOutput(QgsProcessingOutputNumber("POINTS_COLOURED", self.tr("Points coloured")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.colorstore import ColorStore, export_patch

        results = {}
        with ColorStore.open(self.parameterAsString(parameters, self.STORE, context),
                             self.parameterAsString(parameters, self.TABLE, context)) as store:
            store_crs = QgsCoordinateReferenceSystem.fromWkt(store.crs_wkt)
            source = self.parameterAsSource(parameters, self.POINTS, context)
            if source is not None:
                to_store = QgsCoordinateTransform(source.sourceCrs(), store_crs, context.transformContext())
                results.update(self._colour_points(parameters, context, feedback, store, source, to_store))
            if parameters.get(self.EXTENT):
                extent = self.parameterAsExtent(parameters, self.EXTENT, context, store_crs)
                patch = self.parameterAsOutputLayer(parameters, self.OUTPUT_PATCH, context)
                results[self.OUTPUT_PATCH] = export_patch(
                    store, (extent.xMinimum(), extent.yMinimum(), extent.xMaximum(), extent.yMaximum()),
                    self.parameterAsDouble(parameters, self.RESOLUTION, context), patch)
        if not results:
            raise QgsProcessingException(self.tr("Give points to colour, a patch extent, or both."))
        return results

    def _colour_points(self, parameters, context, feedback, store, source, to_store) -> dict:
        fields = source.fields()
        for band in ("R", "G", "B"):
            fields.append(QgsField(band, FieldType.Int))
        sink, sink_id = self.parameterAsSink(parameters, self.OUTPUT, context, fields, WkbType.Point,
                                             source.sourceCrs())
        total = max(source.featureCount(), 1)
        count = 0
        for number, feature in enumerate(source.getFeatures()):
            if feedback.is_canceled():
                break
            point = to_store.transform(feature.geometry().asPoint())
            out = QgsFeature(fields)
            out.setGeometry(feature.geometry())
            out.setAttributes(feature.attributes() + list(store.query_point(point.x(), point.y())))
            if sink is not None:
                sink.addFeature(out, QgsFeatureSink.Flag.FastInsert)
            count += 1
            feedback.progress(100.0 * number / total)
        feedback.check_canceled()
        return {self.OUTPUT: sink_id, "POINTS_COLOURED": count}
