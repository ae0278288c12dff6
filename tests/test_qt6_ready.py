"""QGIS 4 (Qt 6) readiness: the metadata admits QGIS 4, and the plugin's Python has none of what Qt 6 /
QGIS 4 removed (tests/qt6_scan.py, after QGIS's scripts/pyqt5_to_pyqt6 rules). No QGIS 4 build installs
here, so the scanner is tested on a tiny bad snippet per class of problem."""
from __future__ import annotations

import configparser

import pytest
from conftest import ROOT
from qt6_scan import plugin_sources, scan_plugin, scan_source

pytestmark = pytest.mark.qgis_facing

BAD_SNIPPETS = {
    "pyqt5-import": [
        "from PyQt5.QtCore import QTimer\n",
        "import PyQt5.QtWidgets\n",
        "import sip\n",
    ],
    "exec_": [
        "from qgis.PyQt.QtWidgets import QDialog\nQDialog().exec_()\n",
        "class Dialog:\n    def exec_(self): pass\n",
    ],
    "qvariant-type": [
        "from qgis.PyQt.QtCore import QVariant\nkind = QVariant.Int\n",
        "from qgis.PyQt.QtCore import QVariant\nnull = QVariant()\n",
    ],
    "unscoped-enum": [
        "from qgis.PyQt.QtCore import Qt\nalign = Qt.AlignLeft\n",
        "from qgis.core import QgsFeatureSink\nflag = QgsFeatureSink.FastInsert\n",
        "from qgis.core import QgsProcessing\nkind = QgsProcessing.TypeVectorPolygon\n",
        "from qgis.core import Qgis\nlevel = Qgis.Warning\n",
        "def later():\n    from qgis.PyQt.QtWidgets import QMessageBox\n    return QMessageBox.Yes\n",
    ],
    "moved-enum": [
        "from qgis.core import QgsProcessing\nkind = QgsProcessing.SourceType.TypeVectorPolygon\n",
        "from qgis.core import QgsProcessingParameterNumber\nkind = QgsProcessingParameterNumber.Type.Double\n",
        "from qgis.core import QgsWkbTypes\nkind = QgsWkbTypes.GeometryType.PolygonGeometry\n",
    ],
    "removed-api": [
        "from qgis.PyQt.QtCore import QRegExp\n",
        "from qgis.PyQt.QtWidgets import qApp\n",
        "from qgis.PyQt.Qt import Qt\n",
        "from qgis.PyQt.QtCore import Qt\nbutton = Qt.MidButton\n",
        "width = widget.fontMetrics().width('text')\n",
        "from qgis.PyQt.QtGui import QFontMetrics\nwidth = QFontMetrics(font).width('text')\n",
        "from qgis.PyQt.QtGui import QFontMetricsF\nmetrics = QFontMetricsF(font)\nwidth = metrics.width('text')\n",
        "from qgis.PyQt.QtGui import QPainter\nhint = QPainter.HighQualityAntialiasing\n",
        "combo.activated[str].connect(print)\n",
        "screen = app.desktop()\n",
    ],
    "changed-api": [
        "menu.addAction(icon, 'Run', receiver, shortcut)\n",
        "from qgis.PyQt.QtCore import QDateTime\nwhen = QDateTime(2024, 5, 1, 12, 0, 0, 0, 0)\n",
        "from qgis.PyQt.QtCore import QDate, QDateTime\nwhen = QDateTime(QDate(2024, 5, 1))\n",
    ],
}


@pytest.mark.parametrize("rule, snippet", [(rule, s) for rule, snippets in BAD_SNIPPETS.items() for s in snippets])
def test_scanner_catches_each_class_of_problem(rule, snippet):
    findings = scan_source(snippet, "bad.py")
    assert [f.rule for f in findings] == [rule], findings
    assert findings[0].line == len(snippet.splitlines())  # the offending line, the last of each snippet


def test_scanner_accepts_the_spellings_qt6_and_qgis3_share():
    good = (
        "from qgis.core import Qgis, QgsFeatureSink, QgsVectorFileWriter, QgsAbstract3DSymbol\n"
        "from qgis.PyQt.QtCore import Qt, QMetaType\n"
        "from qgis.PyQt.QtWidgets import QDialog, QMessageBox\n"
        "from qgis.PyQt import sip\n"
        "align = Qt.AlignmentFlag.AlignLeft\n"
        "flag = QgsFeatureSink.Flag.FastInsert\n"
        "error = QgsVectorFileWriter.WriterError.NoError\n"
        "height = QgsAbstract3DSymbol.Property.PropertyExtrusionHeight\n"
        "level = Qgis.MessageLevel.Warning\n"
        "version = Qgis.QGIS_VERSION_INT\n"
        "kind = QMetaType.Type.Double\n"
        "answer = QMessageBox.StandardButton.Yes\n"
        "QDialog().exec()\n"
        "spec.loader.exec_module(module)\n"
        "menu.addAction(action)\n"
        "width = QFontMetrics(font).horizontalAdvance('text')\n"
        "when = QDateTime(QDate(2024, 5, 1), QTime(12, 0, 0))\n"
    )
    assert scan_source(good, "good.py") == []


def test_the_plugin_has_nothing_qt6_or_qgis4_removed():
    sources = plugin_sources(ROOT)
    assert ROOT / "plugin.py" in sources and ROOT / "processing_provider" / "base.py" in sources
    findings = scan_plugin(ROOT)
    assert not findings, "\n".join(map(str, findings))


def test_metadata_admits_qgis_3_22_to_4():
    metadata = configparser.ConfigParser()
    metadata.read(ROOT / "metadata.txt", encoding="utf-8")
    general = metadata["general"]
    assert general["qgisMinimumVersion"] == "3.22"
    assert general["qgisMaximumVersion"] == "4.99"
    assert "supportsQt6" not in general  # plugins.qgis.org reports it as deprecated


def test_compat_enums_are_the_ones_this_qgis_takes():
    """Each compatibility name is the Qgis enum where this QGIS has it, else the old scoped one, and the
    parameters built with them behave (a Double number, a Folder file, a polygon source)."""
    from qgis.core import (
        Qgis,
        QgsProcessingParameterFeatureSource,
        QgsProcessingParameterFile,
        QgsProcessingParameterNumber,
    )
    from wit_citymodel.processing_provider.qgis_compat import (
        FileBehavior,
        NumberType,
        ParameterFlag,
        SourceType,
        code,
    )

    if hasattr(Qgis, "ProcessingSourceType"):
        assert SourceType.VectorPolygon is Qgis.ProcessingSourceType.VectorPolygon
    else:
        from qgis.core import QgsProcessing

        assert SourceType.VectorPolygon == QgsProcessing.SourceType.TypeVectorPolygon
    number = QgsProcessingParameterNumber("N", "n", NumberType.Double)
    assert code(number.dataType()) == code(NumberType.Double) != code(NumberType.Integer)
    folder = QgsProcessingParameterFile("F", "f", behavior=FileBehavior.Folder)
    assert code(folder.behavior()) == code(FileBehavior.Folder)
    source = QgsProcessingParameterFeatureSource("S", "s", [SourceType.VectorPolygon])
    assert [code(t) for t in source.dataTypes()] == [code(SourceType.VectorPolygon)]
    number.setFlags(number.flags() | ParameterFlag.Advanced)
    assert code(number.flags()) & code(ParameterFlag.Advanced)
