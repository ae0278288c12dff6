"""Shared behaviour of every ``wit`` algorithm: translation, help, dependency check, errors.

Subclasses declare parameters and implement ``execute`` (``run`` is QGIS API); ``processAlgorithm``
turns core exceptions into ``QgsProcessingException`` so the user sees a message, never a traceback.
Before ``execute``, every algorithm checks its inputs and outputs (``safeguards``): vector and
raster files named with their real problem, geometry types as the parameters ask, and no output that would
replace or share a file with an input; while it runs, atomic writes refuse to replace an input.
"""
from __future__ import annotations

from pathlib import Path

from qgis.core import (
    Qgis,
    QgsCoordinateReferenceSystem,
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingFeedback,
    QgsProcessingParameterBoolean,
    QgsVectorFileWriter,
)
from qgis.PyQt.QtGui import QIcon

from ..wit_plugin.infra import deps
from ..wit_plugin.infra.errors import CanceledError, WitError
from ..wit_plugin.infra.feedback import Feedback
from ..wit_plugin.infra.gdal_env import no_sidecars
from ..wit_plugin.infra.io import fileio
from ..wit_plugin.infra.io.layersource import LayerSource
from . import safeguards
from .dependency_notice import NOTICE
from .help_links import help_url
from .qgis_compat import ParameterFlag
from .translation import tr

PLUGIN_DIR = Path(__file__).resolve().parents[1]


def crs_string(crs: QgsCoordinateReferenceSystem) -> str:
    """A CRS as the core takes it: the authority id when there is one, else WKT."""
    return crs.authid() or crs.toWkt()


class QgisFeedback(Feedback):
    """Core ``Feedback`` that reports to a ``QgsProcessingFeedback``."""

    def __init__(self, feedback: QgsProcessingFeedback | None):
        self._feedback = feedback or QgsProcessingFeedback()

    @property
    def processing_feedback(self) -> QgsProcessingFeedback:
        """The wrapped QGIS feedback, for running child algorithms."""
        return self._feedback

    def progress(self, percent: float) -> None:
        self._feedback.setProgress(percent)

    def is_canceled(self) -> bool:
        return self._feedback.isCanceled()

    def info(self, message: str) -> None:
        self._feedback.pushInfo(message)

    def warning(self, message: str) -> None:
        self._feedback.pushWarning(message)


class WitAlgorithm(QgsProcessingAlgorithm):
    """Base class: subclasses set the class attributes and implement ``initAlgorithm``/``execute``."""

    #: algorithm id without the provider prefix
    algorithm_id = ""
    #: untranslated display name, group and help text (translated through ``tr``)
    display_name = ""
    group_name = ""
    help_text = ""
    #: import names of the optional packages the core step needs (see wit_plugin.infra.deps)
    requirements: tuple[str, ...] = ()
    #: string parameters that name an input file (checked against the outputs like layer inputs)
    path_parameters: tuple[str, ...] = ()

    def tr(self, text: str) -> str:
        return tr(text)

    def createInstance(self):  # noqa: N802
        return type(self)()

    def name(self) -> str:
        return self.algorithm_id

    def displayName(self) -> str:  # noqa: N802
        return self.tr(self.display_name)

    def group(self) -> str:
        return self.tr(self.group_name)

    def groupId(self) -> str:  # noqa: N802
        return self.group_name.lower().replace(" ", "")

    def icon(self) -> QIcon:
        return QIcon(str(PLUGIN_DIR / "icon.svg"))

    def helpUrl(self) -> str:  # noqa: N802
        return help_url(self.algorithm_id)

    def shortHelpString(self) -> str:  # noqa: N802
        text = self.tr(self.help_text)
        absent = deps.missing(self.requirements)
        if absent:
            text = self.missing_message(absent).replace("\n", "<br>") + "<br><br>" + text
        return text

    def missing_message(self, absent: list[str]) -> str:
        """What to do about missing packages: the installing algorithm first, the shell commands after."""
        return (self.tr("Missing Python packages: {packages}. Run 'Install Python dependencies' "
                        "(wit:installdependencies, group Tools) to install them into your QGIS profile.")
                .format(packages=", ".join(absent)) + "\n" + deps.install_hint(absent))

    def checkParameterValues(self, parameters, context):  # noqa: N802
        """A vector or raster file's real problem before QGIS's generic "Incorrect parameter value";
        QGIS loads the layers here, without writing .aux.xml beside them (``no_sidecars``)."""
        with no_sidecars():
            problem = safeguards.file_problem(self, parameters, context)
            return (False, problem) if problem else super().checkParameterValues(parameters, context)

    def vector_source(self, parameters, name: str, context, feedback=None) -> str | None:
        """The core's source for a vector-layer parameter: ``file`` or ``file|layername=…`` of whatever layer
        the user gave — a file of any name, a layer of a GeoPackage, a layer of the project. Layers the
        core cannot open as they are (memory or database layers, filtered or /vsi layers, formats GDAL
        cannot write) are copied to a GeoPackage by Processing first; None when the parameter is empty."""
        layer = self.parameterAsVectorLayer(parameters, name, context)
        if layer is None:
            return None
        path, layer_name = self.parameterAsCompatibleSourceLayerPathAndLayerName(
            parameters, name, context, QgsVectorFileWriter.supportedFormatExtensions(), "gpkg",
            getattr(feedback, "processing_feedback", feedback))
        if not path:
            return None
        if Path(path) == fileio.source_file(layer.source()):
            return layer.source()  # the layer's own file: its |layername= or |layerid= as QGIS opened it
        return str(LayerSource(path, layer_name or None))

    def extra_outputs(self, parameters, context) -> list:
        """Files or folders written beside the destination parameters' (``safeguards.Endpoint``s)."""
        return []

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        try:
            absent = deps.missing(self.requirements)
            if absent:
                NOTICE.missing.emit(absent)  # the GUI offers the installer (plugin.py)
                raise QgsProcessingException(self.missing_message(absent))
            self._check_geos()
            with no_sidecars():  # layers QGIS loads for the parameters write no .aux.xml beside the inputs
                problem = (safeguards.file_problem(self, parameters, context)
                           or safeguards.geometry_problem(self, parameters, context)
                           or safeguards.overlap_problem(self, parameters, context))
                if problem:
                    raise QgsProcessingException(problem)
                read = [source.path for source in safeguards.inputs(self, parameters, context)]
                with fileio.protect(read):
                    return self.execute(parameters, context, QgisFeedback(feedback))
        except CanceledError as exc:
            raise QgsProcessingException(self.tr("Cancelled: no output was written.")) from exc
        except WitError as exc:
            raise QgsProcessingException(str(exc)) from exc

    def _check_geos(self) -> None:
        """Refuse, rather than crash QGIS, when shapely carries a GEOS other than QGIS's."""
        problem = "shapely" in self.requirements and deps.geos_mismatch(Qgis.geosVersion())
        if problem:
            NOTICE.missing.emit(["shapely>=2"])
            raise QgsProcessingException(
                self.tr("Run 'Install Python dependencies' (wit:installdependencies, group Tools) to install a "
                        "shapely that uses QGIS's GEOS into your QGIS profile, then restart QGIS.")
                + "\n" + deps.install_hint(["shapely>=2"], problem))

    def execute(self, parameters, context, feedback: QgisFeedback) -> dict:
        """Convert the parameters, call the core, return the outputs."""
        raise NotImplementedError

    SPATIAL_INDEX = "SPATIAL_INDEX"

    def add_spatial_index_parameter(self) -> None:
        """Advanced: big GeoPackage layers write twice as fast without an R-tree (the chain's
        intermediate files need none); on by default for layers a user opens."""
        param = QgsProcessingParameterBoolean(
            self.SPATIAL_INDEX, self.tr("Build a spatial index (slower to write, faster to display)"),
            defaultValue=True)
        param.setFlags(param.flags() | ParameterFlag.Advanced)
        self.addParameter(param)
