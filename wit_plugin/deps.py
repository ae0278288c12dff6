"""Optional Python dependencies: which are missing, and how to install them into QGIS's Python.

QGIS ships numpy, GDAL, lxml and pyproj but not ``triangle`` nor (on many systems) shapely 2.
The plugin must load without them; the algorithms that need them call ``require`` first.
"""
from __future__ import annotations

import importlib

from .errors import MissingDependencyError

#: import name -> (pip requirement, minimum major version or None)
REQUIREMENTS: dict[str, tuple[str, int | None]] = {
    "shapely": ("shapely>=2", 2),
    "triangle": ("triangle", None),
    "lxml": ("lxml", None),
    "pyproj": ("pyproj", None),
}


def missing(modules: tuple[str, ...] | list[str]) -> list[str]:
    """The pip requirements among ``modules`` that are absent or too old."""
    result = []
    for name in modules:
        requirement, major = REQUIREMENTS.get(name, (name, None))
        try:
            module = importlib.import_module(name)
        except ImportError:
            result.append(requirement)
            continue
        if major is not None:
            version = getattr(module, "__version__", "0")
            if int(version.split(".")[0]) < major:
                result.append(requirement)
    return result


def install_hint(requirements: list[str]) -> str:
    """A message with the exact commands that install ``requirements`` for QGIS's Python."""
    quoted = " ".join(f'"{r}"' for r in requirements)
    return (
        f"Missing Python package(s): {', '.join(requirements)}. Install them for QGIS's Python, "
        "then restart QGIS.\n"
        f"  Linux (Debian/Ubuntu QGIS): /usr/bin/python3 -m pip install --user --break-system-packages {quoted}\n"
        f"  Windows (OSGeo4W / QGIS installer): open the 'OSGeo4W Shell' and run: python -m pip install {quoted}\n"
        f"  macOS (QGIS.app): /Applications/QGIS.app/Contents/MacOS/bin/python3 -m pip install --user {quoted}\n"
        "Note: 'triangle' is free for non-commercial use only (licence of J. R. Shewchuk's Triangle)."
    )


def require(modules: tuple[str, ...] | list[str]) -> None:
    """Raise ``MissingDependencyError`` with install instructions if any module is missing."""
    absent = missing(modules)
    if absent:
        raise MissingDependencyError(install_hint(absent))
