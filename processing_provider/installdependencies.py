"""wit:installdependencies — the missing Python packages, installed for QGIS's own Python into the user's
QGIS profile (wit_plugin.infra.installer)."""
from qgis.core import (
    Qgis,
    QgsApplication,
    QgsProcessingException,
    QgsProcessingOutputFolder,
    QgsProcessingOutputString,
    QgsProcessingParameterEnum,
    QgsProcessingParameterString,
)

from ..wit_plugin.infra import installer
from ..wit_plugin.infra.errors import CanceledError
from .base import WitAlgorithm
from .qgis_compat import AlgorithmFlag, ParameterFlag
from .translation import tr


def profile_packages_folder():
    """Where this QGIS profile keeps the plugin's packages (on ``sys.path`` from the plugin's load on)."""
    return installer.packages_folder(QgsApplication.qgisSettingsDirPath())


def package_label(package: installer.Package) -> str:
    label = f"{package.module} ({' / '.join(package.candidates)})"
    return f"{label} — {tr(package.licence)}" if package.licence else label


class InstallDependencies(WitAlgorithm):
    algorithm_id = "installdependencies"
    display_name = "Install Python dependencies"
    group_name = "Tools"
    help_text = (
        "Installs the Python packages the algorithms need and QGIS's Python lacks (shapely 2, pythoncdt, "
        "pygltflib, Dask…; triangle, free for non-commercial use only, when you tick it) into a folder of "
        "your QGIS profile (python/wit_citymodel_deps), which the plugin "
        "puts on Python's path when it loads: no administrator rights, nothing changed outside the profile. "
        "Packages that are present already are left alone. The log shows each pip command; Cancel stops pip "
        "and installs nothing. Where QGIS's Python has no pip (Debian's and Ubuntu's QGIS do not install it), "
        "pip runs from its own wheel, downloaded from the package index pip is configured for into a work "
        "folder of the profile and deleted afterwards.<br><br>"
        "On Linux, a shapely from PyPI carries its own GEOS and would crash QGIS: shapely is built from "
        "source against the system GEOS (that needs the GEOS development files, a C compiler and the Python "
        "headers), or, where the system offers shapely 2 (Debian testing/sid: python3-shapely), the message "
        "names the command that installs it. Restart QGIS when the log asks for it (a package that was "
        "already loaded in another version)."
    )

    PACKAGES = "PACKAGES"
    PYTHON = "PYTHON"
    FOLDER = "FOLDER"
    INSTALLED = "INSTALLED"

    def flags(self):
        return super().flags() | AlgorithmFlag.HideFromModeler

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterEnum(
            self.PACKAGES, self.tr("Packages to install when missing"),
            options=[package_label(p) for p in installer.PACKAGES], allowMultiple=True,
            defaultValue=[i for i, p in enumerate(installer.PACKAGES) if p.default]))
        python = QgsProcessingParameterString(
            self.PYTHON, self.tr("Python interpreter to run pip with (empty: QGIS's own)"), optional=True)
        python.setFlags(python.flags() | ParameterFlag.Advanced)
        self.addParameter(python)
        self.addOutput(QgsProcessingOutputFolder(self.FOLDER, self.tr("Package folder")))
        self.addOutput(QgsProcessingOutputString(self.INSTALLED, self.tr("Installed packages")))

    def execute(self, parameters, context, feedback):
        chosen = self.parameterAsEnums(parameters, self.PACKAGES, context)
        python = self.parameterAsString(parameters, self.PYTHON, context) or None
        folder = profile_packages_folder()
        try:
            result = installer.install([installer.PACKAGES[i] for i in chosen], folder, python=python,
                                       host_geos=Qgis.geosVersion(), feedback=feedback, tr=self.tr)
        except CanceledError as exc:
            raise QgsProcessingException(self.tr("Cancelled: pip was stopped and nothing was installed.")) from exc
        if result.restart:
            feedback.warning(self.tr("Restart QGIS to use the new {modules}: this session loaded an older "
                                     "version.").format(modules=", ".join(result.restart)))
        return {self.FOLDER: str(folder), self.INSTALLED: ", ".join(result.installed)}
