"""The plugin card (metadata.txt): one version, the changelog from CHANGELOG.md, no invented addresses.

Core test: reads files only, no QGIS.
"""
from __future__ import annotations

import configparser
import re
import subprocess
import sys

from conftest import ROOT

sys.path.insert(0, str(ROOT / "scripts"))
import changelog


def _card() -> configparser.SectionProxy:
    card = configparser.ConfigParser(interpolation=None)
    card.read(ROOT / "metadata.txt", encoding="utf-8")
    return card["general"]


def test_pyproject_version_is_the_cards():
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    versions = re.findall(r'^version = "([^"]+)"', pyproject, re.MULTILINE)
    assert versions == [_card()["version"]]
    assert re.fullmatch(r"\d+\.\d+\.\d+", _card()["version"])


def test_changelog_in_the_card_is_changelog_md():
    result = subprocess.run([sys.executable, str(ROOT / "scripts" / "changelog.py"), "--check"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stdout
    lines = _card()["changelog"].strip().splitlines()
    assert lines[0] == _card()["version"]  # the newest version first: the one the card declares
    items = [line for line in lines if line.startswith("- ")]
    # every algorithm the provider registers is in the changelog of the version that added it
    provider = (ROOT / "processing_provider" / "provider.py").read_text(encoding="utf-8")
    algorithm_files = re.findall(r"^from \.(\w+) import", provider, re.MULTILINE)
    ids = set()
    for module in algorithm_files:
        ids.update(re.findall(r'^\s+algorithm_id = "(\w+)"',
                              (ROOT / "processing_provider" / f"{module}.py").read_text(encoding="utf-8"),
                              re.MULTILINE))
    assert len(ids) == 18  # 17 algorithms, and merge rasters' first id (wit:mergetiles, deprecated)
    for algorithm_id in ids | {"citymodelmodel"}:
        assert any(f"wit:{algorithm_id}" in item for item in items), algorithm_id


def test_changelog_script_rewrites_only_the_changelog():
    card = "[general]\nname=x\nchangelog=\n    0.0.1\n    - old\nicon=icon.svg\n"
    new = changelog.with_changelog(card, changelog.changelog_lines("# C\n\nintro\n\n## 0.0.2\n\n- new\n- more\n"))
    assert new == "[general]\nname=x\nchangelog=\n    0.0.2\n    - new\n    - more\nicon=icon.svg\n"


def test_card_has_what_qgis_reads_and_no_invented_address():
    card = _card()
    for key in ("name", "qgisMinimumVersion", "description", "about", "version", "author"):
        assert card.get(key, "").strip(), key
    text = (ROOT / "metadata.txt").read_text(encoding="utf-8")
    # the addresses once invented here: a placeholder e-mail, a GitHub repository that does not exist
    assert "example.org" not in text and "github.com/wit-citymodel" not in text
    assert (ROOT / card["icon"]).is_file()
