"""QGIS start-up script (``qgis --code scripts/screenshot_dialog.py``): screenshots of a wit dialog.

Run by scripts/screenshot.sh in the real QGIS window under Xvfb. Once QGIS is up it opens the
Processing dialog of the first algorithm of WIT_SHOT_ALGS that exists (non-modal, so the event loop
keeps running), waits for it to settle, then writes
  WIT_SHOT_DIALOG   the dialog alone (Qt grab), PNG
  WIT_SHOT_WINDOW   QGIS's main window with the dialog on top (Qt grabs), PNG (optional)
  WIT_SHOT_SCREEN   the whole X screen (xwd, proof the real window ran), .xwd (optional)
  WIT_SHOT_JSON     what the dialog shows: title, algorithm name, parameter labels, locale
and quits QGIS. Any failure is written to the JSON ("error") and QGIS exits with status 1.
"""
import json
import os
import subprocess
import traceback

from qgis.core import Qgis, QgsApplication
from qgis.PyQt.QtCore import QSettings, QTimer
from qgis.PyQt.QtGui import QPainter
from qgis.PyQt.QtWidgets import QLabel
from qgis.utils import iface

_ENV = os.environ
_ALGS = [a for a in _ENV.get("WIT_SHOT_ALGS", "wit:citymodel,wit:preparevectors").split(",") if a]
_DELAY_MS = int(_ENV.get("WIT_SHOT_DELAY_MS", "2500"))
_SIZE = _ENV.get("WIT_SHOT_SIZE", "1000x720")
_state = {"dialog": None, "tries": 0}


def _write_json(info):
    path = _ENV.get("WIT_SHOT_JSON")
    if path:
        with open(path, "w", encoding="utf-8") as handle:
            json.dump(info, handle, ensure_ascii=False, indent=2)


def _fail(exc_text):
    print("screenshot_dialog: " + exc_text, flush=True)
    _write_json({"error": exc_text})
    QTimer.singleShot(0, lambda: QgsApplication.exit(1))


def _open_dialog():
    """Open the dialog once the plugin's provider is registered (retrying for a while)."""
    try:
        registry = QgsApplication.processingRegistry()
        alg = next((registry.algorithmById(a) for a in _ALGS if registry.algorithmById(a)), None)
        if alg is None:
            _state["tries"] += 1
            if _state["tries"] > 40:
                _fail(f"none of {_ALGS} is registered; providers: {[p.id() for p in registry.providers()]}")
            else:
                QTimer.singleShot(250, _open_dialog)
            return
        from processing.gui.AlgorithmDialog import AlgorithmDialog

        main = iface.mainWindow()
        # fill the screen (without a window manager showMaximized() does nothing)
        main.setGeometry(QgsApplication.primaryScreen().availableGeometry())
        main.show()
        dialog = alg.createCustomParametersWidget(main) or AlgorithmDialog(alg.create(), parent=main)
        width, height = (int(v) for v in _SIZE.split("x"))
        dialog.resize(width, height)
        geo = main.geometry()  # centred on the main window (no window manager does it)
        dialog.move(geo.x() + (geo.width() - width) // 2, geo.y() + (geo.height() - height) // 2)
        dialog.show()
        dialog.raise_()
        dialog.activateWindow()
        _state["dialog"] = dialog
        _state["alg"] = alg
        QTimer.singleShot(_DELAY_MS, _capture)
    except Exception:  # noqa: BLE001 (report everything, then quit)
        _fail(traceback.format_exc())


def _capture():
    try:
        dialog, alg = _state["dialog"], _state["alg"]
        main = iface.mainWindow()
        main.repaint()
        dialog.repaint()
        QgsApplication.processEvents()
        info = {
            "algorithm": alg.id(),
            "display_name": alg.displayName(),
            "window_title": dialog.windowTitle(),
            "parameters": [p.description() for p in alg.parameterDefinitions()],
            "labels": sorted({w.text() for w in dialog.findChildren(QLabel)
                              if w.isVisible() and w.text().strip()}),
            "locale_override": QSettings().value("locale/overrideFlag", False, type=bool),
            "user_locale": QSettings().value("locale/userLocale", "", type=str),
            "qgis_version": Qgis.version(),
        }
        out = _ENV.get("WIT_SHOT_DIALOG")
        if out:
            info["dialog_png"] = out if dialog.grab().save(out) else None
        out = _ENV.get("WIT_SHOT_WINDOW")
        if out:
            picture = main.grab()
            painter = QPainter(picture)
            painter.drawPixmap(dialog.frameGeometry().topLeft() - main.frameGeometry().topLeft(),
                               dialog.grab())
            painter.end()
            info["window_png"] = out if picture.save(out) else None
        out = _ENV.get("WIT_SHOT_SCREEN")
        if out:
            done = subprocess.run(["xwd", "-root", "-silent", "-display", _ENV.get("DISPLAY", ""),
                                   "-out", out], check=False, timeout=30)
            info["screen_xwd"] = out if done.returncode == 0 else None
        _write_json(info)
        print("screenshot_dialog: " + json.dumps(info, ensure_ascii=False), flush=True)
        dialog.close()
        QTimer.singleShot(200, lambda: QgsApplication.exit(0))
    except Exception:  # noqa: BLE001
        _fail(traceback.format_exc())


QTimer.singleShot(500, _open_dialog)
