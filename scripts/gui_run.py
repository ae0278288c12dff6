"""QGIS start-up script (``qgis --code scripts/gui_run.py``): one algorithm run in the real QGIS window.

What a user does from the toolbox, headless under Xvfb for the tests: once the plugin's provider is
registered, runs WIT_GUI_ALG with the parameters of the JSON file WIT_GUI_PARAMS through
``processing.runAndLoadResults`` (the desktop's own process and GDAL settings, results loaded into the
project), then writes WIT_GUI_JSON — the results, the log, the project's layers (name, valid, provider,
feature count) — and quits QGIS. Any failure is written to the JSON ("error") and QGIS exits with 1;
a crash is the exit status itself.
"""
import json
import os
import traceback

from qgis.core import QgsApplication, QgsProcessingFeedback, QgsProject, QgsVectorLayer
from qgis.PyQt.QtCore import QTimer

_ENV = os.environ
_state = {"tries": 0}


def _write(info):
    with open(_ENV["WIT_GUI_JSON"], "w", encoding="utf-8") as handle:
        json.dump(info, handle, ensure_ascii=False, indent=2, default=str)


class _Log(QgsProcessingFeedback):
    def __init__(self):
        super().__init__()
        self.lines = []

    def pushInfo(self, info):  # noqa: N802 (QGIS's name)
        self.lines.append(info)

    def pushWarning(self, warning):  # noqa: N802
        self.lines.append(warning)

    def reportError(self, error, fatalError=False):  # noqa: N802, N803
        self.lines.append(error)


def _run():
    try:
        alg = QgsApplication.processingRegistry().algorithmById(_ENV["WIT_GUI_ALG"])
        if alg is None:
            _state["tries"] += 1
            if _state["tries"] > 80:
                raise RuntimeError(f"{_ENV['WIT_GUI_ALG']} is not registered")
            QTimer.singleShot(250, _run)
            return
        import processing

        with open(_ENV["WIT_GUI_PARAMS"], encoding="utf-8") as handle:
            parameters = json.load(handle)
        log = _Log()
        results = processing.runAndLoadResults(alg.id(), parameters, feedback=log)
        layers = [{"name": layer.name(), "valid": layer.isValid(), "provider": layer.providerType(),
                   "features": layer.featureCount() if isinstance(layer, QgsVectorLayer) else None}
                  for layer in QgsProject.instance().mapLayers().values()]
        _write({"results": results, "log": log.lines, "layers": layers})
        # QGIS 3.44 (Debian sid) dies on signal 11 when it quits from a start-up script with a layer in
        # the project, with or without this plugin (native:creategrid too): quit with an empty project
        QgsProject.instance().clear()
        QTimer.singleShot(0, lambda: QgsApplication.exit(0))
    except Exception:  # noqa: BLE001 (report everything, then quit)
        _write({"error": traceback.format_exc()})
        QTimer.singleShot(0, lambda: QgsApplication.exit(1))


QTimer.singleShot(500, _run)
