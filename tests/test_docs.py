"""The user's manual (README.md) and the developer's guide (docs/): every relative link resolves."""
from __future__ import annotations

import re
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


def package_map(markdown: str) -> dict[str, set[str]]:
    """docs/development.md's package map: package folder → the module names its rows list (a name ending in
    ``/`` is a subpackage, all of it)."""
    section = markdown.split("## Package map of the core", 1)[1].split("\n## ", 1)[0]
    listed: dict[str, set[str]] = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or not cells[1].startswith("`"):
            continue
        package = cells[1].strip("`")
        listed.setdefault(package, set()).update(re.findall(r"`([^`]+)`", cells[2]))
    return listed


def modules_of_the_tree(core: Path) -> dict[str, set[str]]:
    """Each package folder under ``core`` (``infra/``, ``infra/io/``…) → its modules and direct subpackages, as
    the map names them; a subpackage that is itself a row of the map is left to its row."""
    def is_package(folder: Path) -> bool:  # citygml/ has no __init__ (a namespace package)
        return folder.is_dir() and folder.name != "__pycache__" and any(folder.glob("*.py"))

    tree: dict[str, set[str]] = {}
    for folder in sorted(p for p in core.rglob("*") if is_package(p)):
        names = {p.stem for p in folder.glob("*.py") if p.stem not in ("__init__", "__main__")}
        names |= {f"{p.name}/" for p in folder.iterdir() if is_package(p)}
        tree[f"{folder.relative_to(core).as_posix()}/"] = names
    return tree


def test_the_package_map_finds_what_is_missing_and_what_is_gone():
    markdown = ("## Package map of the core\n\n| layer | package | modules | what |\n|---|---|---|---|\n"
                "| steps | `terrain/` | `build`, `mesh` (+ `gone`) | … |\n| | `texture/` | `facade/` | … |\n"
                "\n## Next\n")
    assert package_map(markdown) == {"terrain/": {"build", "mesh", "gone"}, "texture/": {"facade/"}}


def test_the_package_map_matches_the_tree():
    """Every package of the core is a row of the map, every module and subpackage is named in its package's
    rows, and nothing named there is gone from the tree."""
    listed = package_map((ROOT / "docs" / "development.md").read_text(encoding="utf-8"))
    tree = modules_of_the_tree(ROOT / "wit_plugin")
    rows = set(listed)
    covered = {p for p in tree if p in rows or any(p.startswith(r) and f"{p[len(r):]}" in listed[r] for r in rows)}
    assert set(tree) - covered == set()  # a package the map does not show
    for package, names in listed.items():
        children = {n for n in tree[package] if f"{package}{n}" not in rows}
        assert names == children, package
