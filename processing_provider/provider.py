"""The ``wit`` Processing provider."""
from qgis.core import QgsProcessingProvider
from qgis.PyQt.QtGui import QIcon

from .base import PLUGIN_DIR, tr
from .citymodel import CityModel
from .colorstore_algorithms import BuildColorStore, QueryColorStore
from .generatesample import GenerateSample
from .georeferencemapsheets import GeoreferenceMapSheets
from .extrudebuildings import ExtrudeBuildings
from .mergetiles import MergeTiles
from .preparevectors import PrepareVectors
from .qualitymetrics import QualityMetrics
from .triangulateterrain import TriangulateTerrain
from .validatecitygml import ValidateCityGML
from .wittexture import WitTexture
from .writecitygml import WriteCityGML

ALGORITHMS = (
    GenerateSample,
    GeoreferenceMapSheets,
    MergeTiles,
    PrepareVectors,
    TriangulateTerrain,
    ExtrudeBuildings,
    WitTexture,
    WriteCityGML,
    ValidateCityGML,
    BuildColorStore,
    QueryColorStore,
    QualityMetrics,
    CityModel,
)


class WitProvider(QgsProcessingProvider):
    def id(self) -> str:
        return "wit"

    def name(self) -> str:
        return tr("WIT City Model")

    def longName(self) -> str:  # noqa: N802
        return tr("WIT City Model: textured CityGML 3.0 from Korean national GIS data")

    def icon(self) -> QIcon:
        return QIcon(str(PLUGIN_DIR / "icon.svg"))

    def loadAlgorithms(self):  # noqa: N802
        for algorithm in ALGORITHMS:
            self.addAlgorithm(algorithm())
