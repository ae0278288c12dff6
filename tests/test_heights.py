"""wit_plugin.buildings.heights: height rules for the common real building layers, and their order."""
from __future__ import annotations

import pytest

from wit_plugin.buildings.heights import FIELD, FLOORS, HeightOptions, building_height, parse_height, recognise
from wit_plugin.infra.errors import InputError

# field lists as the real downloads have them (abridged)
JUSO = ["BD_MGT_SN", "BUL_MAN_NO", "SIG_CD", "GRO_FLO_CO", "UND_FLO_CO", "BULD_NM"]
NGII = ["UFID", "BPRP_SE", "BULD_SE", "BULD_NM", "BFLR_CO", "PNU_NO"]
AL_D010 = [f"A{k}" for k in range(29)]
AL_D010_2022 = [f"A{k}" for k in range(23)]  # the 2022 national files stop at A22: no floor fields
OSM = ["osm_id", "building", "name", "height", "building:levels", "roof:shape"]
OSM_LEVELS_ONLY = ["osm_id", "building", "building_levels"]


def _rule(fields, **options):
    return HeightOptions(**options).rule_for(fields)


def _height(rule, attributes):
    value, source = building_height(attributes, rule)
    return round(value, 3), rule.label(source)


def test_road_name_address_layer_uses_floors_and_basement():
    rule = _rule(JUSO)
    assert [(s.kind, s.name) for s in rule.sources] == [(FLOORS, "GRO_FLO_CO")]
    assert (rule.floors_field, rule.basement_field) == ("GRO_FLO_CO", "UND_FLO_CO")
    assert _height(rule, {"GRO_FLO_CO": 7}) == (21.0, "GRO_FLO_CO × 3 m")
    assert _height(rule, {"GRO_FLO_CO": 0}) == (3.0, "default 3 m")


def test_ngii_digital_map_building_layer_uses_bflr_co():
    rule = _rule(NGII, storey_height=3.3)
    assert recognise(NGII).label == "NGII digital map buildings (N3A_B0010000)"
    assert _height(rule, {"BFLR_CO": "12"}) == (39.6, "BFLR_CO × 3.3 m")
    assert rule.floors_field == "BFLR_CO"


@pytest.mark.parametrize("fields", [["UFID", "명칭", "구분", "종류", "용도", "주기", "층수", "측량방법"],
                                    ["층수", "용도"]])
def test_ngii_digital_map_buildings_as_shipped_use_their_korean_floor_field(fields):
    """N3A_B0010000 as NGII ships it: Korean field names (층수 = floors above ground)."""
    rule = _rule(fields, storey_height=3.0)
    assert recognise(fields).label == "NGII digital map buildings (N3A_B0010000, Korean field names)"
    assert [(s.kind, s.name, s.layer) for s in rule.sources] == [
        (FLOORS, "층수", "NGII digital map buildings (N3A_B0010000, Korean field names)")]
    assert _height(rule, {"층수": 4}) == (12.0, "층수 × 3 m")
    assert _height(rule, {"층수": None}) == (3.0, "default 3 m")
    assert rule.floors_field == "층수"


def test_building_integrated_information_prefers_measured_height_then_floors():
    rule = _rule(AL_D010)
    assert [(s.kind, s.name) for s in rule.sources] == [(FIELD, "A16"), (FLOORS, "A26")]
    assert (rule.floors_field, rule.basement_field) == ("A26", "A27")
    assert _height(rule, {"A16": 45.2, "A26": 12}) == (45.2, "A16 (m)")
    assert _height(rule, {"A16": 0.0, "A26": 12}) == (36.0, "A26 × 3 m")
    assert [(s.kind, s.name) for s in _rule(AL_D010_2022).sources] == [(FIELD, "A16")]


def test_openstreetmap_height_with_units_then_levels():
    rule = _rule(OSM)
    assert [(s.kind, s.name) for s in rule.sources] == [(FIELD, "height"), (FLOORS, "building:levels")]
    assert "OpenStreetMap" in rule.describe()
    assert _height(rule, {"height": "23.5"}) == (23.5, "height (m)")
    assert _height(rule, {"height": "40 ft", "building:levels": "4"}) == (12.192, "height (m)")
    assert _height(rule, {"height": "tall", "building:levels": "4"}) == (12.0, "building:levels × 3 m")
    assert _height(rule, {"height": None, "building:levels": None}) == (3.0, "default 3 m")
    assert [(s.kind, s.name) for s in _rule(OSM_LEVELS_ONLY).sources] == [(FLOORS, "building_levels")]


def test_korean_named_fields():
    rule = _rule(["건물명", "높이", "지상층수", "지하층수"])
    assert _height(rule, {"높이": 30}) == (30.0, "높이 (m)")
    assert _height(rule, {"지상층수": 5}) == (15.0, "지상층수 × 3 m")


def test_user_choice_replaces_recognition_but_floors_of_juso_stay_first():
    rule = _rule(OSM, height_field="HEIGHT")  # case-insensitive lookup, the layer's spelling is used
    assert [(s.kind, s.name) for s in rule.sources] == [(FIELD, "height")]
    juso = _rule(JUSO + ["H_M"], height_field="H_M")
    assert [s.name for s in juso.sources] == ["GRO_FLO_CO", "H_M"]  # the national layer's floor count first
    with pytest.raises(InputError, match="height field 'HGT' is not in the building layer"):
        _rule(OSM, height_field="HGT")
    with pytest.raises(InputError, match="must be positive"):
        _rule(OSM, storey_height=0)


def test_unknown_layer_gets_the_default_only():
    rule = _rule(["id", "name"])
    assert rule.sources == [] and rule.describe() == "default 3 m"


@pytest.mark.parametrize("value, metres", [
    (12, 12.0), ("12", 12.0), ("12.5 m", 12.5), ("12,5", 12.5), ("7 metres", 7.0), ("10ft", 3.048), ("10'", 3.048),
    ("0", None), (-3, None), ("abc", None), ("", None), (None, None), (float("nan"), None), (float("inf"), None),
    ("1e999", None)])
def test_parse_height(value, metres):
    result = parse_height(value)
    assert (result is None and metres is None) or result == pytest.approx(metres)
