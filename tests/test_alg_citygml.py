"""wit:validatecitygml through Processing: result values batch users read, reports, bad input."""
from __future__ import annotations

import shutil

import pytest
from qgis.core import QgsProcessingException, QgsVectorLayer


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


def test_schema_folder_without_schemas_is_a_clear_error(tmp_path, shared_dir, run_algorithm):
    shutil.copy(shared_dir / "schemas" / "examples" / "LocalCRS_CityGML3.gml", tmp_path / "a.gml")
    with pytest.raises(QgsProcessingException, match="does not contain citygml3-all.xsd"):
        run_algorithm("wit:validatecitygml", {
            "INPUT": [str(tmp_path / "a.gml")], "SCHEMA_DIR": str(tmp_path), "OUTPUT": str(tmp_path / "r.html")})
