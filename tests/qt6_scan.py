"""A small scanner for what QGIS 4 (Qt 6, PyQt6) removed, after the rules of QGIS's own
``scripts/pyqt5_to_pyqt6/pyqt5_to_pyqt6.py`` that matter for this plugin.

No QGIS 4 build installs here, so the plugin's Python is read, not run, under Qt 6. Each rule is one
class of problem:

* ``pyqt5-import``: ``PyQt5`` (or bare ``sip``) imported instead of ``qgis.PyQt``;
* ``exec_``: ``exec_()`` called or defined (PyQt6 has only ``exec()``);
* ``qvariant-type``: ``QVariant.Int``, ``QVariant.Type``… or ``QVariant()``: PyQt6's QVariant has no
  type enum (use ``QMetaType.Type``), and no null constructor (use ``NULL``);
* ``unscoped-enum``: an enum member reached through its class (``Qt.AlignLeft``,
  ``QgsFeatureSink.FastInsert``): PyQt6 knows only the scoped spelling (``Qt.AlignmentFlag.AlignLeft``).
  Found by introspection of the running (Qt 5) QGIS, as the reference script introspects PyQt6;
* ``moved-enum``: an enum that QGIS 3.30–3.40 moved into the ``Qgis`` namespace, under its old
  class (``QgsProcessing.SourceType``): the old names are gone in QGIS 4;
* ``removed-api``: Qt 5 API that Qt 6 removed (``QRegExp``, ``qApp``, ``QDesktopWidget``,
  ``fontMetrics().width`` and ``QFontMetrics(…).width``, also through a variable, ``activated[str]``, compiled
  resources, ``qgis.PyQt.Qt``, renamed enums);
* ``changed-api``: calls Qt 6 reads otherwise: ``addAction`` with four arguments or more, the eight-number
  ``QDateTime(…)`` and ``QDateTime(QDate(…))`` (the tool rewrites both, to ``QDateTime(QDate, QTime, …)``).

``make qt6-check`` runs QGIS's script itself on what the ZIP ships (scripts/qt6_check.py); this scan is the
part of it that runs without PyQt6, in ``make test``, and adds the QGIS enums it cannot see without QGIS 4.
"""
from __future__ import annotations

import ast
import enum
import importlib
from dataclasses import dataclass
from pathlib import Path

#: class enums that QGIS moved into ``Qgis`` (3.30–3.40): QGIS 4 has only the new ones
MOVED_ENUMS = {
    ("QgsProcessing", "SourceType"): "Qgis.ProcessingSourceType",
    ("QgsProcessingParameterNumber", "Type"): "Qgis.ProcessingNumberParameterType",
    ("QgsProcessingParameterFile", "Behavior"): "Qgis.ProcessingFileParameterBehavior",
    ("QgsProcessingParameterField", "DataType"): "Qgis.ProcessingFieldParameterDataType",
    ("QgsProcessingParameterDefinition", "Flag"): "Qgis.ProcessingParameterFlag",
    ("QgsProcessingAlgorithm", "Flag"): "Qgis.ProcessingAlgorithmFlag",
    ("QgsProcessingFeatureSource", "Flag"): "Qgis.ProcessingFeatureSourceFlag",
    ("QgsProcessingParameterDateTime", "Type"): "Qgis.ProcessingDateTimeParameterDataType",
    ("QgsWkbTypes", "Type"): "Qgis.WkbType",
    ("QgsWkbTypes", "GeometryType"): "Qgis.GeometryType",
    ("QgsUnitTypes", "DistanceUnit"): "Qgis.DistanceUnit",
    ("QgsUnitTypes", "AreaUnit"): "Qgis.AreaUnit",
    ("QgsMapLayer", "LayerType"): "Qgis.LayerType",
    ("QgsFeatureRequest", "Flag"): "Qgis.FeatureRequestFlag",
    ("QgsFields", "FieldOrigin"): "Qgis.FieldOrigin",
}
#: Qt 5 names that Qt 6 removed, and what to use
REMOVED_NAMES = {
    "QRegExp": "QRegularExpression",
    "QDesktopWidget": "QScreen (QApplication.screens())",
    "qApp": "QApplication.instance()",
    "resources_rc": "icons by file path",
}
RENAMED_ENUMS = {
    ("Qt", "MidButton"): "Qt.MouseButton.MiddleButton",
    ("Qt", "TextColorRole"): "Qt.ItemDataRole.ForegroundRole",
    ("Qt", "BackgroundColorRole"): "Qt.ItemDataRole.BackgroundRole",
    ("QPainter", "HighQualityAntialiasing"): "QPainter.RenderHint.Antialiasing",
}
FONT_METRICS = ("QFontMetrics", "QFontMetricsF")
#: modules whose names are introspected for enums
INTROSPECTED = ("qgis.", "PyQt5.")


@dataclass(frozen=True)
class Finding:
    path: str
    line: int
    rule: str
    message: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: [{self.rule}] {self.message}"


def _is_enum_member(value) -> bool:
    """A member of a sip (PyQt5) or Python enum, as opposed to an enum type, class, method or constant."""
    if isinstance(value, type):
        return False
    return isinstance(value, enum.Enum) or type(type(value)).__name__ == "enumtype"


def _imported_names(tree: ast.AST) -> dict[str, tuple[str, str]]:
    """Local name → (module, imported name), for every ``from … import`` of the file (any scope)."""
    names = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                names[alias.asname or alias.name] = (node.module, alias.name)
    return names


def _resolve(module: str, name: str):
    if not module.startswith(INTROSPECTED):
        return None
    try:
        return getattr(importlib.import_module(module), name, None)
    except ImportError:
        return None


def scan_source(source: str, path: str = "<source>") -> list[Finding]:
    """Every Qt 6 / QGIS 4 problem of one Python source."""
    tree = ast.parse(source, filename=path)
    imported = _imported_names(tree)
    metrics = {target.id for node in ast.walk(tree) if isinstance(node, ast.Assign) and _calls(node.value, FONT_METRICS)
               for target in node.targets if isinstance(target, ast.Name)}  # fm = QFontMetrics(font)
    findings = []

    def report(node: ast.AST, rule: str, message: str) -> None:
        findings.append(Finding(path, node.lineno, rule, message))

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            _check_import(node, report)
        elif isinstance(node, ast.ImportFrom) and node.module:
            _check_import_from(node, node.module, report)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name == "exec_":
            report(node, "exec_", "def exec_(): PyQt6 calls exec()")
        elif isinstance(node, ast.Call):
            _check_call(node, report)
        elif isinstance(node, ast.Subscript):
            value = node.value
            if (isinstance(value, ast.Attribute) and value.attr == "activated"
                    and isinstance(node.slice, ast.Name) and node.slice.id == "str"):
                report(node, "removed-api", "activated[str] is gone in Qt 6: use textActivated")
        elif isinstance(node, ast.Attribute):
            _check_attribute(node, imported, report, metrics)
    return sorted(findings, key=lambda f: (f.line, f.rule))


def _check_import(node: ast.Import, report) -> None:
    for alias in node.names:
        if alias.name.split(".")[0] == "PyQt5":
            report(node, "pyqt5-import", f"import {alias.name}: import from qgis.PyQt")
        elif alias.name == "sip":
            report(node, "pyqt5-import", "import sip: use 'from qgis.PyQt import sip'")


def _check_import_from(node: ast.ImportFrom, module: str, report) -> None:
    if module.split(".")[0] == "PyQt5":
        report(node, "pyqt5-import", f"from {module} import …: import from qgis.PyQt")
    if module == "qgis.PyQt.Qt":
        report(node, "removed-api", "qgis.PyQt.Qt is gone: import Qt from qgis.PyQt.QtCore")
    for alias in node.names:
        if alias.name in REMOVED_NAMES:
            report(node, "removed-api", f"{alias.name} is gone in Qt 6: use {REMOVED_NAMES[alias.name]}")


def _check_call(node: ast.Call, report) -> None:
    func = node.func
    if isinstance(func, ast.Attribute) and func.attr == "exec_":
        report(node, "exec_", "exec_() is gone in PyQt6: call exec()")
    elif isinstance(func, ast.Attribute) and func.attr == "addAction" and len(node.args) >= 4:
        report(node, "changed-api", "addAction(…) with 4+ arguments is fragile in Qt 6: "
                                    "create the QAction, then addAction(action)")
    elif _calls(node, ("QDateTime",)) and (len(node.args) == 8 or (len(node.args) == 1 and _calls(
            node.args[0], ("QDate",)))):
        report(node, "changed-api", "this QDateTime(…) form is gone in Qt 6: QDateTime(QDate(…), QTime(…))")
    elif isinstance(func, ast.Attribute) and func.attr == "desktop" and not node.args:
        report(node, "removed-api", "desktop() (QDesktopWidget) is gone in Qt 6: use QScreen")
    elif isinstance(func, ast.Name) and func.id == "QVariant" and not node.args:
        report(node, "qvariant-type", "QVariant() is gone in PyQt6: use NULL from qgis.core")


def _calls(node: ast.AST, names: tuple[str, ...]) -> bool:
    """``node`` is a call of one of ``names`` (a plain name)."""
    return isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in names


def _check_attribute(node: ast.Attribute, imported: dict, report, metrics: set[str]) -> None:
    value = node.value
    if node.attr == "width" and ((isinstance(value, ast.Call) and isinstance(value.func, ast.Attribute)
                                  and value.func.attr == "fontMetrics") or _calls(value, FONT_METRICS)
                                 or (isinstance(value, ast.Name) and value.id in metrics)):
        report(node, "removed-api", "QFontMetrics.width() is gone in Qt 6: use horizontalAdvance()")
        return
    if not isinstance(value, ast.Name):
        return
    owner, attr = value.id, node.attr
    if owner == "qApp":
        report(node, "removed-api", "qApp is gone in Qt 6: use QApplication.instance()")
    elif owner == "QVariant" and attr[:1].isupper():
        report(node, "qvariant-type", f"QVariant.{attr}: PyQt6's QVariant has no type enum (QMetaType.Type)")
    elif (owner, attr) in RENAMED_ENUMS:
        report(node, "removed-api", f"{owner}.{attr} is gone in Qt 6: use {RENAMED_ENUMS[owner, attr]}")
    elif (owner, attr) in MOVED_ENUMS:
        report(node, "moved-enum", f"{owner}.{attr} is gone in QGIS 4: use {MOVED_ENUMS[owner, attr]}")
    elif owner in imported:
        cls = _resolve(*imported[owner])
        member = getattr(cls, attr, None) if isinstance(cls, type) else None
        if member is not None and _is_enum_member(member):
            enum_name = type(member).__name__
            moved = MOVED_ENUMS.get((owner, enum_name))
            scoped = f"{moved} (processing_provider/qgis_compat.py)" if moved else f"{owner}.{enum_name}.{attr}"
            report(node, "unscoped-enum", f"{owner}.{attr}: PyQt6 knows only the scoped spelling: {scoped}")


def plugin_sources(root: Path) -> list[Path]:
    """The Python files the plugin ships (those ``scripts/package.sh`` puts in the ZIP)."""
    files = [root / "__init__.py", root / "plugin.py"]
    for folder in ("processing_provider", "wit_plugin"):
        files += sorted((root / folder).rglob("*.py"))
    return [f for f in files if "__pycache__" not in f.parts]


def scan_plugin(root: Path) -> list[Finding]:
    findings = []
    for path in plugin_sources(root):
        findings += scan_source(path.read_text(encoding="utf-8"), str(path.relative_to(root)))
    return findings
