"""The plugin's one translation context, for every module of the glue (none of them needs ``base`` for it)."""
from __future__ import annotations

from qgis.PyQt.QtCore import QCoreApplication

CONTEXT = "WitCityModel"


def translatable(text: str) -> str:
    """Mark a literal for scripts/i18n.py that is translated later, through ``tr`` on a variable."""
    return text


def tr(text: str) -> str:
    """Translate in the plugin's single translation context."""
    return QCoreApplication.translate(CONTEXT, text)
