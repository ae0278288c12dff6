"""The plugin's version, from its one source: metadata.txt's ``version=`` (what QGIS's plugin manager shows).

The core installed alone (``pip install .`` on Dask workers, no metadata.txt beside it) reads the same number
from its package metadata, which pyproject.toml takes from metadata.txt (a test checks it).
"""
from __future__ import annotations

import configparser
from importlib import metadata
from pathlib import Path

PLUGIN_DIR = Path(__file__).resolve().parents[2]
CORE_DISTRIBUTION = "wit-citymodel-core"


def plugin_version() -> str:
    """``version=`` of metadata.txt in the plugin folder, else the installed core's version."""
    card = configparser.ConfigParser(interpolation=None)
    if card.read(PLUGIN_DIR / "metadata.txt", encoding="utf-8"):
        return card["general"]["version"]
    return metadata.version(CORE_DISTRIBUTION)
