"""make package: the zip holds the plugin only, and QGIS loads it installed from the zip."""
from __future__ import annotations

import os
import subprocess
import zipfile

from conftest import ROOT


def test_package_zip_installs_and_loads_in_qgis_process(tmp_path):
    out = subprocess.run(["bash", str(ROOT / "scripts" / "package.sh")], capture_output=True,
                         text=True, check=True, cwd=ROOT).stdout.strip().splitlines()[-1]
    archive = zipfile.ZipFile(ROOT / out)
    names = archive.namelist()
    assert all(n.startswith("wit_citymodel/") for n in names)
    for required in ("metadata.txt", "__init__.py", "plugin.py", "icon.svg", "LICENSE",
                     "processing_provider/provider.py", "wit_plugin/errors.py",
                     "i18n/wit_citymodel_ko.qm", "i18n/wit_citymodel_ko.ts",
                     "README.md", "CHANGELOG.md"):  # README: the Help buttons open it
        assert f"wit_citymodel/{required}" in names, required
    for forbidden in ("tests/", ".ci/", "scripts/", "benchmarks/", "out/", ".venv/", "__pycache__"):
        assert not any(forbidden in n for n in names), forbidden

    profile = tmp_path / "profile"
    plugins = profile / "profiles" / "default" / "python" / "plugins"
    plugins.mkdir(parents=True)
    archive.extractall(plugins)
    env = dict(os.environ, QGIS_CUSTOM_CONFIG_PATH=str(profile), QT_QPA_PLATFORM="offscreen")
    enable = subprocess.run(["qgis_process.bin", "plugins", "enable", "wit_citymodel"],
                            capture_output=True, text=True, env=env, timeout=120)
    assert enable.returncode == 0, enable.stderr
    listing = subprocess.run(["qgis_process.bin", "list"], capture_output=True, text=True,
                             env=env, timeout=120).stdout
    assert "WIT City Model" in listing
    assert "wit:generatesample" in listing
