"""The user's manual (README.md) and the developer's guide (docs/): every relative link resolves."""
from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROOT
from markdown_links import broken_links, github_anchors

DOCUMENTS = ("README.md", "docs/development.md", "benchmarks/README.md")


def test_github_anchors_as_github_forms_them():
    assert github_anchors("# WIT City Model — textured (QGIS plugin)\n## Sample data (`wit:generatesample`)\n"
                          "```sh\n# not a heading\n```\n## Sample data (`wit:generatesample`)\n") == {
        "wit-city-model--textured-qgis-plugin", "sample-data-witgeneratesample", "sample-data-witgeneratesample-1"}


def test_broken_links_finds_a_missing_file_and_a_missing_anchor(tmp_path: Path):
    (tmp_path / "other.md").write_text("# Its heading\n", encoding="utf-8")
    page = tmp_path / "page.md"
    page.write_text("# Here\n[a](other.md#its-heading) [b](#here) [c](missing.md) [d](other.md#nowhere) "
                    "[e](#gone) ![f](https://example.org/x.png)\n```\n[g](in-code.md)\n```\n", encoding="utf-8")
    assert broken_links(page) == ["missing.md", "other.md#nowhere", "#gone"]


@pytest.mark.parametrize("document", DOCUMENTS)
def test_every_relative_link_resolves(document: str):
    assert broken_links(ROOT / document) == []
