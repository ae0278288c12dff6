"""The ``wit`` Processing provider."""
from qgis.core import QgsApplication, QgsProcessingModelAlgorithm, QgsProcessingProvider
from qgis.PyQt.QtGui import QIcon

from ..wit_plugin.infra.version import plugin_version
from .base import PLUGIN_DIR
from .citymodel import CityModel
from .citymodeltiles import CityModelTiles
from .colorstore_algorithms import BuildColorStore, QueryColorStore
from .export3dtiles import Export3DTiles
from .exportcityjson import ExportCityJSON
from .extrudebuildings import ExtrudeBuildings
from .generatesample import GenerateSample
from .georeferencemapsheets import GeoreferenceMapSheets
from .installdependencies import InstallDependencies
from .mergerasters import MergeRasters, MergeRastersFirstId
from .preparevectors import PrepareVectors
from .qualitymetrics import QualityMetrics
from .translation import tr, translatable
from .triangulateterrain import TriangulateTerrain
from .validatecitygml import ValidateCityGML
from .wittexture import WitTexture
from .writecitygml import WriteCityGML

ALGORITHMS = (
    GenerateSample,
    GeoreferenceMapSheets,
    MergeRasters,
    MergeRastersFirstId,
    PrepareVectors,
    TriangulateTerrain,
    ExtrudeBuildings,
    WitTexture,
    WriteCityGML,
    ExportCityJSON,
    Export3DTiles,
    ValidateCityGML,
    BuildColorStore,
    QueryColorStore,
    QualityMetrics,
    CityModel,
    CityModelTiles,
    InstallDependencies,
)


#: graphical models shipped in models/ (built by scripts/make_model.py): file → display name
MODELS = {"wit_citymodel.model3": translatable("City model (graphical model)")}


class ShippedModel(QgsProcessingModelAlgorithm):
    """A shipped model: id from its name (wit:citymodelmodel), a readable display name, the group
    id the wit algorithms use (a model's group id is its group name, so "Chain" ≠ "chain")."""

    def __init__(self, path: str = "", display_name: str = ""):
        super().__init__()
        self._display_name = display_name
        if path:
            self.fromFile(path)
            self.setSourceFilePath(path)

    def displayName(self) -> str:  # noqa: N802
        return tr(self._display_name) if self._display_name else self.name()

    def group(self) -> str:
        return tr(super().group())

    def groupId(self) -> str:  # noqa: N802
        return super().group().lower().replace(" ", "")

    def createInstance(self):  # noqa: N802
        return ShippedModel(self.sourceFilePath(), self._display_name)


class WitProvider(QgsProcessingProvider):
    def id(self) -> str:
        return "wit"

    def name(self) -> str:
        return tr("WIT City Model")

    def longName(self) -> str:  # noqa: N802
        return tr("WIT City Model: textured CityGML 3.0 from Korean national GIS data")

    def icon(self) -> QIcon:
        return QIcon(str(PLUGIN_DIR / "icon.svg"))

    def versionInfo(self) -> str:  # noqa: N802
        return plugin_version()

    def load(self) -> bool:
        # A model's steps (wit:…) resolve only once this provider is registered, i.e. after load():
        # reload then, so the registered models have their outputs and validate.
        QgsApplication.processingRegistry().providerAdded.connect(self._reload_when_registered)
        return super().load()

    def _reload_when_registered(self, provider_id: str) -> None:
        if provider_id == self.id():
            QgsApplication.processingRegistry().providerAdded.disconnect(self._reload_when_registered)
            self.refreshAlgorithms()

    def loadAlgorithms(self):  # noqa: N802
        for algorithm in ALGORITHMS:
            self.addAlgorithm(algorithm())
        for file_name, display_name in MODELS.items():
            self.addAlgorithm(ShippedModel(str(PLUGIN_DIR / "processing_provider" / "models" / file_name),
                                           display_name))
