"""QGIS plugin object: installs the translation, registers the Processing provider and, in the QGIS window,
offers the dependency installer when an algorithm lacks a package."""
from pathlib import Path

from osgeo import gdal
from qgis.core import Qgis, QgsApplication
from qgis.PyQt.QtCore import QCoreApplication, QLocale, QSettings, QTranslator
from qgis.PyQt.QtWidgets import QPushButton

from .processing_provider.dependency_notice import NOTICE
from .processing_provider.provider import WitProvider
from .processing_provider.translation import tr

PLUGIN_DIR = Path(__file__).resolve().parent


def user_locale() -> str:
    """The two-letter language QGIS runs in (its own setting, else the system's)."""
    settings = QSettings()
    if settings.value("locale/overrideFlag", False, type=bool):
        name = settings.value("locale/userLocale", "", type=str)
    else:
        name = QLocale.system().name()
    return (name or "en")[:2]


def install_translator(locale: str) -> "QTranslator | None":
    """Load i18n/wit_citymodel_<locale>.qm if it exists; English needs none."""
    qm = PLUGIN_DIR / "i18n" / f"wit_citymodel_{locale}.qm"
    if not qm.exists():
        return None
    translator = QTranslator()
    if not translator.load(str(qm)):
        return None
    QCoreApplication.installTranslator(translator)
    return translator


def batch_reads_write_nothing() -> None:
    """In qgis_process, QGIS loads the input layers itself before any algorithm code runs, and computes
    raster statistics then: with GDAL's PAM on they end up in an .aux.xml beside the input (the
    algorithms' own reads turn PAM off, ``gdal_env.no_sidecars``, but cannot reach these). A batch run
    keeps nothing in PAM that it needs, so PAM is off for the whole qgis_process process."""
    if QgsApplication.platform() == "qgis_process":
        gdal.SetConfigOption("GDAL_PAM_ENABLED", "NO")


def open_installer():
    """The dialog of wit:installdependencies (non-modal: the user watches it work)."""
    import processing

    dialog = processing.createAlgorithmDialog("wit:installdependencies")
    dialog.show()
    return dialog


class WitCityModelPlugin:
    """Loaded by QGIS (classFactory); qgis_process calls initProcessing() only."""

    def __init__(self, iface):
        self.iface = iface
        self.provider = None
        self.translator = install_translator(user_locale())
        self.notice = None  # the message bar item offering the installer
        self.installer_dialog = None

    def initProcessing(self):  # noqa: N802 (QGIS API name)
        batch_reads_write_nothing()
        if self.provider is None:
            self.provider = WitProvider()
            QgsApplication.processingRegistry().addProvider(self.provider)

    def initGui(self):  # noqa: N802 (QGIS API name)
        self.initProcessing()
        NOTICE.missing.connect(self.offer_installer)

    def offer_installer(self, missing: list) -> None:
        """A message bar item with a button that opens 'Install Python dependencies' (once at a time)."""
        bar = self.iface.messageBar()
        if self.notice is not None and self.notice in bar.items():
            return
        item = bar.createMessage(tr("WIT City Model"), tr("Missing Python packages: {packages}.").format(
            packages=", ".join(missing)))
        button = QPushButton(tr("Install Python dependencies…"), item)
        button.clicked.connect(self.show_installer)
        item.layout().addWidget(button)
        bar.pushWidget(item, Qgis.MessageLevel.Warning)
        self.notice = item

    def show_installer(self) -> None:
        bar = self.iface.messageBar()
        if self.notice in bar.items():
            bar.popWidget(self.notice)
        self.notice = None
        self.installer_dialog = open_installer()

    def unload(self):
        try:
            NOTICE.missing.disconnect(self.offer_installer)
        except TypeError:  # not connected: initGui never ran (qgis_process)
            pass
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
        if self.translator is not None:
            QCoreApplication.removeTranslator(self.translator)
            self.translator = None
