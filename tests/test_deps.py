"""Optional dependencies: detection, install instructions, the GEOS clash guard."""
from __future__ import annotations

import sys

import pytest
import shapely

from wit_plugin import deps
from wit_plugin.errors import MissingDependencyError


def test_missing_package_is_named_with_install_commands(monkeypatch):
    monkeypatch.setitem(sys.modules, "triangle", None)
    assert deps.missing(["triangle", "lxml"]) == ["triangle"]
    with pytest.raises(MissingDependencyError) as error:
        deps.require(["triangle"])
    message = str(error.value)
    assert '/usr/bin/python3 -m pip install --user --break-system-packages "triangle"' in message
    assert 'OSGeo4W Shell' in message and "non-commercial" in message


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
