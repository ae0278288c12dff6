"""Which Python runs the core in another process (Dask workers, the merge and the 3D Tiles export beside the
next steps), and which runs pip for QGIS's Python (``this_python``).

Inside QGIS on Windows and macOS ``sys.executable`` is QGIS itself: starting it would open QGIS again.
So a separate process always gets an explicit interpreter: the one configured, else the first Python
that imports what the work needs among the Python of this installation (QGIS's own prefix, or the virtual
environment running), ``sys.executable`` (only when it is a Python), and ``python3`` / ``python`` on the PATH
(see ``_candidates``); the core comes from this checkout.
"""
from __future__ import annotations

import functools
import importlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

from .errors import InputError

CORE_ROOT = Path(__file__).resolve().parents[2]  # the folder holding the package wit_plugin


#: folders of packages the plugin put on ``sys.path`` (``installer.activate``): its processes need them too
PACKAGE_FOLDERS: list[str] = []


#: one thread each for the numeric libraries of the core's processes, unless the user set another number: they
#: run beside each other (a step beside the next ones, one Dask worker per core), and OpenBLAS's threads spin on
#: every core even for a product three columns wide (the 3D Tiles export: 10.4 CPU-s for 7.9 s, 8.1 with one)
SINGLE_THREADED = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def core_env() -> dict:
    """This process's environment with the core importable as ``wit_plugin``, the packages the plugin
    installed into the QGIS profile, and ``SINGLE_THREADED``."""
    paths = (str(CORE_ROOT), *PACKAGE_FOLDERS, os.environ.get("PYTHONPATH"))
    return {**SINGLE_THREADED, **os.environ, "PYTHONPATH": os.pathsep.join(p for p in paths if p)}


#: True in a Python program the plugin started to run the core (the chain apart, ``chain.apart``): the program's
#: own interpreter, given the same environment, is then checked by importing here rather than by starting it again
THIS_PROGRAM_IS_OURS = False


def core_python(configured: str | None, modules: tuple[str, ...], module: str) -> str:
    """An interpreter that imports ``modules`` and the core's ``module`` (see the module docstring);
    ``configured`` (else ``$WIT_WORKER_PYTHON``) wins and must work."""
    for candidate in (configured, os.environ.get("WIT_WORKER_PYTHON")):
        if candidate:
            if not (Path(candidate).is_file() and os.access(candidate, os.X_OK)):
                raise InputError(f"The worker Python {candidate} is not an executable file.")
            problem = _cannot_run(candidate, modules, module)
            if problem:
                raise InputError(f"The worker Python {candidate} cannot run the core: {problem}")
            return candidate
    tried = []
    for candidate in _candidates():
        ours = THIS_PROGRAM_IS_OURS and candidate == sys.executable
        problem = _cannot_import(modules, module) if ours else _cannot_run(candidate, modules, module)
        if not problem:
            return candidate
        tried.append(f"{candidate}: {problem}")
    raise InputError("No Python imports the plugin's dependencies for a separate process ("
                     + "; ".join(tried or ["none found"]) + "). Set WORKER_PYTHON (or $WIT_WORKER_PYTHON) to one "
                     "that does, e.g. a virtual environment with the packages of requirements.txt.")


def candidate_pythons() -> list[str]:
    """The interpreters ``core_python`` tries, in its order: ``$WIT_WORKER_PYTHON`` alone when set."""
    configured = os.environ.get("WIT_WORKER_PYTHON")
    return [configured] if configured else _candidates()


def _candidates() -> list[str]:
    """Pythons to try, in order: ``sys.executable`` when it is a Python of this installation (a virtual
    environment's own), the one of QGIS's own prefix (``bin/python3``, or ``python.exe`` on Windows), then
    ``sys.executable`` when it is another Python, then ``python3`` / ``python`` on the PATH.

    Inside qgis_process ``sys.executable`` is whatever ``python3`` the PATH finds first (a pyenv shim, say):
    tried first, it cost a failed start of a few tenths of a second each run."""
    executable = [sys.executable] if Path(sys.executable).name.lower().startswith("python") else []
    prefix = Path(sys.exec_prefix)
    own = [str(prefix / "bin" / "python3"), str(prefix / "python.exe")]
    on_path = [c for c in (shutil.which("python3"), shutil.which("python")) if c]
    if executable and _within(sys.executable, sys.prefix):
        candidates = executable + own + on_path
    else:
        candidates = own + executable + on_path
    return list(dict.fromkeys(c for c in candidates if Path(c).is_file()))


def _within(path: str, folder: str) -> bool:
    """Whether ``path`` lies in ``folder`` as written (a virtual environment's ``bin/python`` is a link out of it)."""
    path, folder = os.path.abspath(path), os.path.abspath(folder)
    return os.path.commonpath([path, folder]) == folder


def this_python(configured: str | None = None) -> str:
    """An interpreter of the very Python this process runs (same version, same installation), to run pip
    for it: QGIS's own Python inside QGIS, never QGIS itself, nor another Python 3.X that happens to be
    on the PATH (inside qgis_process ``sys.executable`` can be such a one, e.g. a pyenv shim). A
    ``configured`` one wins and must be of the same version."""
    ours = (f"{sys.version_info[0]}.{sys.version_info[1]}", _same_path(sys.base_prefix))
    if configured and not (Path(configured).is_file() and os.access(configured, os.X_OK)):
        raise InputError(f"The Python {configured} is not an executable file.")
    tried = []
    for candidate in [configured] if configured else _candidates():
        found = _identity(candidate)
        if found == ours or (configured and found[0] == ours[0]):
            return candidate
        tried.append(f"{candidate}: Python {found[0]} in {found[1]}")
    raise InputError(f"No interpreter of QGIS's Python (Python {ours[0]} in {sys.base_prefix}) was found ("
                     + "; ".join(tried or ["none found"]) + "). Give its path as the Python interpreter.")


def _same_path(path: str) -> str:
    return os.path.normcase(os.path.realpath(path))


@functools.lru_cache(maxsize=16)
def _identity(python: str) -> tuple[str, str]:
    """``python``'s ("major.minor", installation prefix), or (why it does not run, "")."""
    code = "import sys; print('%d.%d' % sys.version_info[:2]); print(sys.base_prefix)"
    try:
        result = subprocess.run([python, "-c", code], capture_output=True, text=True,  # nosec B603  # no shell
                                timeout=60)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return str(exc), ""
    lines = result.stdout.splitlines()
    if result.returncode != 0 or len(lines) < 2:
        return result.stderr.strip() or "fails", ""
    return lines[0], _same_path(lines[1])


@functools.lru_cache(maxsize=16)
def _cannot_run(python: str, modules: tuple[str, ...], module: str) -> str | None:
    """Why ``python`` cannot run ``module`` (a missing import), or None; asked once per process."""
    code = f"import {', '.join(modules)}; import {module}"
    try:
        result = subprocess.run([python, "-c", code], env=core_env(),  # nosec B603  # a Python with our code, no shell
                                capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return str(exc)
    return None if result.returncode == 0 else (result.stderr.strip().splitlines() or ["fails"])[-1]


def _cannot_import(modules: tuple[str, ...], module: str) -> str | None:
    """Why this very Python cannot import ``modules`` and ``module``, or None."""
    for name in (*modules, module):
        try:
            importlib.import_module(name)
        except ImportError as exc:
            return f"{type(exc).__name__}: {exc}"
    return None
