"""wit:mergerasters — streaming mosaic of georeferenced rasters (orthoimage sheets, DEM pieces), overwrite (paper)
or WIT feather. Its first id, wit:mergetiles, still runs (saved models and scripts call it) but is deprecated:
hidden from the toolbox and the modeler, as QGIS hides its own renamed algorithms."""
from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterEnum,
    QgsProcessingParameterExtent,
    QgsProcessingParameterMultipleLayers,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterDestination,
)

from ..wit_plugin.mosaic import DEFAULT_MAX_EMPTY
from .base import WitAlgorithm
from .qgis_compat import AlgorithmFlag, NumberType, ParameterFlag, SourceType

MODES = ("overwrite", "feather")


class MergeRasters(WitAlgorithm):
    algorithm_id = "mergerasters"
    display_name = "Merge rasters (WIT seam feathering)"
    group_name = "Rasters"
    help_text = (
        "Mosaics georeferenced tiles into one tiled, compressed GeoTIFF with internal overviews, "
        "block by block so memory does not grow with the mosaic. The output grid is the one "
        "gdal_merge.py builds (union extent, first input's pixel size). Overlap 'overwrite' lets "
        "later tiles overwrite earlier ones (the paper's method); 'feather' (WIT) blends each "
        "overlap pixel as the mean of the tiles weighted by the distance to each tile's edge. "
        "Tone correction (GAIN) equalises the tiles' tone from their overlaps: every pixel of a tile "
        "becomes gain × value + offset, per band, solved over all overlaps at once; heights (one band "
        "of floats or signed integers, a DEM) get an offset only, never a gain. NoData pixels are "
        "never blended. Inputs with another CRS or pixel size are resampled onto the first input's "
        "grid, with a warning. A mosaic that would be mostly empty (tiles far apart) is refused "
        "beyond the maximum empty share (advanced). With an extent, only the mosaic's pixels that meet it "
        "are written, with the tone and feathering of the whole mosaic."
    )

    INPUT = "INPUT"
    OVERLAP = "OVERLAP"
    GAIN = "GAIN"
    NODATA = "NODATA"
    MAX_EMPTY = "MAX_EMPTY"
    EXTENT = "EXTENT"
    OUTPUT = "OUTPUT"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterMultipleLayers(
            self.INPUT, self.tr("Input rasters"), SourceType.Raster))
        self.addParameter(QgsProcessingParameterEnum(
            self.OVERLAP, self.tr("Overlap"),
            options=[self.tr("Overwrite (paper)"), self.tr("Feather (WIT)")], defaultValue=1))
        self.addParameter(QgsProcessingParameterBoolean(
            self.GAIN, self.tr("Equalise tile tone (gain and offset; with feather)"), defaultValue=True))
        self.addParameter(QgsProcessingParameterNumber(
            self.NODATA, self.tr("NoData value of the inputs (empty = as declared)"),
            NumberType.Double, optional=True))
        max_empty = QgsProcessingParameterNumber(
            self.MAX_EMPTY, self.tr("Maximum empty share of the mosaic (%)"), NumberType.Double,
            defaultValue=100 * DEFAULT_MAX_EMPTY, minValue=0.0, maxValue=100.0, optional=True)  # old models stay valid
        max_empty.setFlags(max_empty.flags() | ParameterFlag.Advanced)
        self.addParameter(max_empty)
        self.addParameter(QgsProcessingParameterExtent(
            self.EXTENT, self.tr("Write only this extent of the mosaic (empty = all of it)"), optional=True))
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, self.tr("Mosaic")))
        self.addOutput(QgsProcessingOutputNumber("BLENDED_PIXELS", self.tr("Blended pixels")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.mosaic import merge_rasters

        layers = self.parameterAsLayerList(parameters, self.INPUT, context)
        mode = MODES[self.parameterAsEnum(parameters, self.OVERLAP, context)]
        nodata = parameters.get(self.NODATA)
        output = self.parameterAsOutputLayer(parameters, self.OUTPUT, context)
        report = merge_rasters(
            [layer.source() for layer in layers],
            output,
            mode=mode,
            gain=mode == "feather" and self.parameterAsBool(parameters, self.GAIN, context),
            nodata=None if nodata in (None, "") else self.parameterAsDouble(parameters, self.NODATA, context),
            feedback=feedback,
            max_empty=self.parameterAsDouble(parameters, self.MAX_EMPTY, context) / 100.0,
            extent=self._extent(parameters, context, layers),
        )
        return {self.OUTPUT: output, "BLENDED_PIXELS": report.blended_pixels}

    def _extent(self, parameters, context, layers):
        """The EXTENT parameter in the first input's CRS (the mosaic's), or None."""
        if not parameters.get(self.EXTENT) or not layers:
            return None
        box = self.parameterAsExtent(parameters, self.EXTENT, context, layers[0].crs())
        return box.xMinimum(), box.yMinimum(), box.xMaximum(), box.yMaximum()


class MergeRastersFirstId(MergeRasters):
    """The same algorithm under its first id, for models and scripts saved before the rename."""

    algorithm_id = "mergetiles"

    def flags(self):
        return super().flags() | AlgorithmFlag.Deprecated
