"""QGIS enums spelled so that QGIS 3.22 to 3.44 and QGIS 4 (Qt 6) all accept them.

QGIS 3.30 and 3.36 moved many class enums into the ``Qgis`` namespace (``QgsProcessing.TypeVectorPolygon``
became ``Qgis.ProcessingSourceType.VectorPolygon``) and kept the old names as deprecated aliases; QGIS 4
drops the aliases, and QGIS 3.22 knows only the old names. Each enum here answers with the new member where
this QGIS has it, else with the old one under its scoped spelling (``QgsProcessing.SourceType.TypeVectorPolygon``,
which QGIS 3's PyQt5 accepts). Old names are looked up by name, and only on a QGIS that has them, so no
line of the plugin spells a name that QGIS 4 removed (``tests/test_qt6_ready.py`` checks that).
"""
from __future__ import annotations

import enum

import qgis.core
from qgis.core import Qgis
from qgis.PyQt import QtCore


def _lookup(path: str):
    """The object at a dotted path below ``qgis.core`` or ``QtCore`` ("QgsProcessing.SourceType")."""
    root, *parts = path.split(".")
    value = getattr(qgis.core, root, None) or getattr(QtCore, root)
    for part in parts:
        value = getattr(value, part)
    return value


def _exists(path: str) -> bool:
    try:
        _lookup(path)
    except AttributeError:
        return False
    return True


class _Enum:
    """Members by their new name: ``new.<name>`` where QGIS has ``new`` (from version ``since``, when
    given), else ``old.<old_name(name)>``."""

    def __init__(self, new: str, old: str, old_name=lambda name: name, since: int | None = None):
        present = _exists(new) if since is None else Qgis.QGIS_VERSION_INT >= since
        self._path, self._old_name = (new, None) if present else (old, old_name)

    def __getattr__(self, name: str):
        if name.startswith("_"):
            raise AttributeError(name)
        owner = _lookup(self._path)
        return getattr(owner, self._old_name(name) if self._old_name else name)


#: layer types of Processing parameters (Qgis.ProcessingSourceType from QGIS 3.36)
SourceType = _Enum("Qgis.ProcessingSourceType", "QgsProcessing.SourceType", lambda name: f"Type{name}")
#: QgsProcessingParameterNumber's type (Integer, Double)
NumberType = _Enum("Qgis.ProcessingNumberParameterType", "QgsProcessingParameterNumber.Type")
#: QgsProcessingParameterFile's behaviour (File, Folder)
FileBehavior = _Enum("Qgis.ProcessingFileParameterBehavior", "QgsProcessingParameterFile.Behavior")
#: QgsProcessingParameterField's data type (Any, Numeric, String…)
FieldDataType = _Enum("Qgis.ProcessingFieldParameterDataType", "QgsProcessingParameterField.DataType")
#: parameter flags (Advanced…)
ParameterFlag = _Enum("Qgis.ProcessingParameterFlag", "QgsProcessingParameterDefinition.Flag",
                      lambda name: f"Flag{name}")
#: algorithm flags (NoThreading…)
AlgorithmFlag = _Enum("Qgis.ProcessingAlgorithmFlag", "QgsProcessingAlgorithm.Flag", lambda name: f"Flag{name}")
#: geometry types (Point, Line, Polygon, Unknown, Null; Qgis.GeometryType from QGIS 3.30)
GeometryType = _Enum("Qgis.GeometryType", "QgsWkbTypes.GeometryType", lambda name: f"{name}Geometry")
#: WKB types (Point, Polygon, NoGeometry…; Qgis.WkbType from QGIS 3.30)
WkbType = _Enum("Qgis.WkbType", "QgsWkbTypes.Type")
#: QgsField's type by its QMetaType name (Int, Double, QString): QGIS 4 has no QVariant types, and
#: QgsField takes QMetaType from QGIS 3.38 on
FieldType = _Enum("QMetaType.Type", "QVariant", lambda name: {"QString": "String"}.get(name, name), since=33800)


def code(member) -> int:
    """An enum member's integer value, whether QGIS gives a Python enum or a sip one (``dataTypes()``
    answers plain integers on every version)."""
    return member.value if isinstance(member, enum.Enum) else int(member)
