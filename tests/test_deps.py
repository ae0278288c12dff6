"""Optional dependencies: detection, install instructions, the GEOS clash guard."""
from __future__ import annotations

import sys
import types

import pytest
import shapely

from wit_plugin.infra import deps
from wit_plugin.infra.errors import MissingDependencyError

pytestmark = pytest.mark.qgis_facing  # the platform's shapely (Debian sid's says "0+unknown") in the chroot too


def test_missing_package_is_named_with_install_commands(monkeypatch):
    monkeypatch.setitem(sys.modules, "triangle", None)
    assert deps.missing(["triangle", "lxml"]) == ["triangle"]
    with pytest.raises(MissingDependencyError) as error:
        deps.require(["triangle"])
    message = str(error.value)
    assert '/usr/bin/python3 -m pip install --user --break-system-packages "triangle"' in message
    assert 'OSGeo4W Shell' in message and "non-commercial" in message


SHAPELY_2_API = ("from_wkb", "to_wkb", "make_valid", "STRtree", "geos_version")


def fake_module(name: str, version: str, features=()) -> types.ModuleType:
    module = types.ModuleType(name)
    module.__version__ = version
    for feature in features:
        setattr(module, feature, object())
    return module


@pytest.mark.parametrize(("version", "features", "ok"), [
    ("0+unknown", SHAPELY_2_API, True),     # Debian trixie/sid's python3-shapely 2.x
    ("2.0.1", SHAPELY_2_API, True),
    ("2.1.0rc1", SHAPELY_2_API, True),      # a pre-release of 2.1
    ("1.8.5.post1", (), False),             # shapely 1.8: no vectorised API
    ("1.8.5.post1", SHAPELY_2_API, False),  # says 1.8, whatever it has
    ("0+unknown", (), False),               # a shapely 1.x build without version metadata
])
def test_shapely_is_checked_by_feature_not_by_its_version_string(monkeypatch, version, features, ok):
    monkeypatch.setitem(sys.modules, "shapely", fake_module("shapely", version, features))
    assert deps.missing(["shapely"]) == ([] if ok else ["shapely>=2"])


@pytest.mark.parametrize(("version", "ok"), [
    ("1.16.2", True), ("1.16", True), ("2.0.0rc1", True), ("1.15.6", False), ("1.9", False),
    ("0+unknown", True), ("", True), ("1.16.0.dev3", True)])
def test_a_minimum_version_is_compared_as_numbers(monkeypatch, version, ok):
    """1.9 < 1.16 < 2.0rc1; a version that says nothing does not refuse an importable module."""
    monkeypatch.setitem(sys.modules, "pygltflib", fake_module("pygltflib", version))
    assert deps.missing(["pygltflib"]) == ([] if ok else ["pygltflib>=1.16"])


def test_release_numbers_of_version_strings():
    assert deps.release("2.1.0rc1") == (2, 1, 0)
    assert deps.release("1.8.5.post1") == (1, 8, 5)
    assert deps.release("1!2.0") == (2, 0)
    assert deps.release("0+unknown") is None and deps.release("0.0.0") is None and deps.release("dev") is None


def test_the_real_shapely_passes_the_check():
    assert deps.missing(["shapely", "triangle", "pygltflib"]) == []


def test_shapely_is_built_from_source_on_linux_in_the_hint():
    message = deps.install_hint(["shapely>=2", "triangle"])
    assert "sudo apt install libgeos-dev python3-dev && /usr/bin/python3 -m pip install --user " \
           '--break-system-packages --no-binary shapely "shapely>=2" "triangle"' in message


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the clash is an ELF symbol-scope issue")
def test_geos_guard_accepts_the_same_geos_and_refuses_another():
    ours = ".".join(map(str, shapely.geos_version))
    assert deps.geos_mismatch(f"{ours}-CAPI-1.17.1") is None
    problem = deps.geos_mismatch("3.9.0-CAPI-1.14.2")
    assert problem and "would crash QGIS" in problem and ours in problem
    assert "--force-reinstall --no-binary shapely" in deps.install_hint(["shapely>=2"], problem)


def test_this_environment_builds_shapely_against_qgis_geos():
    """The set-up must build shapely from source, or qgis_process segfaults (seen with the wheel)."""
    from qgis.core import Qgis

    assert deps.geos_mismatch(Qgis.geosVersion()) is None


def test_a_too_old_pythoncdt_is_missing_and_a_new_enough_one_is_not(monkeypatch):
    """The minimum comes from the requirement's own ``>=`` bound (a bare int there once made every check of
    pythoncdt raise a TypeError)."""
    for version, ok in (("2.0.1", False), ("2.0.2", True), ("2.1.0", True), ("0+unknown", True)):
        monkeypatch.setitem(sys.modules, "pythoncdt", types.SimpleNamespace(__version__=version))
        assert deps.missing(["pythoncdt"]) == ([] if ok else ["pythoncdt>=2.0.2"]), version
