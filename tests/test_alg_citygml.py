"""wit:validatecitygml through Processing: result values batch users read, reports, bad input."""
from __future__ import annotations

import csv
import os
import shutil
from pathlib import Path

import pytest
from qgis.core import QgsProcessingException, QgsVectorLayer

pytestmark = pytest.mark.qgis_facing


def test_validate_reports_table13_rows_and_result_values(tmp_path, shared_dir, run_algorithm):
    examples = shared_dir / "schemas" / "examples"
    files = [str(examples / "Building_LOD1-EPSG25832.gml"), str(examples / "INVALID_handmade_LOD1_4_errors.gml")]
    result = run_algorithm("wit:validatecitygml", {
        "INPUT": files, "SCHEMA_DIR": str(shared_dir / "schemas"),
        "OUTPUT": str(tmp_path / "report.html"), "OUTPUT_CSV": str(tmp_path / "report.csv"),
        "OUTPUT_TABLE": str(tmp_path / "table.gpkg")})
    assert result["VALID"] is False
    assert result["ERROR_COUNT"] >= 4
    assert result["SCHEMA_SOURCE"] == "configured folder"
    table = QgsVectorLayer(result["OUTPUT_TABLE"], "t", "ogr")
    rows = {f["file"].rsplit("/", 1)[-1]: (f["status"], f["errors"]) for f in table.getFeatures()}
    assert rows["Building_LOD1-EPSG25832.gml"] == ("Success", 0)
    assert rows["INVALID_handmade_LOD1_4_errors.gml"][0] == "Fail"
    html = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert "posLst" in html and "INVALID_handmade_LOD1_4_errors.gml" in html
    assert (tmp_path / "report.csv").read_text(encoding="utf-8-sig").count("\n") >= 5


def test_all_valid_gives_valid_true(tmp_path, shared_dir, run_algorithm):
    result = run_algorithm("wit:validatecitygml", {
        "INPUT": [str(shared_dir / "schemas" / "examples" / "LocalCRS_CityGML3.gml")],
        "SCHEMA_DIR": str(shared_dir / "schemas"), "OUTPUT": str(tmp_path / "r.html")})
    assert result["VALID"] is True and result["ERROR_COUNT"] == 0


def test_without_an_html_report_one_is_written_to_a_temporary_file(tmp_path, shared_dir, run_algorithm):
    source = tmp_path / "LocalCRS_CityGML3.gml"
    shutil.copy(shared_dir / "schemas" / "examples" / source.name, source)
    result = run_algorithm("wit:validatecitygml", {"INPUT": [str(source)]})
    report = Path(result["OUTPUT"])
    assert result["VALID"] is True and report.parent != tmp_path and report.name == "validation_report.html"
    assert "1 of 1 file(s) valid" in report.read_text(encoding="utf-8") and os.listdir(tmp_path) == [source.name]


def test_schema_folder_without_schemas_is_a_clear_error(tmp_path, shared_dir, run_algorithm):
    shutil.copy(shared_dir / "schemas" / "examples" / "LocalCRS_CityGML3.gml", tmp_path / "a.gml")
    with pytest.raises(QgsProcessingException, match="does not contain citygml3-all.xsd"):
        run_algorithm("wit:validatecitygml", {
            "INPUT": [str(tmp_path / "a.gml")], "SCHEMA_DIR": str(tmp_path), "OUTPUT": str(tmp_path / "r.html")})


def _bad_files(shared_dir) -> dict[str, tuple[bytes, str]]:
    """File contents that are no CityGML 3.0 at all, and the one message each gets."""
    example = (shared_dir / "schemas" / "examples" / "LocalCRS_CityGML3.gml").read_bytes()
    return {
        "empty": (b"", "The file is empty (0 bytes)"),
        "blank": (b" \n\n", "only white space"),
        "zip": (b"PK\x03\x04\x14\x00", "not XML: it starts with 'PK\\x03\\x04' (a ZIP archive"),
        "cityjson": (b'{"type": "CityJSON", "version": "2.0"}', "not XML: it starts with '{\"ty' (JSON"),
        "kml": (b'<?xml version="1.0"?>\n<kml xmlns="http://www.opengis.net/kml/2.2"><Document/></kml>\n',
                "not CityGML 3.0: its root element is kml in namespace http://www.opengis.net/kml/2.2"),
        "citygml2": ((shared_dir / "data" / "citygml2_sig3d_building_examples" / "Building_LOD1-EPSG25832.gml")
                     .read_bytes(), "The file is CityGML 2.0"),
        "truncated": (example[:5000], "The file is truncated: it ends at line 62 inside gml:EngineeringDatum"),
    }


@pytest.mark.parametrize("case", ["empty", "blank", "zip", "cityjson", "kml", "citygml2", "truncated"])
def test_what_is_not_citygml_3_gets_one_message_naming_it(case, tmp_path, shared_dir, run_algorithm):
    content, words = _bad_files(shared_dir)[case]
    path = tmp_path / "in" / f"{case}.gml"
    path.parent.mkdir()
    path.write_bytes(content)
    result = run_algorithm("wit:validatecitygml", {
        "INPUT": [str(path)], "OUTPUT": str(tmp_path / "out" / "report.html"),
        "OUTPUT_CSV": str(tmp_path / "out" / "report.csv")})
    assert result["VALID"] is False and result["ERROR_COUNT"] == 1
    [row] = list(csv.DictReader((tmp_path / "out" / "report.csv").open(encoding="utf-8-sig")))
    assert (row["status"], row["check"], row["severity"]) == ("Fail", "xml", "error")
    assert words in row["message"], row["message"]
    assert path.read_bytes() == content and os.listdir(path.parent) == [path.name]  # input untouched, nothing beside it
    assert sorted(os.listdir(tmp_path / "out")) == ["report.csv", "report.html"]  # no temporary left


def test_unreadable_file_stops_the_run_before_any_output(tmp_path, shared_dir, run_algorithm, monkeypatch):
    import sys

    good = tmp_path / "in" / "good.gml"
    good.parent.mkdir()
    shutil.copy(shared_dir / "schemas" / "examples" / "LocalCRS_CityGML3.gml", good)
    locked = tmp_path / "in" / "locked.gml"
    locked.write_bytes(good.read_bytes())
    locked.chmod(0)
    if os.access(locked, os.R_OK):  # root reads anything: make the file refuse as a locked share would
        real_open = open

        def refusing_open(file, *args, **kwargs):
            if str(file) == str(locked):
                raise PermissionError(13, "Permission denied", str(file))
            return real_open(file, *args, **kwargs)
        run_algorithm("wit:validatecitygml", {"INPUT": [str(good)], "OUTPUT": str(tmp_path / "warm.html")})
        for name, module in list(sys.modules.items()):  # the core as the plugin imported it, and as tests do
            if name.endswith("wit_plugin.citygml.validate"):
                monkeypatch.setattr(module, "open", refusing_open, raising=False)
    before = {p.name: p.read_bytes() for p in (good,)}
    with pytest.raises(QgsProcessingException, match=r"locked\.gml cannot be read: Permission denied"):
        run_algorithm("wit:validatecitygml", {
            "INPUT": [str(good), str(locked)], "OUTPUT": str(tmp_path / "out" / "report.html"),
            "OUTPUT_CSV": str(tmp_path / "out" / "report.csv")})
    locked.chmod(0o644)
    assert not (tmp_path / "out").exists()
    assert {p.name: p.read_bytes() for p in (good,)} == before and locked.read_bytes() == before["good.gml"]
    assert sorted(os.listdir(good.parent)) == ["good.gml", "locked.gml"]
