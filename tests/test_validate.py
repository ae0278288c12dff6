"""wit:validatecitygml core: XSD + geometry/reference/texture checks, schema lookup, reports."""
from __future__ import annotations

import csv
import functools
import http.server
import re
import shutil
import subprocess
import threading
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

import numpy as np
import pyproj
import pytest

from wit_plugin.citygml import reader as streaming
from wit_plugin.citygml import schemas, validate
from wit_plugin.citygml.validation import ids as id_store
from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback

DATA = Path(__file__).parent / "data" / "citygml"
VALID_EXAMPLES = ["Building_LOD1-EPSG25832.gml", "Building_LOD2-EPSG25832.gml", "LocalCRS_CityGML3.gml",
                  "Building_CityGML3.0_LOD2_with_several_attributes.gml",
                  "handmade_LOD1_textured_building_TIN_group.gml"]


@pytest.fixture(scope="session")
def schema_dir(shared_dir: Path) -> Path:
    return shared_dir / "schemas"


def _with_texture(src: Path, tmp_path: Path) -> Path:
    """Copy a file beside the texture image it references (textures/tile_1.jpg)."""
    (tmp_path / "textures").mkdir(exist_ok=True)
    (tmp_path / "textures" / "tile_1.jpg").write_bytes(b"\xff\xd8\xff\xd9")
    return Path(shutil.copy(src, tmp_path / src.name))


def _errors(report: validate.FileReport) -> list[validate.Issue]:
    return [i for i in report.issues if i.severity == "error"]


def _one(path: Path, schema_dir: Path, **kw) -> validate.FileReport:
    return validate.validate_files([str(path)], schema_dir, **kw)[0]


def _small_parts(monkeypatch, chunk: int = 256, min_part: int = 1) -> None:
    """Feed the parser ``chunk`` bytes at a time and hand out any finished child: many tiny parts."""
    monkeypatch.setattr(streaming, "CHUNK_BYTES", chunk)
    monkeypatch.setattr(streaming, "MIN_PART", min_part)


@pytest.mark.parametrize("name", VALID_EXAMPLES)
def test_valid_examples_have_no_errors(name, schema_dir, tmp_path):
    path = _with_texture(schema_dir / "examples" / name, tmp_path)
    report = _one(path, schema_dir)
    assert _errors(report) == []
    assert report.valid and report.status == "Success"


def test_only_warning_on_valid_examples_is_2d_address_point(schema_dir, tmp_path):
    reports = validate.validate_files(
        [str(_with_texture(schema_dir / "examples" / n, tmp_path)) for n in VALID_EXAMPLES], schema_dir)
    warnings = [i for r in reports for i in r.issues]
    assert [(Path(w.file).name, w.check, w.line) for w in warnings] == [
        ("Building_CityGML3.0_LOD2_with_several_attributes.gml", "dimension", 294)]
    assert "EPSG::4326" in warnings[0].message


@pytest.mark.skipif(shutil.which("xmllint") is None, reason="xmllint not installed")
@pytest.mark.parametrize("small", [False, True])  # True: every finished element is handed out on its own
@pytest.mark.parametrize("name", VALID_EXAMPLES + ["INVALID_handmade_LOD1_4_errors.gml"])
def test_xsd_verdict_agrees_with_xmllint(name, small, schema_dir, tmp_path, monkeypatch):
    if small:
        _small_parts(monkeypatch)
    path = schema_dir / "examples" / name
    run = subprocess.run(["xmllint", "--nonet", "--noout", "--schema", str(schema_dir / "citygml3-all.xsd"), str(path)],
                         capture_output=True, text=True, timeout=60)
    xmllint_lines = {int(line.split(":")[1]) for line in run.stderr.splitlines() if "Schemas validity error" in line}
    ours = {i.line for i in _one(path, schema_dir).issues if i.check == "xsd"}
    assert (run.returncode == 0) == (not ours)
    assert ours == xmllint_lines


def test_missing_texture_image_is_an_error(schema_dir):
    report = _one(schema_dir / "examples" / "handmade_LOD1_textured_building_TIN_group.gml", schema_dir)
    assert not report.valid
    [issue] = report.issues
    assert (issue.check, issue.line, issue.gml_id) == ("texture-image", 159, "tex_tile_1")
    assert "textures/tile_1.jpg" in issue.message and "does not exist" in issue.message
    assert report.details == "texture-image: 1 error"


def test_invalid_example_reports_all_four_errors_with_lines(schema_dir, tmp_path):
    report = _one(_with_texture(schema_dir / "examples" / "INVALID_handmade_LOD1_4_errors.gml", tmp_path), schema_dir)
    assert report.status == "Fail"
    xsd = {i.line: i for i in report.issues if i.check == "xsd"}
    assert sorted(xsd) == [63, 117, 126, 175]
    assert "gml:posLst" in xsd[63].message and "did you mean gml:posList" in xsd[63].message
    assert "storeysAboveGround" in xsd[117].message and "'one'" in xsd[117].message
    assert "missing the required element dem:lod" in xsd[126].message and xsd[126].gml_id == "tin_1"
    assert "'abc'" in xsd[175].message
    [tex] = [i for i in report.issues if i.check == "texture-coordinates"]
    assert tex.line == 175 and "'abc'" in tex.message
    assert report.details == "xsd: 4 errors; texture-coordinates: 1 error"


FAULTS = {  # fixture -> (check, line, gml:id, words in the message)
    "duplicate_id": ("duplicate-id", 64, "bldg_1_wall_s", "used more than once"),
    "unresolved_target": ("reference", 156, None, "app:target '#bldg_1_roof_missing' points to no gml:id"),
    "unresolved_href": ("reference", 141, None, "xlink:href of grp:groupMember '#bldg_99'"),
    "open_solid": ("solid-closed", 33, "bldg_1_lod1", "is used by only one face: the shell has a hole"),
    "inverted_solid": ("solid-orientation", 33, "bldg_1_lod1", "inside out"),
    "flipped_face": ("solid-orientation", 33, "bldg_1_lod1", "face(s) bldg_1_roof are oriented opposite"),
    "nonplanar_face": ("planarity", 46, "bldg_1_roof", "0.125 m from the face's plane"),
    "bowtie_face": ("self-intersection", 46, "bldg_1_roof", "intersects itself"),
    "degenerate_triangle": ("degenerate-triangle", 121, "tin_1_t1", "degenerate"),
    "pos_2d": ("dimension", 117, "tin_1_t0", 'srsDimension="2"'),
    "texcoord_count": ("texture-coordinates", 159, "tex_tile_1", "4 texture coordinate pairs for ring #bldg_1_roof_r, "
                       "which has 5 points"),
    "texcoord_nan": ("texture-coordinates", 159, "tex_tile_1", "contain 'NaN'"),
    "unknown_ade": ("ade", 105, None,
                    "uses ADE namespace http://example.org/ade/energy/1.0 whose schema is not available"),
}


@pytest.mark.parametrize("name", sorted(FAULTS))
def test_each_fault_is_detected(name, schema_dir, tmp_path):
    check, line, gml_id, words = FAULTS[name]
    report = _one(_with_texture(DATA / f"{name}.gml", tmp_path), schema_dir)
    assert not report.valid
    hits = [i for i in _errors(report) if i.check == check]
    assert [(i.line, i.gml_id) for i in hits] == [(line, gml_id)]
    assert words.lower() in hits[0].message.lower()
    others = {i.check for i in _errors(report)} - {check}
    expected_side_effects = {"bowtie_face": {"solid-closed"}}
    assert others == expected_side_effects.get(name, set())


# -- geographic CRSs: tolerances in metres whatever the CRS's units --------------------------------------
GEOGRAPHIC = {  # srsName -> the axis order the file is written in
    "EPSG:4326": "lon lat",  # the short form: longitude first, as GIS software writes it
    "urn:ogc:def:crs:EPSG::4326": "lat lon",  # the EPSG axis order
    "http://www.opengis.net/def/crs/EPSG/0/4979": "lat lon",  # WGS 84 with ellipsoidal heights
    "http://www.opengis.net/def/crs/EPSG/0/6697": "lat lon",  # JGD2011 + JGD2011 height, as Japan's PLATEAU
}
_POSITION_TEXT = re.compile(r"(<gml:(posList|pos|lowerCorner|upperCorner)\b[^>]*>)([^<]*)(</gml:\2>)")


def _geographic(src: Path, dest: Path, srs_name: str, order: str, lon_shift: float = 0.0) -> Path:
    """``src`` (ETRS89 / UTM 32N) with every position in degrees, heights kept, in ``order``; lines unchanged.

    ``lon_shift`` moves the model east by that many degrees (same shapes, other longitudes).
    """
    to_degrees = pyproj.Transformer.from_crs(25832, 4258, always_xy=True)

    def convert(match: re.Match) -> str:
        values = np.array(match.group(3).split(), dtype=float).reshape(-1, 3)
        lon, lat = to_degrees.transform(values[:, 0], values[:, 1])
        first, second = (lon + lon_shift, lat) if order == "lon lat" else (lat, lon + lon_shift)
        text = " ".join(f"{a:.10f} {b:.10f} {h:.3f}" for a, b, h in zip(first, second, values[:, 2]))
        return match.group(1) + text + "\n" * match.group(3).count("\n") + match.group(4)

    text = _POSITION_TEXT.sub(convert, src.read_text(encoding="utf-8"))
    dest.parent.mkdir(exist_ok=True)
    dest.write_text(re.sub(r'srsName="[^"]*"', f'srsName="{srs_name}"', text), encoding="utf-8")
    return dest


@pytest.mark.parametrize("srs_name", sorted(GEOGRAPHIC))
@pytest.mark.parametrize("name", ["Building_LOD1-EPSG25832.gml", "Building_LOD2-EPSG25832.gml",
                                  "handmade_LOD1_textured_building_TIN_group.gml"])
def test_examples_in_degrees_are_valid(name, srs_name, schema_dir, tmp_path):
    """A closed solid is closed and a 10 m triangle not degenerate in degrees too (0.001 was 100 m there)."""
    path = _with_texture(_geographic(schema_dir / "examples" / name, tmp_path / "degrees" / name, srs_name,
                                     GEOGRAPHIC[srs_name]), tmp_path)
    report = _one(path, schema_dir)
    assert report.issues == [] and report.valid


GEOGRAPHIC_FAULTS = ["open_solid", "inverted_solid", "flipped_face", "nonplanar_face", "bowtie_face",
                     "degenerate_triangle"]


@pytest.mark.parametrize("srs_name", ["EPSG:4326", "http://www.opengis.net/def/crs/EPSG/0/6697"])
@pytest.mark.parametrize("name", GEOGRAPHIC_FAULTS)
def test_faults_in_degrees_are_found(name, srs_name, schema_dir, tmp_path):
    path = _with_texture(_geographic(DATA / f"{name}.gml", tmp_path / "degrees" / f"{name}.gml", srs_name,
                                     GEOGRAPHIC[srs_name]), tmp_path)
    if name == "degenerate_triangle":  # collinear in metres is not quite collinear in degrees: make it so there
        text = path.read_text(encoding="utf-8")
        ring = re.search(r'gml:id="tin_1_t1">\s*<gml:posList[^>]*>([^<]*)<', text).group(1)
        corners = np.array(ring.split(), dtype=float).reshape(-1, 3)
        corners[1] = (corners[0] + corners[2]) / 2
        path.write_text(text.replace(ring, " ".join(map(repr, corners.ravel().tolist()))), encoding="utf-8")
    check, line, gml_id, words = FAULTS[name]
    report = _one(path, schema_dir)
    assert [(i.line, i.gml_id) for i in _errors(report) if i.check == check] == [(line, gml_id)]
    assert words.lower() in next(i for i in report.issues if i.check == check).message.lower()  # "0.125 m" too


# -- projected CRSs whose EPSG order is northing first (the Korean belts): the srsName's form decides -------
PROJECTED = {  # srsName -> the axis order the file is written in, as each form is read
    "EPSG:5186": "east north",  # the short form: easting first (GDAL's reading; what wit:writecitygml writes)
    "urn:ogc:def:crs:EPSG::5186": "north east",  # EPSG's order for EPSG:5186: X north, Y east
    "http://www.opengis.net/def/crs/EPSG/0/5186": "north east",
}


def _projected(src: Path, dest: Path, srs_name: str, order: str) -> Path:
    """``src`` (ETRS89 / UTM 32N) moved to Korea (EPSG:5186) shape for shape, in ``order``; lines unchanged."""
    def convert(match: re.Match) -> str:
        values = np.array(match.group(3).split(), dtype=float).reshape(-1, 3)
        east, north = values[:, 0] - 458870.0 + 209000.0, values[:, 1] - 5438340.0 + 543100.0
        first, second = (east, north) if order == "east north" else (north, east)
        text = " ".join(f"{a:.3f} {b:.3f} {h:.3f}" for a, b, h in zip(first, second, values[:, 2]))
        return match.group(1) + text + "\n" * match.group(3).count("\n") + match.group(4)

    text = _POSITION_TEXT.sub(convert, src.read_text(encoding="utf-8"))
    dest.parent.mkdir(exist_ok=True)
    dest.write_text(re.sub(r'srsName="[^"]*"', f'srsName="{srs_name}"', text), encoding="utf-8")
    return dest


@pytest.mark.parametrize("srs_name", sorted(PROJECTED))
@pytest.mark.parametrize("name", ["Building_LOD1-EPSG25832.gml", "Building_LOD2-EPSG25832.gml",
                                  "handmade_LOD1_textured_building_TIN_group.gml"])
def test_examples_in_a_northing_first_crs_are_valid_in_each_form(name, srs_name, schema_dir, tmp_path):
    path = _with_texture(_projected(schema_dir / "examples" / name, tmp_path / "korea" / name, srs_name,
                                    PROJECTED[srs_name]), tmp_path)
    report = _one(path, schema_dir)
    assert report.issues == [] and report.valid


@pytest.mark.parametrize("srs_name", ["http://www.opengis.net/def/crs/EPSG/0/5186", "urn:ogc:def:crs:EPSG::5186"])
def test_easting_first_under_a_northing_first_urn_or_url_is_a_mirror_image(srs_name, schema_dir, tmp_path):
    """What wit:writecitygml wrote before (the URL form, easting first): GDAL reads such a file with x and y
    swapped, so every solid is inside out there; the message says how the file reads the other way."""
    name = "Building_LOD1-EPSG25832.gml"
    path = _with_texture(_projected(schema_dir / "examples" / name, tmp_path / "korea" / name, srs_name, "east north"),
                         tmp_path)
    report = _one(path, schema_dir)
    [issue] = _errors(report)
    assert issue.check == "solid-orientation" and "is inside out" in issue.message
    assert (f"unless the coordinates are written easting first: {srs_name} is read northing first, and read the "
            "other way the solid points outwards") in issue.message


def _jefferson_like(path: Path, srs_name: str, order: str, outward: bool) -> Path:
    """An LoD1 building near the Jefferson Building (Washington, DC) in degrees, built the way OGC's
    ``JeffersonBuilding_CityGML3.0_LOD1_with_xAL3_CommonTypes.gml`` builds its solid: the footprint ring,
    counter-clockwise seen from above, as the ground face, the roof its reverse, walls rising along the ring
    — which points every face inwards (``outward`` reverses them all)."""
    lon = np.array([-77.00541, -77.00385, -77.00385, -77.00541, -77.00541])
    lat = np.array([38.88800, 38.88800, 38.88926, 38.88926, 38.88800])  # counter-clockwise, lon/lat
    ring = [(x, y) for x, y in zip(lon, lat)]

    def face(points: list) -> str:
        points = points[::-1] if outward else points
        coords = [(a, b) if order == "lon lat" else (b, a) for a, b, _ in points]
        text = " ".join(f"{a:.7f} {b:.7f} {h:.2f}" for (a, b), (_, _, h) in zip(coords, points))
        return (f"<gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing><gml:posList>{text}</gml:posList>"
                "</gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember>")

    h = 9.31
    faces = [face([(x, y, 0.0) for x, y in ring]), face([(x, y, h) for x, y in ring[::-1]])]
    for (x0, y0), (x1, y1) in zip(ring, ring[1:]):
        faces.append(face([(x0, y0, 0.0), (x0, y0, h), (x1, y1, h), (x1, y1, 0.0), (x0, y0, 0.0)]))
    path.write_text(f"""<?xml version="1.0" encoding="UTF-8"?>
<CityModel xmlns="http://www.opengis.net/citygml/3.0" xmlns:gml="http://www.opengis.net/gml/3.2"
    xmlns:bldg="http://www.opengis.net/citygml/building/3.0">
  <gml:boundedBy><gml:Envelope srsName="{srs_name}" srsDimension="3">
    <gml:lowerCorner>{'-77.00541 38.888 0' if order == 'lon lat' else '38.888 -77.00541 0'}</gml:lowerCorner>
    <gml:upperCorner>{'-77.00385 38.88926 9.31' if order == 'lon lat' else '38.88926 -77.00385 9.31'}</gml:upperCorner>
  </gml:Envelope></gml:boundedBy>
  <cityObjectMember><bldg:Building gml:id="jefferson"><lod1Solid><gml:Solid gml:id="jefferson_solid">
    <gml:exterior><gml:Shell>{''.join(faces)}</gml:Shell></gml:exterior>
  </gml:Solid></lod1Solid></bldg:Building></cityObjectMember>
</CityModel>
""", encoding="utf-8")
    return path


@pytest.mark.parametrize(("srs_name", "order"), [("EPSG:4979", "lon lat"), ("urn:ogc:def:crs:EPSG::4979", "lat lon"),
                                                 ("http://www.opengis.net/def/crs/EPSG/0/4979", "lat lon")])
def test_a_solid_built_as_the_jefferson_example_is_inside_out_in_its_own_axis_order(srs_name, order, schema_dir,
                                                                                   tmp_path):
    """OGC's Jefferson example (srsName "EPSG:4979", longitude first: it lies in Washington, DC) is reported
    inside out: it is, read as it is written (checked by hand: projected to UTM 18N its signed volume is
    −124,799 m³, every face inwards). Only read latitude first — at 77° S — would it point outwards. The
    same construction is inside out in each srsName form read in its own order; reversed, it is valid."""
    inverted = _one(_jefferson_like(tmp_path / "inverted.gml", srs_name, order, outward=False), schema_dir)
    [issue] = _errors(inverted)
    assert issue.check == "solid-orientation" and issue.gml_id == "jefferson_solid"
    volume = float(re.search(r"signed volume (-[\d.]+) m³", issue.message).group(1))
    east = pyproj.Geod(ellps="WGS84").inv(-77.00541, 38.888, -77.00385, 38.888)[2]
    north = pyproj.Geod(ellps="WGS84").inv(-77.00541, 38.888, -77.00541, 38.88926)[2]
    assert volume == pytest.approx(-east * north * 9.31, rel=1e-3)
    other = "latitude first" if order == "lon lat" else "longitude first"
    assert f"unless the coordinates are written {other}" in issue.message
    outward = _one(_jefferson_like(tmp_path / "outward.gml", srs_name, order, outward=True), schema_dir)
    assert outward.valid and _errors(outward) == []


def test_the_3d_tiles_georeference_reads_model_coordinates_easting_first():
    """The 3D Tiles export reads the GeoPackage layers (GIS order, easting first) as the CityGML's
    "EPSG:n" says: Suseo's model coordinates land at Suseo, not at the swapped place."""
    from wit_plugin.tiles3d.geo import Georeference

    ecef = Georeference("EPSG:5186").ecef(np.array([[209020.9, 543132.8, 0.0]]))
    lon, lat, _ = pyproj.Transformer.from_crs("EPSG:4978", "EPSG:4979", always_xy=True).transform(*ecef[0])
    assert (lon, lat) == pytest.approx((127.1020, 37.4876), abs=1e-3)


def test_longitude_first_despite_the_crs_axis_order_is_read_as_written(schema_dir, tmp_path):
    """Korea's longitudes (127°) cannot be latitudes: such a file is read longitude first, with a warning."""
    path = _geographic(schema_dir / "examples" / "Building_LOD1-EPSG25832.gml", tmp_path / "b.gml",
                       "urn:ogc:def:crs:EPSG::4326", "lon lat", lon_shift=118.0)
    [warning] = _one(path, schema_dir).issues
    assert (warning.check, warning.severity) == ("crs", "warning") and "longitude before latitude" in warning.message


def test_unknown_crs_is_read_as_metres_with_a_warning(schema_dir, tmp_path):
    path = tmp_path / "b.gml"
    path.write_text(re.sub(r'srsName="[^"]*"', 'srsName="urn:x-example:crs:site-grid"',
                           (schema_dir / "examples" / "Building_LOD1-EPSG25832.gml").read_text(encoding="utf-8")),
                    encoding="utf-8")
    [warning] = _one(path, schema_dir).issues
    assert (warning.check, warning.severity, warning.line) == ("crs", "warning", None)
    assert "urn:x-example:crs:site-grid" in warning.message and "metres" in warning.message


def test_gml_id_syntax_is_checked(schema_dir, tmp_path):
    path = tmp_path / "badid.gml"
    path.write_text((DATA / "pos_2d.gml").read_text(encoding="utf-8").replace('gml:id="bldg_1_wall_n"',
                                                                            'gml:id="1wall"'), encoding="utf-8")
    [issue] = [i for i in _one(path, schema_dir).issues if i.check == "xsd"]
    assert issue.gml_id == "1wall" and "not a valid XML name" in issue.message


def test_bowtie_with_unequal_lobes_is_located(schema_dir, tmp_path):
    text = (DATA / "bowtie_face.gml").read_text(encoding="utf-8").replace(
        "458875.0 5438355.0 116.0 458875.0 5438350.0 116.0</gml:posList>",
        "458875.0 5438356.0 116.0 458875.0 5438350.0 116.0</gml:posList>", 1)
    path = tmp_path / "bowtie2.gml"
    path.write_text(text, encoding="utf-8")
    [hit] = [i for i in _one(path, schema_dir).issues if i.check == "self-intersection"]
    assert hit.gml_id == "bldg_1_roof" and "Self-intersection" in hit.message
    assert "near (458880.455 5438352.727 116.000)" in hit.message


def test_inverted_solid_reports_negative_volume(schema_dir, tmp_path):
    [issue] = _errors(_one(_with_texture(DATA / "inverted_solid.gml", tmp_path), schema_dir))
    assert "signed volume -200.000 m³" in issue.message


def test_planarity_tolerance_is_a_parameter(schema_dir, tmp_path):
    path = _with_texture(DATA / "nonplanar_face.gml", tmp_path)
    assert not _one(path, schema_dir, planarity_tol=0.1).valid
    assert _one(path, schema_dir, planarity_tol=0.2).valid


def test_xxe_is_harmless(schema_dir, tmp_path):
    path = _with_texture(DATA / "xxe.gml", tmp_path)
    (tmp_path / "secret.txt").write_text("TOPSECRET-42", encoding="utf-8")
    report = _one(path, schema_dir)
    out_csv, out_html = tmp_path / "r.csv", tmp_path / "r.html"
    validate.write_report_csv([report], str(out_csv))
    validate.write_report_html([report], str(out_html))
    everything = repr(report) + out_csv.read_text(encoding="utf-8-sig") + out_html.read_text(encoding="utf-8")
    assert "TOPSECRET" not in everything
    [entity] = [i for i in _errors(report) if i.check == "xml"]
    assert entity.line == 26 and "&xxe;" in entity.message and "not expanded" in entity.message
    assert not [i for i in report.issues if i.check == "xsd"]  # the rest of the file was still validated


def test_entity_bomb_is_refused_unexpanded(schema_dir):
    """A "billion laughs" file (1.3 GB if expanded) is one XML issue, never expanded: libxml2 before 2.15
    calls it an entity reference loop where &g; is used (line 16); 2.15 (Debian sid, QGIS 3.44) stops at its
    amplification limit and reports line 1."""
    from lxml import etree

    [issue] = _one(DATA / "entity_bomb.gml", schema_dir).issues
    if etree.LIBXML_VERSION < (2, 15):
        assert (issue.check, issue.line) == ("xml", 16) and "entity reference loop" in issue.message
    else:
        assert (issue.check, issue.line) == ("xml", 1) and "entity amplification" in issue.message


def test_not_well_formed_file(schema_dir, tmp_path):
    path = tmp_path / "broken.gml"
    path.write_text('<core:CityModel xmlns:core="http://www.opengis.net/citygml/3.0">\n<a>\n</core:CityModel>\n')
    issue, *schema_errors = _one(path, schema_dir).issues
    assert issue.check == "xml" and issue.line == 3 and "Not well-formed" in issue.message
    assert [(i.check, i.line) for i in schema_errors] == [("xsd", 2)]  # <a> is met before the break


def test_many_issues_are_capped(schema_dir, tmp_path):
    text = (DATA / "texcoord_nan.gml").read_text(encoding="utf-8")
    path = tmp_path / "many.gml"
    path.write_text(text.replace("<bldg:storeysAboveGround>1<", "<bldg:storeysAboveGround>x<"), encoding="utf-8")
    report = _one(path, schema_dir, max_issues_per_check=0)
    assert {i.message for i in report.issues} >= {"... and 1 more xsd errors not listed."}


def test_bad_inputs_raise_input_error(schema_dir, tmp_path):
    with pytest.raises(InputError, match="No CityGML files"):
        validate.validate_files([], schema_dir)
    with pytest.raises(InputError, match="does not exist"):
        validate.validate_files([str(tmp_path / "nope.gml")], schema_dir)
    with pytest.raises(InputError, match="citygml3-all.xsd"):
        validate.validate_files([str(DATA / "pos_2d.gml")], tmp_path)


def test_cancel_and_progress(schema_dir, tmp_path):
    class Recorder(Feedback):
        def __init__(self, cancel: bool):
            self.cancel, self.values = cancel, []

        def progress(self, percent: float) -> None:
            self.values.append(percent)

        def is_canceled(self) -> bool:
            return self.cancel

    fb = Recorder(False)
    validate.validate_files([str(DATA / "pos_2d.gml"), str(DATA / "open_solid.gml")], schema_dir, feedback=fb)
    assert fb.values[-1] == pytest.approx(100.0) and fb.values == sorted(fb.values)
    with pytest.raises(CanceledError):
        validate.validate_files([str(DATA / "pos_2d.gml")], schema_dir, feedback=Recorder(True))


def test_reports_csv_and_html(schema_dir, tmp_path):
    reports = validate.validate_files(
        [str(DATA / "unresolved_href.gml"), str(_with_texture(DATA / "open_solid.gml", tmp_path))], schema_dir)
    reports[0].issues.append(validate.Issue(reports[0].file, "xsd", "error", 1, None, "<script>alert(1)</script> & co"))
    csv_path, html_path = tmp_path / "out" / "report.csv", tmp_path / "out" / "report.html"
    validate.write_report_csv(reports, str(csv_path))
    validate.write_report_html(reports, str(html_path))
    rows = list(csv.DictReader(csv_path.open(encoding="utf-8-sig")))
    assert {r["status"] for r in rows} == {"Fail"} and rows[1]["line"] == "141"
    assert [(Path(r["file"]).name, r["check"]) for r in rows] == [
        ("unresolved_href.gml", "texture-image"), ("unresolved_href.gml", "reference"), ("unresolved_href.gml", "xsd"),
        ("open_solid.gml", "solid-closed")]
    page = html_path.read_text(encoding="utf-8")
    assert "<script>alert" not in page and "&lt;script&gt;alert(1)&lt;/script&gt; &amp; co" in page
    assert page.count("<tr class='fail'>") == 2 and "solid-closed: 1 error" in page
    assert not list((tmp_path / "out").glob(".*"))  # atomic: no temporary left behind


# -- schema lookup and one-time download -------------------------------------------------------
def test_find_schema_dir_order(schema_dir, tmp_path):
    assert schemas.find_schema_dir(str(schema_dir), str(tmp_path), False) == (schema_dir, "configured folder")
    with pytest.raises(InputError, match="does not contain citygml3-all.xsd"):
        schemas.find_schema_dir(str(tmp_path), str(tmp_path), True)
    assert schemas.find_schema_dir(None, str(tmp_path), True) == (schemas.EMBEDDED_DIR, "embedded")
    # an install whose embedded copy was removed: cache, else a download
    with pytest.raises(InputError, match="No CityGML 3.0 schemas available: set SCHEMA_DIR"):
        schemas.find_schema_dir(None, str(tmp_path), False, embedded=tmp_path / "gone")
    cached = tmp_path / schemas.CACHE_SUBDIR
    shutil.copytree(schema_dir, cached)
    assert schemas.find_schema_dir(None, str(tmp_path), False, embedded=None) == (cached, "cache")


#: the one comment added to the shipped schemas (NOTICE.md): plugins.qgis.org's secrets scan takes a type name
#: of building.xsd for a Base64 secret
SCAN_COMMENT = b"  <!-- pragma: allowlist secret: a type name, not a secret (WIT City Model: NOTICE.md) -->"


def test_embedded_schemas_are_the_offline_set(schema_dir):
    """The plugin ships every schema file of the offline set, byte for byte but for the scanner's one comment,
    and their notices."""
    def files(root: Path, top: str) -> dict[str, bytes]:
        return {p.relative_to(root).as_posix(): p.read_bytes() for p in (root / top).rglob("*") if p.is_file()}
    for top in ("opengis", "w3"):
        shipped = files(schemas.EMBEDDED_DIR, top)
        if top == "opengis":
            building = "opengis/citygml/3.0/building.xsd"
            assert shipped[building].count(SCAN_COMMENT) == 1
            shipped[building] = shipped[building].replace(SCAN_COMMENT, b"")
        assert shipped == files(schema_dir, top)
    assert (schemas.EMBEDDED_DIR / "citygml3-all.xsd").read_bytes() == (schema_dir / "citygml3-all.xsd").read_bytes()
    notice = (schemas.EMBEDDED_DIR / "NOTICE.md").read_text(encoding="utf-8")
    assert "OASIS_COPYRIGHT_NOTICE.txt" in notice and "w3.org/copyright" in notice


def test_embedded_schemas_validate_without_network(schema_dir, tmp_path, monkeypatch):
    """No folder configured, no network: the shipped copy gives the same verdicts as the offline set."""
    def no_network(*args, **kwargs):
        raise AssertionError("the network was used")
    monkeypatch.setattr(schemas.urllib.request, "urlopen", no_network)
    folder, source = schemas.find_schema_dir(None, str(tmp_path / "cache"), True)
    assert source == "embedded" and not (tmp_path / "cache").exists()
    reports = validate.validate_files([str(schema_dir / "examples" / "INVALID_handmade_LOD1_4_errors.gml"),
                                       str(schema_dir / "examples" / "Building_LOD2-EPSG25832.gml")], folder)
    assert sorted(i.line for i in reports[0].issues if i.check == "xsd") == [63, 117, 126, 175]
    assert reports[1].valid


def _public_mirror(schema_dir: Path, root: Path) -> None:
    """Lay the shared schemas out under their public URLs (host/path), using its catalog.xml."""
    cat = ET.parse(schema_dir / "catalog.xml").getroot()
    ns = "{urn:oasis:names:tc:entity:xmlns:xml:catalog}"
    mapping = {e.get("systemId"): e.get("uri") for e in cat.iter(f"{ns}system")}
    for e in cat.iter(f"{ns}rewriteSystem"):
        prefix, local = e.get("systemIdStartString"), e.get("rewritePrefix")
        for f in (schema_dir / local).rglob("*"):
            if f.is_file():
                mapping[prefix + f.relative_to(schema_dir / local).as_posix()] = (Path(local) / f.relative_to(
                    schema_dir / local)).as_posix()
    for url, local in mapping.items():
        if url.startswith("http://") and not url.startswith("http://docs.oasis"):
            out = root / url[len("http://"):]
            out.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(schema_dir / local, out)


@pytest.fixture()
def mirror_server(schema_dir, tmp_path):
    root = tmp_path / "www"
    _public_mirror(schema_dir, root)
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(root))
    handler.log_message = lambda *a: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/", root
    server.shutdown()
    server.server_close()


def test_download_once_into_cache_then_validate_offline(mirror_server, schema_dir, tmp_path):
    base_url, www = mirror_server
    cache = tmp_path / "cache"
    folder, source = schemas.find_schema_dir(None, str(cache), True, base_url=base_url, embedded=None)
    assert (folder, source) == (cache / schemas.CACHE_SUBDIR, "downloaded")
    assert (folder / "opengis/citygml/3.0/building.xsd").is_file() and (folder / "w3/1999/xlink.xsd").is_file()
    assert (folder / "opengis/iso/19139/20070417/gmd/gmd.xsd").is_file()
    every_location = [loc for f in folder.rglob("*.xsd") for loc in
                      (e.get("schemaLocation") for e in ET.parse(f).getroot().iter() if e.get("schemaLocation"))]
    assert every_location and not [loc for loc in every_location if "://" in loc]  # no network at validation time
    shutil.rmtree(www)  # the server is gone: the second call must use the cache
    assert schemas.find_schema_dir(None, str(cache), True, base_url=base_url, embedded=None) == (folder, "cache")
    reports = validate.validate_files([str(schema_dir / "examples" / "INVALID_handmade_LOD1_4_errors.gml"),
                                       str(schema_dir / "examples" / "Building_LOD2-EPSG25832.gml")], folder)
    assert sorted(i.line for i in reports[0].issues if i.check == "xsd") == [63, 117, 126, 175]
    assert reports[1].valid


@pytest.mark.parametrize("base_url, message", [
    ("http://127.0.0.1:9/", "Could not download the CityGML schema"),  # nothing listens on the discard port
    ("file:///tmp/schemas/", "downloaded over http"),  # no other scheme is opened (file:, ftp:, custom ones)
])
def test_failed_download_leaves_no_cache(tmp_path, base_url, message):
    with pytest.raises(InputError, match=message):
        schemas.find_schema_dir(None, str(tmp_path), True, base_url=base_url, embedded=None)
    assert not (tmp_path / schemas.CACHE_SUBDIR).exists() and not list(tmp_path.glob(".wit-schemas-*"))


@pytest.mark.qgis_facing  # what SpatiaLite does inside QGIS; crashed QGIS 3.44 (libxml2 2.15)
@pytest.mark.parametrize("streaming", [True, False], ids=["libxml2-streaming", "lxml-fallback"])
def test_validation_survives_libxml2_cleanup_between_runs(schema_dir, monkeypatch, streaming):
    """SpatiaLite calls libxml2's xmlCleanupParser when a connection closes (GDAL and QGIS open them):
    that frees the schema built-in types, so no compiled schema may be kept from one validation to the
    next (a kept one reported "Internal error" for every element, or segfaulted QGIS)."""
    from wit_plugin.citygml.validation import xsd

    if not streaming:
        monkeypatch.setattr(xsd, "_compiled", lambda folder: None)
    example = schema_dir / "examples" / "Building_LOD2-EPSG25832.gml"
    assert _one(example, schema_dir).valid
    xsd._libxml2().xmlCleanupParser()
    report = _one(example, schema_dir)
    assert report.valid, [i.message for i in report.issues][:5]
    invalid = _one(schema_dir / "examples" / "INVALID_handmade_LOD1_4_errors.gml", schema_dir)
    assert len([i for i in invalid.issues if i.check == "xsd" and i.severity == "error"]) == 4


# -- streaming: long runs of triangles and texture entries, ids as hashes -------------------------
_NS = ('xmlns:core="http://www.opengis.net/citygml/3.0" xmlns:gml="http://www.opengis.net/gml/3.2" '
       'xmlns:dem="http://www.opengis.net/citygml/relief/3.0" '
       'xmlns:app="http://www.opengis.net/citygml/appearance/3.0" '
       'xmlns:grp="http://www.opengis.net/citygml/cityobjectgroup/3.0" xmlns:xlink="http://www.w3.org/1999/xlink"')
_FOO = ' foo="1"'  # an attribute no schema allows
_UV = "0 0 1 0 0 1 0 0"  # 4 pairs: one per point of a triangle's ring (closing point included)


def _long_runs(path: Path, n: int, pad: int) -> list[tuple[str, int, str | None, str]]:
    """Write a model whose TIN has ``n`` triangles, its texture ``n`` associations plus one TIN association
    with ``n`` entries, one element per line, ``pad`` empty lines before the appearance (so its lines pass
    65,535); faults sit on the first, middle and last element of each run.

    Returns the expected issues as (check, line, gml_id, words of the message).
    """
    text: list[str] = []
    expected: list[tuple[str, int, str | None, str]] = []
    lines = [0]  # lines written so far

    def put(line: str) -> int:
        """Write ``line`` (it may hold line breaks); return the number of the line where it starts."""
        text.append(line)
        lines[0] += line.count("\n") + 1
        return lines[0] - line.count("\n")

    faulty = {0, n // 2, n - 1}
    put('<?xml version="1.0" encoding="UTF-8"?>')
    put(f'<core:CityModel {_NS}>')
    put('<gml:boundedBy><gml:Envelope srsName="EPSG:25832" srsDimension="3"><gml:lowerCorner>0 0 0</gml:lowerCorner>'
        '<gml:upperCorner>100 1 10</gml:upperCorner></gml:Envelope></gml:boundedBy>')
    put('<core:cityObjectMember><grp:CityObjectGroup gml:id="grp">')
    put('<grp:groupMember><grp:Role><grp:role>member</grp:role><grp:groupMember xlink:href="#relief"/></grp:Role>'
        '</grp:groupMember>')  # refers forward: resolved at the end
    line = put('<grp:groupMember><grp:Role><grp:role>member</grp:role><grp:groupMember xlink:href="#ghost"/>'
               '</grp:Role></grp:groupMember>')
    expected.append(("reference", line, None, "xlink:href of grp:groupMember '#ghost' points to no gml:id"))
    put('</grp:CityObjectGroup></core:cityObjectMember>')
    put('<core:cityObjectMember><dem:ReliefFeature gml:id="relief"><dem:lod>1</dem:lod><dem:reliefComponent>'
        '<dem:TINRelief gml:id="tin"><dem:lod>1</dem:lod><dem:tin><gml:TriangulatedSurface gml:id="tin_s">'
        '<gml:patches>')
    for k in range(n):
        third = f"{k + 2} 0 10" if k in faulty else f"{k} 1 10"  # faulty: collinear corners
        line = put(f'<gml:Triangle{_FOO if k in faulty else ""}><gml:exterior><gml:LinearRing gml:id="t{k}_r">'
                   f'<gml:posList srsDimension="3">{k} 0 10 {k + 1} 0 10 {third} {k} 0 10</gml:posList>'
                   '</gml:LinearRing>'
                   '</gml:exterior></gml:Triangle>')
        if k in faulty:
            expected += [("xsd", line, "tin_s", "gml:Triangle', attribute 'foo': The attribute 'foo' is not allowed"),
                         ("degenerate-triangle", line, f"t{k}_r", "Triangle is degenerate (area 0 m²")]
    put('</gml:patches></gml:TriangulatedSurface></dem:tin></dem:TINRelief></dem:reliefComponent></dem:ReliefFeature>'
        '</core:cityObjectMember>' + "\n" * pad)
    put('<core:appearanceMember><app:Appearance gml:id="app"><app:theme>rgb</app:theme><app:surfaceData>'
        '<app:ParameterizedTexture gml:id="tex"><app:imageURI>textures/tile_1.jpg</app:imageURI>'
        '<app:mimeType>image/jpeg</app:mimeType>')
    duplicates = {n // 2 + 1: "ta1", n - 2: "t0_r"}  # the same id earlier in the same run / in another member
    for k in range(n):
        aid = duplicates.get(k, f"ta{k}")
        line = put(f'<app:textureParameterization><app:TextureAssociation gml:id="{aid}"'
                   f'{_FOO if k in faulty else ""}>'
                   f'<app:target>#{f"nowhere{k}" if k in faulty else "tin_s"}</app:target>')
        put('<app:textureParameterization><app:TexCoordList>'
            f'<app:textureCoordinates>{"0 0 1 0 0 1" if k in faulty else _UV}</app:textureCoordinates>')
        put(f'<app:ring>#t{k}_r</app:ring></app:TexCoordList></app:textureParameterization></app:TextureAssociation>'
            '</app:textureParameterization>')
        if k in faulty:
            expected += [("xsd", line, aid,
                          "app:TextureAssociation', attribute 'foo': The attribute 'foo' is not allowed"),
                         ("reference", line, None, f"app:target '#nowhere{k}' points to no gml:id"),
                         ("texture-coordinates", line + 1, aid, f"3 texture coordinate pairs for ring #t{k}_r, "
                          "which has 4 points")]
        if k in duplicates:
            expected.append(("duplicate-id", line, aid, f"gml:id '{aid}' is used more than once"))
    put('<app:textureParameterization><app:TextureAssociation gml:id="ta_tin"><app:target>#tin_s</app:target>')
    for k in range(n + 1):  # one more than rings
        # the list starts on the line of its first entry: past line 65,535 libxml2 2.9 keeps no line for an
        # element, and lxml takes the line of its first text (a line break would give the next line)
        line = put(('<app:textureParameterization><app:TexCoordList>' if k == 0 else '')
                   + f'<app:textureCoordinates>{"0 0 1 0 NaN 1 0 0" if k in faulty else _UV}</app:textureCoordinates>')
        if k == 0:
            expected.append(("texture-coordinates", line, "ta_tin", f"TexCoordList has {n + 1} textureCoordinates "
                             f"but {n} ring references"))
        if k in faulty:
            expected.append(("texture-coordinates", line, "ta_tin",
                             f"Texture coordinates for ring #t{k}_r contain 'NaN'"))
    for k in range(n):
        line = put(f'<app:ring{_FOO if k in faulty else ""}>#t{k}_r</app:ring>')
        if k in faulty:
            expected.append(("xsd", line, "ta_tin", "app:ring', attribute 'foo': The attribute 'foo' is not allowed"))
    put('</app:TexCoordList></app:textureParameterization></app:TextureAssociation></app:textureParameterization>')
    put('</app:ParameterizedTexture></app:surfaceData></app:Appearance></core:appearanceMember>')
    put('</core:CityModel>')
    path.write_text("\n".join(text) + "\n", encoding="utf-8")
    (path.parent / "textures").mkdir(exist_ok=True)
    (path.parent / "textures" / "tile_1.jpg").write_bytes(b"\xff\xd8\xff\xd9")
    return expected


@pytest.mark.parametrize(("chunk", "min_part"), [(97, 2), (1000, 3), (4096, 64), (None, None)])
def test_faults_in_long_runs_are_found_on_their_lines(chunk, min_part, schema_dir, tmp_path, monkeypatch):
    if chunk:
        _small_parts(monkeypatch, chunk, min_part)
    expected = _long_runs(tmp_path / "runs.gml", 40, pad=70_000)
    report = _one(tmp_path / "runs.gml", schema_dir)
    assert sorted((i.check, i.line) for i in report.issues) == sorted((check, line) for check, line, _, _ in expected)
    assert max(line for _, line, _, _ in expected) > 70_000
    for check, line, gml_id, words in expected:
        assert [i for i in report.issues if (i.check, i.line, i.gml_id) == (check, line, gml_id) and words in i.message]
    assert all(i.severity == "error" for i in report.issues) and report.status == "Fail"


@pytest.mark.parametrize(("chunk", "min_part"), [(97, 1), (1000, 3), (4096, 7)])
def test_each_element_is_handed_out_once_and_the_tree_stays_small(chunk, min_part, tmp_path, monkeypatch):
    """Parts cover the file exactly once, and the parsed tree never holds much more than a chunk."""
    _small_parts(monkeypatch, chunk, min_part)
    n = 40
    _long_runs(tmp_path / "runs.gml", n, pad=0)
    g, a = "{http://www.opengis.net/gml/3.2}", "{http://www.opengis.net/citygml/appearance/3.0}"
    stream = streaming.Stream(tmp_path / "runs.gml", "{http://www.opengis.net/citygml/3.0}CityModel", lambda _: None)
    seen, largest = Counter(), 0
    for parent, k in stream.parts():
        largest = max(largest, sum(1 for _ in stream.root.iter()))
        seen.update(node.tag for child in parent[:k] for node in child.iter() if isinstance(node.tag, str))
    assert seen[g + "Triangle"] == n and seen[a + "textureParameterization"] == 2 * n + 2
    assert seen[a + "textureCoordinates"] == 2 * n + 1 and seen[a + "ring"] == 2 * n
    assert largest < 12 + chunk / 8  # elements of one chunk (> 8 bytes each) plus the open path


def test_streamed_xsd_lines_agree_with_xmllint(schema_dir, tmp_path, monkeypatch):
    if shutil.which("xmllint") is None:
        pytest.skip("xmllint not installed")
    _small_parts(monkeypatch, 500, 3)
    expected = _long_runs(tmp_path / "runs.gml", 40, pad=0)
    run = subprocess.run(["xmllint", "--nonet", "--noout", "--schema", str(schema_dir / "citygml3-all.xsd"),
                          str(tmp_path / "runs.gml")], capture_output=True, text=True, timeout=60)
    xmllint_lines = {int(line.split(":")[1]) for line in run.stderr.splitlines() if "Schemas validity error" in line}
    schema_checks = {"xsd", "duplicate-id"}  # xmllint reports a duplicate gml:id as an xs:ID error
    ours = {i.line for i in _one(tmp_path / "runs.gml", schema_dir).issues if i.check in schema_checks}
    assert ours == xmllint_lines == {line for check, line, _, _ in expected if check in schema_checks}
    assert len(ours) == 11


def test_id_store_keeps_hashes_and_reports_later_duplicates():
    store = id_store.IdStore()
    for start in range(0, 1000, 8):
        names = [f"id{k}" for k in range(start, start + 8)]
        assert not store.add(id_store.hashes(names), np.array([k % 7 for k in range(start, start + 8)])).any()
    dup = store.add(id_store.hashes(["id500", "new", "new"]), np.array([0, 3, 0]))
    assert dup.tolist() == [True, False, True]  # met before; first time; second time in the same call
    assert len(store) == 1001
    assert len(store._runs) <= 10  # merged like a log-structured merge: O(log n) runs
    assert sum(keys.nbytes + points.nbytes for keys, points in store._runs) == 12 * 1001
    found, points = store.find(id_store.hashes(["id6", "id500", "new", "missing"]))
    assert found.tolist() == [True, True, True, False]
    assert points.tolist()[:3] == [6, 500 % 7, 3]


@pytest.mark.parametrize("small", [False, True])
def test_order_error_in_a_list_handed_out_in_parts_is_on_its_line(small, schema_dir, tmp_path, monkeypatch):
    """Coordinates after a ring in a TexCoordList (the schema's order broken) whose entries come in several parts."""
    if small:
        _small_parts(monkeypatch, 200, 1)
    path = _with_texture(schema_dir / "examples" / "handmade_LOD1_textured_building_TIN_group.gml", tmp_path)
    coords = "<app:textureCoordinates>0.0 0.0 1.0 1.0 0.0 1.0 0.0 0.0</app:textureCoordinates>"
    ring = "<app:ring>#tin_1_t0</app:ring>"
    text = path.read_text(encoding="utf-8")
    path.write_text(text.replace(f"{coords}\n                  {ring}", f"{ring}\n                  {coords}"),
                    encoding="utf-8")
    [issue] = _one(path, schema_dir).issues  # xmllint says the same (line 180)
    assert (issue.check, issue.line) == ("xsd", 180)
    assert issue.message == "Element 'app:textureCoordinates': This element is not expected. Expected is ( app:ring )."


# -- the paths taken when the fast ones are not available or do not apply ---------------------------------
def test_without_libxml2_for_ctypes_lxml_reports_the_same_schema_errors_without_lines(schema_dir, monkeypatch):
    from wit_plugin.citygml.validation import xsd

    monkeypatch.setattr(xsd, "_compiled", lambda folder: None)
    report = _one(schema_dir / "examples" / "INVALID_handmade_LOD1_4_errors.gml", schema_dir)
    schema_errors = [i for i in report.issues if i.check == "xsd" and i.severity == "error"]
    assert len(schema_errors) == 4 and {i.line for i in schema_errors} == {None}
    assert any("posLst" in i.message for i in schema_errors) and any("'one'" in i.message for i in schema_errors)
    [note] = [i for i in report.issues if i.severity == "warning"]
    assert "Line numbers of schema errors are not available" in note.message
    assert _one(schema_dir / "examples" / "Building_LOD2-EPSG25832.gml", schema_dir).valid


def _one_by_one(monkeypatch) -> None:
    """Make every check take its element-by-element path."""
    from wit_plugin.citygml import reader as stream
    from wit_plugin.citygml.validation import bulk, context, solids, textures, tin

    monkeypatch.setattr(bulk.BulkChecks, "thin", lambda self, chunk: chunk)  # nothing read from the bytes
    for module in (tin, solids):
        monkeypatch.setattr(module, "numbers", lambda texts, expected: None)  # triangles and solids one by one
    monkeypatch.setattr(textures, "_UNEVEN_LISTS", lambda part: [True])  # texture lists one by one
    monkeypatch.setattr(stream.RawCounts, "any_dimension_not_3", property(lambda self: True))
    monkeypatch.setattr(context.FileContext, "own_crs_possible", lambda self: True)


@pytest.mark.parametrize("name", sorted(FAULTS) + ["long_runs"])
def test_bulk_and_element_by_element_paths_agree(name, schema_dir, tmp_path, monkeypatch):
    if name == "long_runs":
        _long_runs(tmp_path / "runs.gml", 40, pad=0)
        path = tmp_path / "runs.gml"
    else:
        path = _with_texture(DATA / f"{name}.gml", tmp_path)
    bulk = sorted((i.check, i.line, i.gml_id, i.message) for i in _one(path, schema_dir).issues)
    _one_by_one(monkeypatch)
    assert sorted((i.check, i.line, i.gml_id, i.message) for i in _one(path, schema_dir).issues) == bulk


def test_a_star_that_turns_one_way_twice_around_is_not_taken_for_convex():
    """Convex faces skip GEOS: a pentagram turns one way at every corner, but twice around, and crosses itself."""
    from wit_plugin.citygml.validation.crs import Frame
    from wit_plugin.citygml.validation.geometry import SolidBatch, SolidCheck, Where
    from wit_plugin.citygml.validation.names import IssueList

    angles = np.radians(90 + 144 * np.arange(5))
    star = np.column_stack([10 * np.cos(angles), 10 * np.sin(angles), np.zeros(5)])
    square = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0.0]])
    issues = IssueList("f", 10)
    faces = [np.vstack([ring, ring[:1]]) for ring in (star, square)]
    SolidCheck(SolidBatch([Where(1, "s", "s")], [Frame("EPSG:25832")], np.concatenate(faces),
                          np.array([6, 5]), np.array([0, 1]), np.array([0, 0]),
                          lambda f: Where(f + 2, None, ("star", "square")[f])), issues, 0.001, 0.01).run()
    crossing = [i for i in issues.issues if i.check == "self-intersection"]
    assert [(i.line, i.message.split(" intersects")[0]) for i in crossing] == [(2, "Face star")]


def test_an_error_met_at_the_end_tag_is_reported_on_the_start_tag_as_xmllint_does(schema_dir, tmp_path):
    """libxml2's streaming validator meets a missing child at the end tag (line 14); the element starts on 13."""
    path = tmp_path / "missing.gml"
    path.write_text('<?xml version="1.0" encoding="UTF-8"?>\n'
                    '<core:CityModel xmlns:core="http://www.opengis.net/citygml/3.0" '
                    'xmlns:gml="http://www.opengis.net/gml/3.2"\n xmlns:bldg="http://www.opengis.net/citygml/building/3.0">\n'
                    '<core:cityObjectMember>\n<bldg:Building gml:id="b1">\n<core:lod1Solid>\n<gml:Solid gml:id="s1">\n'
                    '<gml:exterior>\n<gml:Shell>\n<gml:surfaceMember>\n<gml:Polygon>\n<gml:exterior>\n'
                    '<gml:LinearRing gml:id="r1">\n</gml:LinearRing>\n</gml:exterior>\n</gml:Polygon>\n'
                    '</gml:surfaceMember>\n'
                    '</gml:Shell>\n</gml:exterior>\n</gml:Solid>\n</core:lod1Solid>\n</bldg:Building>\n'
                    '</core:cityObjectMember>\n</core:CityModel>\n', encoding="utf-8")
    [issue] = [i for i in _one(path, schema_dir).issues if i.check == "xsd"]
    assert (issue.line, issue.gml_id) == (13, "r1") and "Missing child element(s)" in issue.message
    if shutil.which("xmllint"):
        run = subprocess.run(["xmllint", "--noout", "--schema", str(schema_dir / "citygml3-all.xsd"), str(path)],
                             capture_output=True, text=True, timeout=60)
        assert f"{path}:13:" in run.stderr


def test_reading_the_root_element_closes_the_file_itself(tmp_path):
    """iterparse on a path left a file it had not read to the end to the garbage collector: a
    ResourceWarning ("unclosed file") at the end of every validation through qgis_process."""
    import gc
    import warnings

    path = tmp_path / "big.gml"  # larger than what the parser reads ahead for the first element
    path.write_text('<core:CityModel xmlns:core="http://www.opengis.net/citygml/3.0">'
                    + "<!-- filler -->\n" * 100_000 + "</core:CityModel>\n", encoding="utf-8")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        root = streaming.first_element(path)
        gc.collect()
    assert root.tag == "{http://www.opengis.net/citygml/3.0}CityModel"
    assert [str(w.message) for w in caught if issubclass(w.category, ResourceWarning)] == []


# -- the regular bulk read from the bytes (validation.bulk) -----------------------------------------------
def _writer_model(folder: Path) -> Path:
    """A model as the writer lays it out (one element per line): what the bulk read is for."""
    from test_citygml import make_inputs

    from wit_plugin.citygml.writer import write_citygml

    out = folder / "city.gml"
    write_citygml(make_inputs(folder / "in"), str(out))
    return out


def _count_thinned(monkeypatch) -> list[int]:
    """Record how many elements each run checks from the bytes."""
    from wit_plugin.citygml.validation import bulk

    counts: list[int] = []
    original = bulk.BulkChecks.thin

    def thin(self, chunk: bytes) -> bytes:
        thinned = original(self, chunk)
        counts.append(self.thinned)
        return thinned
    monkeypatch.setattr(bulk.BulkChecks, "thin", thin)
    return counts


def _lines_with(path: Path, words: str) -> list[int]:
    return [k for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if words in line]


@pytest.mark.parametrize("chunk", [700, 2000, None])
def test_the_writers_regular_elements_are_checked_from_the_bytes_with_the_same_verdict(chunk, schema_dir, tmp_path,
                                                                                     monkeypatch):
    path = _writer_model(tmp_path)
    if chunk:
        _small_parts(monkeypatch, chunk, 2)
    counts = _count_thinned(monkeypatch)
    report = _one(path, schema_dir)
    assert report.valid and not report.issues
    # the TIN's 3 terrain triangles and the 3 associations of one ring (the roofs, the road's); in small chunks,
    # those whole in one (the road's polygon shares a chunk with a building's shell)
    assert max(counts) == {700: 5, 2000: 6, None: 6}[chunk]

    text = path.read_text(encoding="utf-8")
    tin_ring = re.search(r'<gml:Triangle><gml:exterior><gml:LinearRing gml:id="([^"]+)">', text).group(1)
    face = re.search(r'<gml:surfaceMember><gml:Polygon gml:id="([^"]+)">', text).group(1)  # a building's
    roof = re.search(r"<app:target>#([^<]+)</app:target><app:textureParameterization><app:TexCoordList>"
                     r"<app:textureCoordinates>([^<]+)</app:textureCoordinates>", text)
    tin_poslist = re.search(r'(<gml:LinearRing gml:id="' + tin_ring + r'"><gml:posList srsDimension="3">)([^<]+)<',
                            text)
    corners = tin_poslist.group(2).split()
    flat = " ".join(corners[:3] + corners[:3] + corners[6:9] + corners[:3])  # the second corner on the first
    faulty = (text.replace(f'"{tin_ring}"', f'"{face}"', 1)  # a TIN ring takes the id of a building's face
              .replace(f"<app:target>#{roof.group(1)}</app:target>", "<app:target>#nowhere</app:target>", 1)
              .replace(roof.group(2), " ".join(roof.group(2).split()[2:]), 1))
    second_ring = re.findall(r'<gml:Triangle><gml:exterior><gml:LinearRing gml:id="([^"]+)"><gml:posList '
                             r'srsDimension="3">([^<]+)<', faulty)[1]
    faulty = faulty.replace(second_ring[1], flat, 1)
    path.write_text(faulty, encoding="utf-8")
    bulk = _one(path, schema_dir)
    found = sorted((i.check, i.line, i.gml_id) for i in bulk.issues)
    assert found == sorted([
        ("duplicate-id", _lines_with(path, f'<gml:LinearRing gml:id="{face}">')[0], face),
        ("degenerate-triangle", _lines_with(path, second_ring[0])[0], second_ring[0]),
        ("reference", _lines_with(path, "#nowhere")[0], None),
        ("reference", _lines_with(path, f"<app:ring>#{tin_ring}</app:ring>")[0], None),  # the renamed ring's
        ("texture-coordinates", _lines_with(path, "#nowhere")[0], "tex_1")])
    assert _lines_with(path, f'<gml:LinearRing gml:id="{face}">')[0] > _lines_with(path, f'gml:id="{face}"')[0]
    _one_by_one(monkeypatch)
    assert sorted((i.check, i.line, i.gml_id, i.message) for i in _one(path, schema_dir).issues) == sorted(
        (i.check, i.line, i.gml_id, i.message) for i in bulk.issues)
