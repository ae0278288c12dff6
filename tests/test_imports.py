"""Imports run one way: glue → core, and in the core infrastructure → steps → chain → map-sheet runs.

Read from the source with ``ast`` (nothing is imported, so no QGIS is needed): every ``import`` of every module,
relative ones resolved, also those inside functions; only ``if TYPE_CHECKING:`` blocks are left out (they never
run). Importing ``a.b.c`` also runs the ``__init__`` of ``a`` and ``a.b``: those edges count too.
"""
from __future__ import annotations

import ast
from collections.abc import Iterable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CORE, GLUE = "wit_plugin", "processing_provider"

#: the core's layers, lowest first: a module imports from its own layer or a lower one, never from a higher one.
#: Keys are the names directly under wit_plugin/ (a module or a subpackage); a new one must be given a layer.
LAYERS: tuple[tuple[str, frozenset[str]], ...] = (
    ("infrastructure", frozenset({"infra"})),
    # the pipeline's steps, in its order: orthoimage sheets merged, layers prepared, terrain, LoD1 buildings,
    # textures (and the colour store beside them), CityGML and CityJSON, metrics, 3D Tiles and the preview;
    # the generated sample feeds them all
    ("steps", frozenset({
        "mosaic", "prepare", "terrain", "buildings", "texture", "colorstore", "citygml", "cityjson", "metrics",
        "tiles3d", "preview", "sample",
    })),
    ("chain", frozenset({"chain"})),
    ("map-sheet runs", frozenset({"sheetrun"})),
)


def module_name(path: Path, root: Path) -> str:
    """``wit_plugin/chain/citymodel.py`` → ``wit_plugin.chain.citymodel``; a package is its ``__init__``."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _type_checking_only(node: ast.AST) -> bool:
    test = getattr(node, "test", None)
    return isinstance(node, ast.If) and (
        isinstance(test, ast.Name) and test.id == "TYPE_CHECKING"
        or isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(tree: ast.AST) -> Iterable[ast.Import | ast.ImportFrom]:
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        elif not _type_checking_only(node):
            yield from _imports(node)


def imported_names(source: str, name: str, is_package: bool, modules: set[str]) -> set[str]:
    """The absolute names ``source`` (the module ``name``) imports: ``from x import y`` gives ``x.y`` when
    that is a module of ``modules``, else ``x``."""
    package = name.split(".") if is_package else name.split(".")[:-1]
    found = set()
    for node in _imports(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
            continue
        if node.level:
            base = package[:len(package) - node.level + 1]
            target = ".".join(base + ([node.module] if node.module else []))
        else:
            target = node.module or ""
        for alias in node.names:
            child = f"{target}.{alias.name}" if target else alias.name
            found.add(child if child in modules else target)
    return {n for n in found if n}


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """module → the project modules it imports (each with the packages' ``__init__`` it runs), plus the
    outside names the core must not import (``qgis``…), kept as they are written."""
    files = {module_name(p, root): p for top in (CORE, GLUE) for p in (root / top).rglob("*.py")}
    files.update({module_name(p, root): p for p in root.glob("*.py") if p.name != "__init__.py"})
    modules = set(files)
    graph = {}
    for name, path in files.items():
        edges = set()
        for target in imported_names(path.read_text(encoding="utf-8"), name, path.name == "__init__.py", modules):
            while target and target not in modules and "." in target:  # ``from pkg import name``: the module
                target = target.rsplit(".", 1)[0]
            edges.add(target)
            parts = target.split(".")
            edges.update(ancestor for k in range(1, len(parts))
                         if (ancestor := ".".join(parts[:k])) in modules and not name.startswith(ancestor + "."))
        graph[name] = {e for e in edges if e != name and (e in modules or e.split(".")[0] in ("qgis", GLUE))}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` (its nodes in order, the first repeated at the end), or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        path.pop()
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state and (cycle := visit(start)):
            return cycle
    return None


def top_name(module: str) -> str | None:
    """The name directly under wit_plugin/ that holds ``module`` (None: not in the core, or the core's ``__init__``)."""
    parts = module.split(".")
    return parts[1] if parts[0] == CORE and len(parts) > 1 else None


def package_graph(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """The core's graph between the names directly under wit_plugin/ (subpackages and modules)."""
    collapsed: dict[str, set[str]] = {}
    for module, targets in graph.items():
        if (source := top_name(module)) is not None:
            collapsed.setdefault(source, set()).update(
                t for t in map(top_name, targets) if t is not None and t != source)
    return collapsed


def layer_of(name: str, layers=LAYERS) -> int:
    return next(k for k, (_, members) in enumerate(layers) if name in members)


def uphill(graph: dict[str, set[str]], layers=LAYERS) -> list[str]:
    """Every core import that goes from a lower layer to a higher one, as 'module (layer) → module (layer)'."""
    found = []
    for module, targets in sorted(graph.items()):
        if (source := top_name(module)) is None:
            continue
        for target in sorted(targets):
            if (name := top_name(target)) is not None and layer_of(name, layers) > layer_of(source, layers):
                found.append(f"{module} ({layers[layer_of(source, layers)][0]}) → {target} "
                             f"({layers[layer_of(name, layers)][0]})")
    return found


GRAPH = import_graph()


# the checks themselves, on toy graphs: each must find what it looks for


def test_find_cycle_finds_a_cycle_and_only_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"x": {"x"}}) == ["x", "x"]


def test_relative_imports_resolve_and_packages_collapse():
    modules = {"wit_plugin.chain", "wit_plugin.chain.citymodel", "wit_plugin.sheetrun", "wit_plugin.sheetrun.job",
               "wit_plugin.infra.step_layers"}
    source = ("from ..infra import step_layers\nfrom ..sheetrun.job import TileJob\nfrom . import coverage\n"
              "import qgis.core\n")
    assert imported_names(source, "wit_plugin.chain.citymodel", False, modules) == {
        "wit_plugin.infra.step_layers", "wit_plugin.sheetrun.job", "wit_plugin.chain", "qgis.core"}
    assert imported_names("from .job import TileJob\n", "wit_plugin.sheetrun", True, modules) == {
        "wit_plugin.sheetrun.job"}
    toy = {"wit_plugin.chain.citymodel": {"wit_plugin.sheetrun.job"}, "wit_plugin.sheetrun.job": {"wit_plugin.chain"},
           "wit_plugin.chain": {"wit_plugin.chain.citymodel"}}
    assert find_cycle(package_graph(toy)) == ["chain", "sheetrun", "chain"]


def test_uphill_import_is_found():
    layers = (("low", frozenset({"infra"})), ("high", frozenset({"chain"})))
    toy = {"wit_plugin.infra.errors": {"wit_plugin.chain.citymodel"},
           "wit_plugin.chain.citymodel": {"wit_plugin.infra.errors"}}
    assert uphill(toy, layers) == ["wit_plugin.infra.errors (low) → wit_plugin.chain.citymodel (high)"]


def test_the_graph_is_read():
    """Known edges, so that an empty graph cannot pass the checks below."""
    assert "wit_plugin.chain" in GRAPH["wit_plugin.sheetrun.worker"]
    assert "wit_plugin.infra.errors" in GRAPH["processing_provider.base"]
    assert "wit_plugin.citygml.validation.names" in GRAPH["wit_plugin.citygml.validation.geometry"]
    assert len([m for m in GRAPH if m.startswith(CORE + ".")]) > 60


# the project


def test_no_cycle_between_modules():
    assert find_cycle(GRAPH) is None


def test_no_cycle_between_subpackages_of_the_core():
    assert find_cycle(package_graph(GRAPH)) is None


def test_core_imports_neither_qgis_nor_the_glue():
    wrong = {m: sorted(t for t in targets if t.split(".")[0] in ("qgis", GLUE))
             for m, targets in GRAPH.items() if m.split(".")[0] == CORE}
    assert {m: t for m, t in wrong.items() if t} == {}


def test_every_name_of_the_core_has_a_layer():
    names = {top_name(m) for m in GRAPH} - {None}
    declared = [name for _, members in LAYERS for name in members]
    assert len(declared) == len(set(declared)), "a name is in two layers"
    assert sorted(names - set(declared)) == [], "give each new module or subpackage of wit_plugin a layer in LAYERS"
    assert sorted(set(declared) - names) == [], "LAYERS names what wit_plugin no longer has"


def test_imports_run_down_the_layers():
    assert uphill(GRAPH) == []


@pytest.mark.parametrize("module", sorted(m for m in GRAPH if m.startswith(GLUE + ".")))
def test_glue_imports_the_glue_at_the_top(module):
    """A glue module imports the others at module level: a cycle is not hidden in a function. (The core's
    modules may be imported inside functions, so that the provider loads when an optional package is missing.)"""
    path = ROOT / (module.replace(".", "/") + ".py")
    if not path.is_file():
        path = ROOT / module.replace(".", "/") / "__init__.py"
    tree = ast.parse(path.read_text(encoding="utf-8"))
    lazy = [node.module for fn in ast.walk(tree) if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef))
            for node in ast.walk(fn) if isinstance(node, ast.ImportFrom) and node.level == 1]
    assert lazy == []
