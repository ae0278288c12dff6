"""Optional Python dependencies: which are missing, and how to install them into QGIS's Python.

QGIS ships numpy, GDAL, lxml and pyproj but not ``pythoncdt``, ``triangle`` nor (on many systems) shapely 2.
The plugin must load without them; the algorithms that need them call ``require`` first.
"""
from __future__ import annotations

import importlib
import re
import sys

from .errors import MissingDependencyError

#: import name -> pip requirement; its ``>=`` bound is the minimum release that ``missing`` checks
REQUIREMENTS: dict[str, str] = {
    "shapely": "shapely>=2",
    "triangle": "triangle",
    "pythoncdt": "pythoncdt>=2.0.2",
    "lxml": "lxml",
    "pyproj": "pyproj",
    "distributed": "dask[distributed]",
    "pygltflib": "pygltflib>=1.16",
    "meshoptimizer": "meshoptimizer==0.2.30a0",  # the 3D Tiles web profile only
}

#: what the code uses of a module, checked by feature: distribution builds may report no usable
#: version (Debian's shapely says "0+unknown"), so the version alone cannot decide
FEATURES: dict[str, tuple[str, ...]] = {
    "shapely": ("from_wkb", "to_wkb", "make_valid", "STRtree", "geos_version"),  # the shapely 2 API
}


def release(version: str) -> tuple[int, ...] | None:
    """The release numbers of a PEP 440 version ("2.1.0rc1" -> (2, 1, 0)), or None when it says nothing:
    unparsable, or only a placeholder such as "0+unknown" or "0.0.0" (builds without version metadata)."""
    match = re.match(r"\s*v?(?:\d+!)?(\d+(?:\.\d+)*)", version or "")
    if not match:
        return None
    numbers = tuple(int(part) for part in match.group(1).split("."))
    return None if not any(numbers) else numbers


def _satisfied(name: str, module: object, minimum: tuple[int, ...] | None) -> bool:
    """``module`` has what the code uses: the features of ``FEATURES`` and, when its version says
    something, at least ``minimum`` (a pre-release of the minimum counts as it)."""
    if not all(hasattr(module, feature) for feature in FEATURES.get(name, ())):
        return False
    if minimum is None:
        return True
    found = release(str(getattr(module, "__version__", "")))
    if found is None:
        return True  # the version says nothing: the module imports and has the features
    width = max(len(found), len(minimum))
    return found + (0,) * (width - len(found)) >= minimum + (0,) * (width - len(minimum))


def missing(modules: tuple[str, ...] | list[str]) -> list[str]:
    """The pip requirements among ``modules`` that are absent or too old."""
    result = []
    for name in modules:
        requirement = REQUIREMENTS.get(name, name)
        bound = requirement.partition(">=")[2]
        minimum = release(bound) if bound else None
        try:
            module = importlib.import_module(name)
        except ImportError:
            result.append(requirement)
            continue
        if not _satisfied(name, module, minimum):
            result.append(requirement)
    return result


def install_hint(requirements: list[str], problem: str | None = None) -> str:
    """A message with the exact commands that install ``requirements`` for QGIS's Python.

    On Linux shapely must be built against the system GEOS (see ``geos_mismatch``).
    """
    quoted = " ".join(f'"{r}"' for r in requirements)
    no_binary = "--no-binary shapely " if any(r.startswith("shapely") for r in requirements) else ""
    geos_dev = "sudo apt install libgeos-dev python3-dev && " if no_binary else ""
    if problem:
        no_binary = "--force-reinstall " + no_binary
    return (
        (problem or f"Missing Python package(s): {', '.join(requirements)}.")
        + " Install them for QGIS's Python, then restart QGIS.\n"
        f"  Linux (Debian/Ubuntu QGIS): {geos_dev}/usr/bin/python3 -m pip install --user "
        f"--break-system-packages {no_binary}{quoted}\n"
        f"  Windows (OSGeo4W / QGIS installer): open the 'OSGeo4W Shell' and run: python -m pip install {quoted}\n"
        f"  macOS (QGIS.app): /Applications/QGIS.app/Contents/MacOS/bin/python3 -m pip install --user {quoted}\n"
        "Note: 'triangle' is free for non-commercial use only (licence of J. R. Shewchuk's Triangle); "
        "'pythoncdt' (MPL-2.0) is the terrain triangulator for commercial use."
    )


def geos_mismatch(host_geos: str) -> str | None:
    """Why the installed shapely must not run inside this QGIS, or None when it may.

    On Linux, QGIS loads the system GEOS with its symbols visible to every library loaded later.
    A shapely wheel carries its own GEOS build; inside QGIS its calls then resolve to the
    system's, of another version, and QGIS crashes. A shapely built from source against the
    system GEOS (same version) is safe. ``host_geos`` is QGIS's GEOS version, e.g. "3.11.1".
    """
    if not sys.platform.startswith("linux"):
        return None
    try:
        import shapely
    except ImportError:
        return None
    ours = ".".join(str(part) for part in shapely.geos_version)
    if host_geos.split("-")[0] == ours:
        return None
    return (f"The installed shapely uses its own GEOS {ours} while QGIS uses GEOS {host_geos}; "
            "running it inside QGIS would crash QGIS. Rebuild shapely against the system GEOS.")


def require(modules: tuple[str, ...] | list[str]) -> None:
    """Raise ``MissingDependencyError`` with install instructions if any module is missing."""
    absent = missing(modules)
    if absent:
        raise MissingDependencyError(install_hint(absent))
