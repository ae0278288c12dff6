"""wit:mergetiles — streaming mosaic of georeferenced tiles, overwrite (paper) or WIT feather."""
from qgis.core import (
    QgsProcessing,
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterEnum,
    QgsProcessingParameterMultipleLayers,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterDestination,
)

from .base import WitAlgorithm

MODES = ("overwrite", "feather")


class MergeTiles(WitAlgorithm):
    algorithm_id = "mergetiles"
    display_name = "Merge tiles (WIT seam feathering)"
    group_name = "Rasters"
    help_text = (
        "Mosaics georeferenced tiles into one tiled, compressed GeoTIFF with internal overviews, "
        "block by block so memory does not grow with the mosaic. The output grid is the one "
        "gdal_merge.py builds (union extent, first input's pixel size). Overlap 'overwrite' lets "
        "later tiles overwrite earlier ones (the paper's method); 'feather' (WIT) blends each "
        "overlap pixel as the mean of the tiles weighted by the distance to each tile's edge. "
        "Gain equalises the tiles' brightness from their overlaps (every pixel of a tile is "
        "scaled by its gain). NoData pixels are never blended. Inputs with another CRS or pixel "
        "size are resampled onto the first input's grid, with a warning."
    )

    INPUT = "INPUT"
    OVERLAP = "OVERLAP"
    GAIN = "GAIN"
    NODATA = "NODATA"
    OUTPUT = "OUTPUT"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterMultipleLayers(
            self.INPUT, self.tr("Input rasters"), QgsProcessing.TypeRaster))
        self.addParameter(QgsProcessingParameterEnum(
            self.OVERLAP, self.tr("Overlap"),
            options=[self.tr("Overwrite (paper)"), self.tr("Feather (WIT)")], defaultValue=1))
        self.addParameter(QgsProcessingParameterBoolean(
            self.GAIN, self.tr("Equalise tile brightness (gain; with feather)"), defaultValue=True))
        self.addParameter(QgsProcessingParameterNumber(
            self.NODATA, self.tr("NoData value of the inputs (empty = as declared)"),
            QgsProcessingParameterNumber.Double, optional=True))
        self.addParameter(QgsProcessingParameterRasterDestination(self.OUTPUT, self.tr("Mosaic")))
        self.addOutput(QgsProcessingOutputNumber("BLENDED_PIXELS", self.tr("Blended pixels")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.mosaic import merge_tiles

        layers = self.parameterAsLayerList(parameters, self.INPUT, context)
        mode = MODES[self.parameterAsEnum(parameters, self.OVERLAP, context)]
        nodata = parameters.get(self.NODATA)
        output = self.parameterAsOutputLayer(parameters, self.OUTPUT, context)
        report = merge_tiles(
            [layer.source() for layer in layers],
            output,
            mode=mode,
            gain=mode == "feather" and self.parameterAsBool(parameters, self.GAIN, context),
            nodata=None if nodata in (None, "") else self.parameterAsDouble(parameters, self.NODATA, context),
            feedback=feedback,
        )
        return {self.OUTPUT: output, "BLENDED_PIXELS": report.blended_pixels}
