"""wit:preparevectors — reproject, repair, clip and simplify the building, road and legal-dong layers."""
from qgis.core import (
    QgsProcessingException,
    QgsProcessingOutputFile,
    QgsProcessingOutputNumber,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterCrs,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterString,
    QgsProcessingParameterVectorLayer,
)

from .base import WitAlgorithm, crs_string
from .qgis_compat import NumberType, SourceType
from .shared_parameters import ROADS_LABEL, ROADS_TYPES, add_area_parameters, study_area


class PrepareVectors(WitAlgorithm):
    algorithm_id = "preparevectors"
    display_name = "Prepare vector layers"
    group_name = "Geometry"
    help_text = (
        "Reads the building (TL_SPBD_BULD, NGII N3A_B0010000, AL_D010, OpenStreetMap…), road and legal-dong "
        "(TL_SCCO_EMD) layers — any layer of the right geometry type; shapefiles are read in their text's "
        "encoding (the .cpg's when it fits the text, else CP949 or UTF-8 as the text shows), field names "
        "included — reprojects them "
        "(EPSG:5186 by default), repairs them (closes rings, orients exteriors counter-clockwise and "
        "holes clockwise, makes them valid, removes duplicate vertices, drops slivers, features with infinite "
        "or NaN coordinates and exact duplicates (same id and footprint) with the reason and a count; the same "
        "id on different footprints gets _2, _3… on its wit_id), "
        "clips them to the study area and simplifies them with Douglas–Peucker (buildings 0.5 m, roads "
        "and districts 5 m by default) so that polygons stay valid and buildings sharing a wall still "
        "share it. Road polygons (NGII N3A_A0010000) are the road surfaces as they are; centre lines become "
        "polygons buffered by width / 2, the width from the layer's width field (ROAD_BT, NGII 도로폭 / RVWD, "
        "OpenStreetMap width), else its lanes × 3.25 m (CARTRK_CO, 차로수, RDLN, lanes), else its class (ROA_CLS_SE, "
        "highway), else the default width; the log names the rule and counts. Study area: a legal-dong "
        "code if given, else a polygon layer if given, else the "
        "centre point and radius. Writes one GeoPackage (buildings, roads, districts, stats, dropped) "
        "and a stats CSV: features in/out, repairs, drops and vertices per layer."
    )
    requirements = ("shapely", "pyproj")

    BUILDINGS = "BUILDINGS"
    ROADS = "ROADS"
    DISTRICTS = "DISTRICTS"
    TARGET_CRS = "TARGET_CRS"
    BUILDING_TOLERANCE = "BUILDING_TOLERANCE"
    ROAD_TOLERANCE = "ROAD_TOLERANCE"
    DISTRICT_TOLERANCE = "DISTRICT_TOLERANCE"
    MIN_AREA = "MIN_AREA"
    DEFAULT_ROAD_WIDTH = "DEFAULT_ROAD_WIDTH"
    ENCODING = "ENCODING"
    OUTPUT = "OUTPUT"

    def initAlgorithm(self, config=None):  # noqa: N802
        for name, label, kinds in (
                (self.BUILDINGS, self.tr("Buildings (TL_SPBD_BULD, NGII, AL_D010, OpenStreetMap…)"),
                 [SourceType.VectorPolygon]),
                (self.ROADS, self.tr(ROADS_LABEL), ROADS_TYPES),
                (self.DISTRICTS, self.tr("Legal dongs (TL_SCCO_EMD)"), [SourceType.VectorPolygon])):
            self.addParameter(QgsProcessingParameterVectorLayer(name, label, kinds, optional=True))
        add_area_parameters(self)
        self.addParameter(QgsProcessingParameterCrs(
            self.TARGET_CRS, self.tr("Target CRS"), defaultValue="EPSG:5186", optional=True))
        self._number(self.BUILDING_TOLERANCE, self.tr("Douglas–Peucker tolerance, buildings (m)"), 0.5, 0.0)
        self._number(self.ROAD_TOLERANCE, self.tr("Douglas–Peucker tolerance, roads (m)"), 5.0, 0.0)
        self._number(self.DISTRICT_TOLERANCE, self.tr("Douglas–Peucker tolerance, districts (m)"), 5.0, 0.0)
        self._number(self.MIN_AREA, self.tr("Minimum building area (m²)"), 1.0, 0.0)
        self._number(self.DEFAULT_ROAD_WIDTH, self.tr("Road width when a centre line has no width, lanes or class (m)"),
                     6.0, 0.1)
        self.addParameter(QgsProcessingParameterString(
            self.ENCODING, self.tr("Shapefile text encoding (empty = detect; CP949 for juso.go.kr files)"),
            optional=True))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.OUTPUT, self.tr("Prepared layers (GeoPackage)"), self.tr("GeoPackage (*.gpkg)")))
        self.addOutput(QgsProcessingOutputVectorLayer("BUILDINGS_OUT", self.tr("Prepared buildings")))
        self.addOutput(QgsProcessingOutputVectorLayer("ROADS_OUT", self.tr("Prepared road polygons")))
        self.addOutput(QgsProcessingOutputVectorLayer("DISTRICTS_OUT", self.tr("Prepared legal dongs")))
        self.addOutput(QgsProcessingOutputVectorLayer("AREA_OUT", self.tr("Study area")))
        self.addOutput(QgsProcessingOutputFile("STATS", self.tr("Statistics (CSV)")))
        self.addOutput(QgsProcessingOutputNumber("BUILDING_COUNT", self.tr("Buildings kept")))

    def _number(self, name: str, label: str, default: float, minimum: float) -> None:
        self.addParameter(QgsProcessingParameterNumber(
            name, label, NumberType.Double, defaultValue=default, minValue=minimum))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.infra import step_layers
        from ..wit_plugin.infra.io.layersource import LayerSource
        from ..wit_plugin.prepare.vectors import PrepareConfig, prepare_vectors

        buildings, roads, districts = (self.vector_source(parameters, name, context, feedback)
                                       for name in (self.BUILDINGS, self.ROADS, self.DISTRICTS))
        if not (buildings or roads or districts):
            raise QgsProcessingException(self.tr("Give at least one of the building, road and district layers."))
        area = study_area(self, parameters, context, feedback)
        config = PrepareConfig(
            target_crs=crs_string(self.parameterAsCrs(parameters, self.TARGET_CRS, context)),
            building_tolerance=self.parameterAsDouble(parameters, self.BUILDING_TOLERANCE, context),
            road_tolerance=self.parameterAsDouble(parameters, self.ROAD_TOLERANCE, context),
            district_tolerance=self.parameterAsDouble(parameters, self.DISTRICT_TOLERANCE, context),
            min_area=self.parameterAsDouble(parameters, self.MIN_AREA, context),
            default_road_width=self.parameterAsDouble(parameters, self.DEFAULT_ROAD_WIDTH, context),
            encoding=self.parameterAsString(parameters, self.ENCODING, context).strip() or None,
        )
        output = self.parameterAsFileOutput(parameters, self.OUTPUT, context)
        report = prepare_vectors(buildings, roads, districts, area, output, config, feedback)
        for stats in report.stats:
            feedback.info(f"{stats.layer}: {stats.features_in} in, {stats.features_out} out, "
                          f"vertices {stats.vertices_in} → {stats.vertices_out}, repaired {stats.repaired}, "
                          f"dropped {stats.dropped}")
        written = set(report.layers)
        layer_uri = {name: str(LayerSource(output, name)) if name in written else None
                     for name in (step_layers.PREPARED_BUILDINGS, step_layers.PREPARED_ROADS,
                                  step_layers.PREPARED_DISTRICTS)}
        kept = {s.layer: s.features_out for s in report.stats}
        return {
            self.OUTPUT: output,
            "BUILDINGS_OUT": layer_uri[step_layers.PREPARED_BUILDINGS],
            "ROADS_OUT": layer_uri[step_layers.PREPARED_ROADS],
            "DISTRICTS_OUT": layer_uri[step_layers.PREPARED_DISTRICTS],
            "AREA_OUT": str(LayerSource(output, step_layers.STUDY_AREA)),
            "STATS": report.stats_csv,
            "BUILDING_COUNT": kept.get(step_layers.PREPARED_BUILDINGS, 0),
        }
