"""wit:qualitymetrics — the paper's Tables 17 and 19: positions, shape similarity, texture quality."""
from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterVectorLayer,
)

from .base import WitAlgorithm
from .qgis_compat import FileBehavior, SourceType


class QualityMetrics(WitAlgorithm):
    algorithm_id = "qualitymetrics"
    display_name = "Quality metrics"
    group_name = "CityGML"
    help_text = (
        "Measures the model against its sources, as the paper's Tables 17 and 19 (paper figures beside "
        "ours). Geometry (the CityGML file or the LoD1 layer against the prepared 2D footprints, matched "
        "by wit_id): placement error = distance between the centroids of footprint and ground face; "
        "coordinate error = each roof vertex to the nearest footprint vertex (mean, max); Hausdorff "
        "distance of the outlines; shape similarity index SSI = area(A∩B) / area(A∪B) (intersection "
        "over union) of footprint and ground face. Texture: sharpness = variance of the 4-neighbour "
        "Laplacian of the grey image (0.299R + 0.587G + 0.114B, as OpenCV's Laplacian().var()) and "
        "contrast = standard deviation of the grey values, on the texture images (inside the texture "
        "islands) and on the orthoimage for comparison. Seams: mean colour step across tile borders in "
        "the mosaic. Writes a CSV table, per-building rows, a GeoPackage and an HTML report."
    )
    requirements = ("shapely", "lxml")

    MODEL = "MODEL"
    SOURCE_BUILDINGS = "SOURCE_BUILDINGS"
    TEXTURES = "TEXTURES"
    ORTHO = "ORTHO"
    MOSAIC = "MOSAIC"
    FOOTPRINTS = "FOOTPRINTS"
    OUTPUT = "OUTPUT"
    OUTPUT_HTML = "OUTPUT_HTML"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterFile(
            self.MODEL, self.tr("Model: CityGML file or LoD1 GeoPackage"), optional=True))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.SOURCE_BUILDINGS, self.tr("2D source footprints (prepared buildings)"),
            [SourceType.VectorPolygon], optional=True))
        self.addParameter(QgsProcessingParameterFile(
            self.TEXTURES, self.tr("Texture folder (wit:wittexture)"),
            behavior=FileBehavior.Folder, optional=True))
        self.addParameter(QgsProcessingParameterRasterLayer(
            self.ORTHO, self.tr("Orthoimage for comparison"), optional=True))
        self.addParameter(QgsProcessingParameterRasterLayer(
            self.MOSAIC, self.tr("Merged mosaic (seam step)"), optional=True))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.FOOTPRINTS, self.tr("Tile footprints (index of wit:georeferencemapsheets)"),
            [SourceType.VectorPolygon], optional=True))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.OUTPUT, self.tr("Metrics table (CSV)"), self.tr("CSV files (*.csv)")))
        self.addParameter(QgsProcessingParameterFileDestination(
            self.OUTPUT_HTML, self.tr("HTML report"), self.tr("HTML files (*.html)"), optional=True))
        for name, label in (("PLACEMENT_MEAN_ERROR", self.tr("Mean placement error (m)")),
                            ("COORDINATE_MAX_ERROR", self.tr("Maximum coordinate error (m)")),
                            ("SSI_MEAN", self.tr("Mean shape similarity (IoU)")),
                            ("LAPLACIAN_VARIANCE", self.tr("Texture sharpness (Laplacian variance)")),
                            ("CONTRAST", self.tr("Texture contrast (grey std)")),
                            ("SEAM_STEP", self.tr("Seam step across tile borders"))):
            self.addOutput(QgsProcessingOutputNumber(name, label))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.metrics import quality_report

        def raster(name):
            layer = self.parameterAsRasterLayer(parameters, name, context)
            return layer.source() if layer is not None else None

        def source(name):
            return self.vector_source(parameters, name, context, feedback)

        output = self.parameterAsFileOutput(parameters, self.OUTPUT, context)
        html = self.parameterAsFileOutput(parameters, self.OUTPUT_HTML, context) or None
        report = quality_report(
            output,
            model_source=self.parameterAsFile(parameters, self.MODEL, context) or None,
            source_buildings=source(self.SOURCE_BUILDINGS),
            textures=self.parameterAsFile(parameters, self.TEXTURES, context) or None,
            ortho=raster(self.ORTHO), mosaic=raster(self.MOSAIC),
            footprints=source(self.FOOTPRINTS),
            output_html=html, feedback=feedback)
        values = {r.metric: r.value for r in report.rows}
        for row in report.rows:
            feedback.info(f"{row.group}: {row.metric} = {row.value:.6g} {row.unit}"
                          + (f" (paper {row.paper})" if row.paper is not None else ""))
        results = {self.OUTPUT: output,
                   "PLACEMENT_MEAN_ERROR": values.get("placement_mean_error"),
                   "COORDINATE_MAX_ERROR": values.get("coordinate_max_error"),
                   "SSI_MEAN": values.get("ssi_mean"),
                   "LAPLACIAN_VARIANCE": values.get("model_laplacian_variance"),
                   "CONTRAST": values.get("model_contrast"),
                   "SEAM_STEP": values.get("seam_step")}
        if html:
            results[self.OUTPUT_HTML] = html
        return results

