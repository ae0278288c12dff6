"""Test set-up: the core importable as ``wit_plugin``; the plugin importable as ``wit_citymodel``.

The checkout folder may have any name (CI clones into an arbitrary one), so the plugin package
is registered under its installed name from the repository root.
"""
from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
os.environ.setdefault("PROJ_DATA", "/usr/share/proj")

if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

if "wit_citymodel" not in sys.modules:
    _spec = importlib.util.spec_from_file_location(
        "wit_citymodel", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
    _module = importlib.util.module_from_spec(_spec)
    sys.modules["wit_citymodel"] = _module
    _spec.loader.exec_module(_module)


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """The shared fixture data beside the checkout (present in CI)."""
    if not SHARED.is_dir():
        pytest.fail(f"{SHARED} is missing: the tests need ../shared beside the checkout")
    return SHARED


_KEEP_ALIVE: list = []


def ensure_wit_provider():
    """The ``wit`` provider registered in the test QGIS, as the plugin does it.

    Looked up on every use: a plugin test's unload() removes (and deletes) the provider.
    """
    from qgis.core import QgsApplication

    from wit_citymodel.processing_provider.provider import WitProvider

    registry = QgsApplication.processingRegistry()
    if registry.providerById("wit") is None:
        _KEEP_ALIVE.append(WitProvider())  # the Python side must outlive its registration
        registry.addProvider(_KEEP_ALIVE[-1])
    return registry.providerById("wit")


@pytest.fixture
def wit_provider(qgis_processing):
    return ensure_wit_provider()


@pytest.fixture
def run_algorithm(wit_provider):
    """Run a Processing algorithm like a user (processing.run) and return its results."""
    import processing

    def run(algorithm_id: str, parameters: dict) -> dict:
        return processing.run(algorithm_id, parameters)

    return run


@pytest.fixture
def cancel_after_checks():
    """A core Feedback factory: ``cancel_after_checks(n)`` answers "cancel" from its (n+1)-th check on."""
    from wit_plugin.feedback import Feedback

    class CancelAfter(Feedback):
        def __init__(self, checks: int):
            self.checks = checks

        def is_canceled(self) -> bool:
            self.checks -= 1
            return self.checks < 0

    return CancelAfter
