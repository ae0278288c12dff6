"""The split of the suite (tests/conftest.py): QGIS tests get the marker qgis, and a core run
(scripts/test.sh --core, make test-fast) collects exactly the others with qgis unimportable.

Itself a QGIS test: it compares with a collection that imports QGIS (pytest collects in child processes)."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest
from conftest import ROOT

pytestmark = pytest.mark.qgis


def _collected(*args: str, without_qgis: bool = False) -> set[str]:
    env = dict(os.environ)
    if without_qgis:  # as scripts/test.sh --core runs pytest
        env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "tests" / "without_qgis"), env.get("PYTHONPATH", "")])
        args = ("-p", "no:pytest_qgis", "-W", "ignore::pytest.PytestConfigWarning", *args)
    result = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", *args],
                            capture_output=True, text=True, cwd=ROOT, env=env, timeout=600)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return {line for line in result.stdout.splitlines() if "::" in line}


def test_qgis_tests_are_marked_the_others_are_core_and_run_without_qgis():
    qgis_tests = _collected("-m", "qgis")
    core_tests = _collected("-m", "not qgis")
    assert qgis_tests and core_tests and not qgis_tests & core_tests
    assert _collected(without_qgis=True) == core_tests
    assert any(t.startswith("tests/test_provider.py::") for t in qgis_tests)  # the module imports qgis
    assert not any(t.startswith("tests/test_provider.py::") for t in core_tests)
    assert "tests/test_sheetrun.py::test_citymodeltiles_headless_through_qgis_process" in qgis_tests  # qgis_process
    assert "tests/test_alg_real_layers.py::test_ngii_as_shipped_tiled_on_map_sheets_headless" in qgis_tests  # a helper
    assert "tests/test_plugin_card.py::test_pyproject_version_is_the_cards" in core_tests
    assert "tests/test_sheetrun.py::test_a_second_run_resumes" in core_tests
