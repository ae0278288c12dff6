"""make qt6-check: QGIS's own Qt 6 migration script, run on what the plugin ZIP ships; it must leave no change.

    python scripts/qt6_check.py PATH/TO/pyqt5_to_pyqt6.py

The script (``scripts/pyqt5_to_pyqt6/pyqt5_to_pyqt6.py`` of the public QGIS repository; nothing of it is kept
here, and CI cannot fetch it: hence a target given its path) rewrites a plugin for PyQt6 in place. It runs here
on a copy of the ZIP's files, as plugins.qgis.org's Qt 6 check runs it on an upload, in a Python with its
requirements from PyPI (PyQt6, PyQt6-QScintilla, tokenize-rt, astpretty): ``QT6_TOOL_VENV``, else a
throwaway venv made once in ``~/.cache/wit-citymodel/qt6-tool-venv``. Without a QGIS 4 build it introspects
PyQt6's enums only, so the QGIS enums stay with tests/qt6_scan.py (``make test``). Fails, naming each
difference and each warning, when the script would change a file or warns about one; also runs its
``--dry_run`` mode, as the site does, which must succeed.
"""
from __future__ import annotations

import difflib
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import plugin_zip

TOOL_REQUIREMENTS = ("PyQt6", "PyQt6-QScintilla", "tokenize-rt", "astpretty")
#: what the script says when no QGIS 4 is importable: expected here
NO_QGIS_NOTE = "QGIS classes not available for introspection"


def tool_python() -> Path:
    """A Python with the script's requirements: QT6_TOOL_VENV, else a venv made once outside the checkout."""
    venv = Path(os.environ.get("QT6_TOOL_VENV") or Path.home() / ".cache" / "wit-citymodel" / "qt6-tool-venv")
    python = venv / "bin" / "python"
    if not python.exists():
        print(f"[qt6-check] making {venv} ({', '.join(TOOL_REQUIREMENTS)} from PyPI)", file=sys.stderr)
        subprocess.run([sys.executable, "-m", "venv", "--clear", str(venv)], check=True)  # nosec B603  # no shell
        subprocess.run([str(python), "-m", "pip", "install", "-q", *TOOL_REQUIREMENTS], check=True)  # nosec B603
    return python


def run_tool(python: Path, tool: Path, folder: Path, *options: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
    env.pop("PYTHONPATH", None)  # the checkout's QGIS 3 (PyQt5) must not be seen: the tool warns about it
    return subprocess.run([str(python), str(tool), *options, str(folder)], capture_output=True,  # nosec B603
                          text=True, env=env, timeout=900)


def changes(before: Path, after: Path) -> list[str]:
    """A unified diff of every file the script changed (paths relative to the plugin folder)."""
    lines = []
    for new in sorted(after.rglob("*.py")):
        name = new.relative_to(after)
        old_text, new_text = (before / name).read_text(encoding="utf-8"), new.read_text(encoding="utf-8")
        if old_text != new_text:
            lines += difflib.unified_diff(old_text.splitlines(), new_text.splitlines(), str(name), str(name),
                                          lineterm="")
    return lines


def warnings(run: subprocess.CompletedProcess) -> list[str]:
    return [line for line in (run.stdout + run.stderr).splitlines()
            if ("WARNING" in line or "ERROR" in line) and NO_QGIS_NOTE not in line]


def main(argv: list[str]) -> int:
    if len(argv) != 1 or not Path(argv[0]).is_file():
        print("make qt6-check PYQT5_TO_PYQT6=path/to/QGIS/scripts/pyqt5_to_pyqt6/pyqt5_to_pyqt6.py", file=sys.stderr)
        return 2
    tool, python = Path(argv[0]).resolve(), tool_python()
    with tempfile.TemporaryDirectory(prefix="wit-qt6-") as tmp:
        archive = Path(tmp) / "plugin.zip"
        plugin_zip.build(archive, {})
        with zipfile.ZipFile(archive) as opened:
            opened.extractall(Path(tmp) / "before")
        before = Path(tmp) / "before" / plugin_zip.TOP_FOLDER
        after = Path(tmp) / "after"
        shutil.copytree(before, after)
        dry = run_tool(python, tool, before, "--dry_run")
        fixed = run_tool(python, tool, after)
        found = changes(before, after) + warnings(dry) + warnings(fixed)
        if dry.returncode != 0:
            found.append(f"--dry_run failed (exit {dry.returncode}): {dry.stderr.strip()[-1000:]}")
        if fixed.returncode not in (0, 1) or "Traceback" in fixed.stderr:
            found.append(f"the script failed (exit {fixed.returncode}): {fixed.stderr.strip()[-1000:]}")
        count = len(list(before.rglob("*.py")))
    for line in found:
        print(line)
    print(f"[qt6-check] QGIS's pyqt5_to_pyqt6.py on the {count} Python files the ZIP ships: "
          f"{'no change, no warning' if not found else f'{len(found)} line(s) above'}", file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
