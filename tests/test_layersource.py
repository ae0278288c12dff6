"""A layer source (``infra.io.layersource.LayerSource``) read from and written in QGIS's own form."""
from __future__ import annotations

from pathlib import Path

import pytest

from wit_plugin.infra.io.fileio import source_file
from wit_plugin.infra.io.layersource import LayerSource


@pytest.mark.parametrize(("text", "source"), [
    ("/data/prepared.gpkg|layername=buildings", LayerSource("/data/prepared.gpkg", "buildings")),
    ("/data/prepared.gpkg|layerid=2", LayerSource("/data/prepared.gpkg", index=2)),
    ("/data/buildings.shp", LayerSource("/data/buildings.shp")),
])
def test_a_source_is_read_and_written_back_in_the_qgis_form(text, source):
    assert LayerSource.parse(text) == source and str(source) == text


def test_options_other_than_the_layer_are_left_out_and_a_name_wins_over_an_index():
    source = LayerSource.parse("/d/a.gpkg|layerid=0|subset=\"x\" = 1|layername=roads")
    assert source == LayerSource("/d/a.gpkg", "roads", 0) and str(source) == "/d/a.gpkg|layername=roads"
    assert LayerSource.parse("/d/a.gpkg|layername=|layerid=x") == LayerSource("/d/a.gpkg")


def test_a_parsed_source_and_a_path_pass_through():
    source = LayerSource("/d/a.gpkg", "roads")
    assert LayerSource.parse(source) is source
    assert LayerSource.parse(Path("/d/b.shp")) == LayerSource("/d/b.shp")
    assert source.file == Path("/d/a.gpkg") == source_file(source) == source_file(str(source))
