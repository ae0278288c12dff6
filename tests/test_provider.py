"""The plugin and its provider inside QGIS: registration, unloading, help, translation, deps."""
from __future__ import annotations

import configparser
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import wit_citymodel
from conftest import ROOT
from markdown_links import github_anchors
from qgis.core import QgsApplication
from qgis.PyQt.QtCore import QUrl
from wit_citymodel import plugin as plugin_module
from wit_citymodel.processing_provider.provider import ALGORITHMS, MODELS
from wit_citymodel.processing_provider.translation import tr

pytestmark = pytest.mark.qgis_facing

EXPECTED_IDS = {"wit:generatesample", "wit:georeferencemapsheets", "wit:mergerasters", "wit:preparevectors",
                "wit:wittexture", "wit:writecitygml", "wit:validatecitygml", "wit:triangulateterrain",
                "wit:extrudebuildings", "wit:buildcolorstore", "wit:querycolorstore", "wit:qualitymetrics",
                "wit:citymodel", "wit:export3dtiles", "wit:exportcityjson"}


def _without_registered_provider():
    """Start from a registry without 'wit' (other tests register it for Processing runs)."""
    registry = QgsApplication.processingRegistry()
    if registry.providerById("wit") is not None:
        registry.removeProvider("wit")


@pytest.fixture
def loaded_plugin(qgis_iface, qgis_processing):
    _without_registered_provider()
    plugin = wit_citymodel.classFactory(qgis_iface)
    plugin.initProcessing()
    yield plugin
    plugin.unload()


def test_plugin_registers_provider_and_unloads_cleanly(qgis_iface, qgis_processing):
    _without_registered_provider()
    registry = QgsApplication.processingRegistry()
    plugin = wit_citymodel.classFactory(qgis_iface)
    plugin.initProcessing()
    plugin.initGui()  # QGIS calls both; the provider must be registered once
    provider = registry.providerById("wit")
    assert provider is not None
    assert {a.id() for a in provider.algorithms()} >= EXPECTED_IDS
    assert registry.algorithmById("wit:generatesample").displayName() == "Generate sample data"
    plugin.unload()
    assert registry.providerById("wit") is None
    assert registry.algorithmById("wit:generatesample") is None


def test_every_algorithm_is_documented(loaded_plugin):
    provider = QgsApplication.processingRegistry().providerById("wit")
    for algorithm in provider.algorithms():
        assert len(algorithm.shortHelpString()) > 80, algorithm.id()
        assert algorithm.group() and algorithm.groupId()
        for parameter in algorithm.parameterDefinitions():
            assert parameter.name() == parameter.name().upper(), (algorithm.id(), parameter.name())
            assert parameter.description(), (algorithm.id(), parameter.name())
    assert len(ALGORITHMS) + len(MODELS) == len(provider.algorithms())


def test_korean_locale_translates_labels(loaded_plugin):
    translator = plugin_module.install_translator("ko")
    assert translator is not None, "i18n/wit_citymodel_ko.qm missing: run scripts/setup.sh"
    try:
        assert tr("Generate sample data") == "샘플 데이터 생성"
        algorithm = QgsApplication.processingRegistry().algorithmById("wit:generatesample").create()
        assert algorithm.displayName() == "샘플 데이터 생성"
        assert algorithm.parameterDefinition("OUTPUT").description() == "출력 폴더"
    finally:
        QgsApplication.removeTranslator(translator)
    assert tr("Generate sample data") == "Generate sample data"


def test_every_user_string_has_a_korean_translation():
    result = subprocess.run([sys.executable, str(ROOT / "scripts" / "i18n.py"), "--check"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stdout


def test_plugin_loads_without_optional_packages_and_explains_how_to_install(tmp_path):
    """QGIS's own Python without .venv's packages: no triangle and no shapely 2."""
    script = textwrap.dedent(f"""
        import importlib.util, sys
        sys.modules["shapely"] = None   # as on a QGIS without shapely 2
        sys.modules["triangle"] = None
        spec = importlib.util.spec_from_file_location(
            "wit_citymodel", r"{ROOT / '__init__.py'}", submodule_search_locations=[r"{ROOT}"])
        module = importlib.util.module_from_spec(spec); sys.modules["wit_citymodel"] = module
        spec.loader.exec_module(module)
        from qgis.core import QgsApplication, QgsProcessingContext, QgsProcessingFeedback
        app = QgsApplication([], False); app.initQgis()
        from wit_citymodel.processing_provider.provider import WitProvider
        provider = WitProvider()
        assert QgsApplication.processingRegistry().addProvider(provider)
        print("ALGS", sorted(a.id() for a in provider.algorithms()))
        algorithm = QgsApplication.processingRegistry().algorithmById("wit:generatesample")
        print("HELP", "pip install" in algorithm.shortHelpString())
        class Recorder(QgsProcessingFeedback):
            def reportError(self, error, fatalError=False):
                print("ERROR", error.replace(chr(10), " | "))
        results, ok = algorithm.run({{"OUTPUT": r"{tmp_path / 'out'}"}}, QgsProcessingContext(), Recorder())
        print("OK", ok)
    """)
    env = {"QT_QPA_PLATFORM": "offscreen", "PATH": "/usr/bin:/bin", "HOME": str(tmp_path),
           "XDG_RUNTIME_DIR": str(tmp_path), "QGIS_CUSTOM_CONFIG_PATH": str(tmp_path / "profile")}
    result = subprocess.run(["/usr/bin/python3", "-c", script], capture_output=True, text=True,
                            env=env, timeout=120)
    listed = next(line for line in result.stdout.splitlines() if line.startswith("ALGS"))
    assert "wit:generatesample" in listed, result.stdout + result.stderr
    assert "HELP True" in result.stdout
    assert "OK False" in result.stdout
    error = next(line for line in result.stdout.splitlines() if line.startswith("ERROR"))
    assert 'Missing Python package(s): shapely>=2' in error
    assert '/usr/bin/python3 -m pip install --user --break-system-packages --no-binary shapely "shapely>=2"' in error
    assert "OSGeo4W Shell" in error
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_every_help_button_opens_a_readme_section_that_exists(loaded_plugin):
    """The Help button: the README shipped in the plugin folder, at a heading's anchor."""
    anchors = github_anchors((ROOT / "README.md").read_text(encoding="utf-8"))
    provider = QgsApplication.processingRegistry().providerById("wit")
    targets = {}
    for algorithm in provider.algorithms():
        if algorithm.id() == "wit:citymodelmodel":  # a model: QGIS shows the model's own help
            continue
        url = QUrl(algorithm.helpUrl())
        assert url.isLocalFile(), (algorithm.id(), url.toString())
        assert Path(url.toLocalFile()) == ROOT / "README.md"
        assert url.fragment() in anchors, (algorithm.id(), url.fragment())
        targets[algorithm.id()] = url.fragment()
    assert len(targets) == len(ALGORITHMS)
    assert targets["wit:generatesample"] == "sample-data-witgeneratesample"
    assert targets["wit:mergerasters"] == "algorithms-provider-wit"


def test_provider_version_is_the_plugin_cards(loaded_plugin):
    card = configparser.ConfigParser(interpolation=None)
    card.read(ROOT / "metadata.txt", encoding="utf-8")
    assert QgsApplication.processingRegistry().providerById("wit").versionInfo() == card["general"]["version"]


def test_wall_textures_are_a_choice_of_every_texturing_algorithm(loaded_plugin):
    """FACADES on the texture step, the chain and the tiled run: the core's choices in order, generated by default."""
    from wit_citymodel.processing_provider.shared_parameters import FACADE_OPTIONS
    from wit_citymodel.wit_plugin.texture.config import FACADE_CHOICES, TextureConfig

    assert FACADE_CHOICES == ("none", "generated") and len(FACADE_OPTIONS) == len(FACADE_CHOICES)
    assert FACADE_OPTIONS[0].startswith("None") and FACADE_OPTIONS[1].startswith("Generated")
    for algorithm_id in ("wit:wittexture", "wit:citymodel", "wit:citymodeltiles"):
        parameter = QgsApplication.processingRegistry().algorithmById(algorithm_id).parameterDefinition("FACADES")
        assert parameter is not None, algorithm_id
        assert parameter.options() == list(FACADE_OPTIONS)
        assert FACADE_CHOICES[parameter.defaultValue()] == TextureConfig.facades == "generated"
