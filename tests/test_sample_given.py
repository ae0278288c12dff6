"""The sample's orthoimage and DEM drawn from given layers (core, no QGIS): real Gangnam roads (CP949,
EPSG:5179, ROAD_BT) and OpenStreetMap-style footprints (EPSG:4326), checked to the pixel after
georeferencing the tiles; sheet names; inputs untouched; the whole chain on the result."""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely
from conftest import juso_roads
from lxml import etree
from osgeo import gdal, ogr, osr

from wit_plugin.chain import ChainInputs, ChainOptions, run_city_model
from wit_plugin.infra import mapsheet
from wit_plugin.infra.errors import CanceledError, InputError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.infra.io.vector_io import read_layer
from wit_plugin.infra.polygons import repair_polygons, transform
from wit_plugin.mosaic.georef import OK, georeference_sheets
from wit_plugin.prepare.area import StudyArea
from wit_plugin.prepare.vectors import ROAD_QUAD_SEGS, road_widths
from wit_plugin.sample import GivenLayers, SampleConfig, draw_from_layers
from wit_plugin.sample.ortho import RASTER_CRS
from wit_plugin.sample.rasters import _PALETTE, ASPHALT, ROOF_COLOURS, roof_styles

SUSEO = (127.1020, 37.4876)
TARGET = pyproj.CRS(RASTER_CRS)
PIXEL = 0.5
DISTINCT_ROOFS = ROOF_COLOURS[[1, 2, 3, 4]]  # green, red tile, brown tile, blue metal: unlike any ground


def snapshot(*paths: Path) -> dict[str, str]:
    """Every file of the inputs' folders with the hash of its bytes (a new file beside them shows too)."""
    folders = {Path(str(p).split("|")[0]).parent for p in paths}
    return {str(f): hashlib.sha256(f.read_bytes()).hexdigest() for d in folders for f in sorted(d.iterdir())
            if f.is_file()}


@pytest.fixture(scope="module")
def drawn(tmp_path_factory, shared_dir, suseo_buildings):
    """250 m around Suseo at 0.5 m, from the real roads and the footprints; tiles georeferenced as VRTs."""
    roads = juso_roads(shared_dir)
    before = snapshot(roads, suseo_buildings)
    out = tmp_path_factory.mktemp("drawn")
    layers = GivenLayers(buildings=str(suseo_buildings), roads=str(roads), area=StudyArea.circle(*SUSEO, 250.0))
    result = draw_from_layers(out / "sample", layers, SampleConfig(ortho_pixel_size=PIXEL, seed=9))
    after = snapshot(roads, suseo_buildings)
    georeferenced = georeference_sheets([str(t) for t in result.ortho_tiles], out / "geo", RASTER_CRS, fmt="VRT")
    assert [g.status for g in georeferenced] == [OK] * len(result.ortho_tiles)
    manifest = json.loads(result.manifest.read_text(encoding="utf-8"))
    gains = {Path(t["file"]).name: np.array(t["gain"]) for t in manifest["tiles"]}
    tiles = [(g.output, gains[Path(g.source).name]) for g in georeferenced]
    return dict(result=result, before=before, after=after, tiles=tiles, manifest=manifest, roads=roads,
                buildings=suseo_buildings)


def _pixels(tiles, geom, raw: bool = False) -> np.ndarray:
    """RGB of every pixel whose centre lies in ``geom`` (EPSG:5186), divided by the tile's gain unless
    ``raw``, from the first georeferenced tile (path, gain) that holds the whole of ``geom``."""
    xmin, ymin, xmax, ymax = geom.bounds
    for path, gain in tiles:
        ds = gdal.Open(path)
        x0, dx, _, y0, _, dy = ds.GetGeoTransform()
        c0, c1 = int(np.floor((xmin - x0) / dx)), int(np.ceil((xmax - x0) / dx))
        r0, r1 = int(np.floor((ymax - y0) / dy)), int(np.ceil((ymin - y0) / dy))
        if c0 < 0 or r0 < 0 or c1 > ds.RasterXSize or r1 > ds.RasterYSize:
            continue
        block = ds.ReadAsArray(c0, r0, c1 - c0, r1 - r0).astype(float)
        xs, ys = np.meshgrid(x0 + (np.arange(c0, c1) + 0.5) * dx, y0 + (np.arange(r0, r1) + 0.5) * dy)
        rgb = block[:, shapely.contains_xy(geom, xs, ys)].T
        return rgb if raw else rgb / gain
    return np.zeros((0, 3))


def _chroma(rgb: np.ndarray) -> np.ndarray:
    return rgb / rgb.sum(axis=-1, keepdims=True)


def _centres(geom, step: float) -> np.ndarray:
    """Points every ``step`` m inside ``geom``."""
    xmin, ymin, xmax, ymax = geom.bounds
    xs, ys = np.meshgrid(np.arange(xmin, xmax, step), np.arange(ymin, ymax, step))
    points = np.column_stack([xs.ravel(), ys.ravel()])
    return points[shapely.contains_xy(geom, points[:, 0], points[:, 1])]


def _footprints(path: Path) -> np.ndarray:
    layer = read_layer(path)
    geoms = repair_polygons(transform(layer.geoms, layer.crs, TARGET)).geoms
    return geoms[~shapely.is_missing(geoms)]


def test_roofs_are_drawn_exactly_where_the_footprints_are(drawn):
    """Inside every footprint with a coloured roof each pixel has that roof's colour; in the 1 m ring of
    ground around it none has; the roof colour is the one roof_styles gives the footprint."""
    roofs = _footprints(drawn["buildings"])
    area = drawn["result"].area
    rgb, pitched = roof_styles(roofs, 9)
    tree = shapely.STRtree(roofs)
    styles = np.argmin(np.abs(_chroma(rgb)[:, None, :] - _chroma(ROOF_COLOURS)[None]).sum(axis=2), axis=1)
    assert len(set(styles)) >= 5 and pitched.any() and not pitched.all()  # roofs vary per building
    checked = 0
    for k in np.flatnonzero(shapely.within(roofs, area) & (shapely.area(roofs) > 60)):
        colour = _chroma(rgb[k])
        if np.abs(_chroma(DISTINCT_ROOFS) - colour).sum(axis=1).min() > 0.06:
            continue
        near = shapely.union_all(roofs[tree.query(roofs[k].buffer(1.0), predicate="intersects")])
        inside = _pixels(drawn["tiles"], roofs[k].buffer(-0.01))
        raw = _pixels(drawn["tiles"], roofs[k].buffer(-0.01), raw=True)
        ring = roofs[k].buffer(1.0).difference(near.buffer(0.01))  # ground only: neighbours' roofs left out
        if ring.area < 10.0:
            continue
        ring = _pixels(drawn["tiles"], ring)
        assert len(inside) > 4 * 60 * 0.8 and len(ring) > 20
        inside = inside[raw.max(axis=1) < 250]  # not clipped at 255
        assert np.abs(_chroma(inside) - colour).max() < 0.015, k
        assert np.abs(_chroma(ring) - colour).sum(axis=1).min() > 0.03, k
        checked += 1
    assert checked >= 20


def test_roads_are_drawn_where_the_real_roads_are(drawn):
    """Every pixel within 0.5 m of the inner edge of a narrow real road (no markings, no street trees),
    away from buildings and wide roads, is asphalt; the ring just beyond its surface is not."""
    roads = read_layer(drawn["roads"], bbox=(208300.0, 542400.0, 209800.0, 543900.0), bbox_crs=TARGET)
    widths, sources = road_widths(roads, 6.0)
    lines = transform(roads.geoms, roads.crs, TARGET)
    surfaces = shapely.buffer(lines, widths / 2, quad_segs=ROAD_QUAD_SEGS)
    wide = shapely.union_all(surfaces[widths >= 15.0]).buffer(25.0)
    near_buildings = shapely.union_all(_footprints(drawn["buildings"])).buffer(50.0)
    asphalt = _chroma(_PALETTE[ASPHALT])
    checked = 0
    for k in np.flatnonzero(widths < 15.0):
        core = surfaces[k].buffer(-0.5).difference(wide).difference(near_buildings)
        if core.area < 200:
            continue
        pixels = _pixels(drawn["tiles"], core)
        assert len(pixels) > 4 * 200 * 0.8
        assert np.abs(_chroma(pixels) - asphalt).max() < 0.012, roads.columns["RN"][k]
        checked += 1
    assert checked >= 5
    assert sources.count("ROAD_BT") == len(sources)  # the real layer has its widths


def test_tiles_are_the_sheets_of_the_area(drawn):
    """The sheets met by the 250 m circle (every 10 m), named as NGII names them."""
    result = drawn["result"]
    to_sheet = pyproj.Transformer.from_crs(TARGET, "EPSG:4737", always_xy=True)
    points = _centres(result.area, 10.0)
    expected = {mapsheet.sheet_at(*to_sheet.transform(x, y)).number for x, y in points}
    assert sorted(expected) == sorted(result.sheets) == ["37709004", "37709005"]
    assert [p.name for p in result.ortho_tiles] == [f"(B060)정사영상_2022_{n}.tif" for n in result.sheets]
    for path in result.ortho_tiles:
        ds = gdal.Open(str(path))
        assert ds.GetGeoTransform(can_return_null=True) is None and ds.GetProjection() == ""
        xmin, ymin, xmax, ymax = mapsheet.projected_envelope(mapsheet.find_sheet_in_name(path.name), RASTER_CRS,
                                                             margin=50.0)
        assert (ds.RasterXSize, ds.RasterYSize) == (round((xmax - xmin) / PIXEL), round((ymax - ymin) / PIXEL))
    assert result.area.area == pytest.approx(np.pi * 250.0 ** 2, rel=1e-3)


def test_inputs_untouched_and_the_manifest_names_them(drawn, shared_dir):
    assert drawn["after"] == drawn["before"]
    result, manifest = drawn["result"], drawn["manifest"]
    assert sorted(p.name for p in result.folder.iterdir()) == ["dem_5186.tif", "ortho", "sample_manifest.json"]
    sources = manifest["drawn_from"]
    assert sources["roads"]["source"] == str(drawn["roads"]) and sources["roads"]["encoding"] == "CP949"
    assert sources["roads"]["bytes"] == drawn["roads"].stat().st_size
    assert sources["buildings"]["source"] == str(drawn["buildings"])
    assert sources["buildings"]["features_drawn"] == result.counts["buildings"] == len(_footprints(drawn["buildings"]))
    assert result.counts["roads"] == sources["roads"]["features_drawn"] > 50
    assert manifest["counts"]["tiles"] == 2 and manifest["files"]["dem"] == "dem_5186.tif"
    assert manifest["area"]["study_area"]["kind"] == "circle"


def test_dem_covers_the_area_with_the_margin(drawn):
    ds = gdal.Open(str(drawn["result"].dem))
    x0, dx, _, y1, _, dy = ds.GetGeoTransform()
    xmin, ymin, xmax, ymax = drawn["result"].area.bounds
    assert x0 <= xmin - 250 and y1 >= ymax + 250
    assert x0 + dx * ds.RasterXSize >= xmax + 250 and y1 + dy * ds.RasterYSize <= ymin - 250
    assert osr.SpatialReference(wkt=ds.GetProjection()).GetAuthorityCode(None) == "5186"


def test_a_district_by_name_gives_its_sheets(shared_dir, tmp_path):
    """역삼동 of the real district layer: the tiles are the sheets the dong meets (every 20 m)."""
    districts = shared_dir / "data" / "juso_gangnam_11680_2019" / "TL_SCCO_EMD.shp"
    result = draw_from_layers(tmp_path / "out", GivenLayers(roads=str(juso_roads(shared_dir)), districts=str(districts),
                                                            area=StudyArea.from_district_code("역삼동")),
                              SampleConfig(ortho_pixel_size=8.0, with_dem=False))
    layer = read_layer(districts)
    dong = transform(layer.geoms[[n == "역삼동" for n in layer.columns["EMD_KOR_NM"]]], layer.crs, TARGET)[0]
    assert result.area.area == pytest.approx(dong.area, rel=1e-6)
    to_sheet = pyproj.Transformer.from_crs(TARGET, "EPSG:4737", always_xy=True)
    expected = {mapsheet.sheet_at(*to_sheet.transform(x, y)).number for x, y in _centres(dong, 20.0)}
    assert sorted(result.sheets) == sorted(expected) and len(expected) >= 2
    manifest = json.loads(result.manifest.read_text(encoding="utf-8"))
    assert manifest["area"]["district_layer"]["source"] == str(districts)
    assert manifest["files"]["dem"] is None and not (tmp_path / "out" / "dem_5186.tif").exists()


def _osm_roads(path: Path, epsg: int, geoms: np.ndarray, highway: str = "residential") -> Path:
    """An OpenStreetMap-style road layer (``highway``, no width) in a new folder."""
    path.parent.mkdir()
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(epsg)
    layer = ds.CreateLayer("roads", srs, ogr.wkbUnknown)
    layer.CreateField(ogr.FieldDefn("highway", ogr.OFTString))
    for geom in geoms:
        feature = ogr.Feature(layer.GetLayerDefn())
        feature.SetField("highway", highway)
        feature.SetGeometry(ogr.CreateGeometryFromWkb(shapely.to_wkb(geom)))
        layer.CreateFeature(feature)
    del layer, ds
    return path


def test_whole_extent_and_road_polygons_of_another_schema(tmp_path, shared_dir, suseo_buildings):
    """No area: the layers' extent. Roads as polygons (no ROAD_BT) are drawn as they are."""
    roads = read_layer(juso_roads(shared_dir), bbox=(964400.0, 1942900.0, 965200.0, 1943500.0))
    polygons = shapely.buffer(roads.geoms, 4.0)
    path = _osm_roads(tmp_path / "in" / "road_areas.gpkg", 5179, polygons)
    before = snapshot(path)
    result = draw_from_layers(tmp_path / "out", GivenLayers(roads=str(path)),
                              SampleConfig(ortho_pixel_size=2.0, with_dem=False))
    assert snapshot(path) == before
    extent = shapely.box(*shapely.total_bounds(transform(polygons, roads.crs, TARGET)))
    assert result.area.contains(extent) and result.area.area < 1.03 * extent.area
    geo = georeference_sheets([str(t) for t in result.ortho_tiles], tmp_path / "geo", RASTER_CRS, fmt="VRT")
    gains = {Path(t["file"]).name: np.array(t["gain"])
             for t in json.loads(result.manifest.read_text(encoding="utf-8"))["tiles"]}
    tiles = [(g.output, gains[Path(g.source).name]) for g in geo]
    cores = transform(shapely.buffer(roads.geoms, 3.0), roads.crs, TARGET)
    pixels = np.vstack([_pixels(tiles, c) for c in cores])
    assert len(pixels) > 1000
    asphalt = _chroma(_PALETTE[ASPHALT])
    # markings and street trees come with centre lines only: polygons are plain asphalt
    assert np.abs(_chroma(pixels) - asphalt).max() < 0.012
    assert result.counts == {"buildings": 0, "roads": len(polygons), "tiles": len(result.sheets)}


@pytest.mark.parametrize("highway,width,warned", [("residential", 6.5, False), ("construction", 6.0, True)])
def test_roads_without_width_get_the_class_or_default_width_with_a_warning(tmp_path, highway, width, warned):
    """OpenStreetMap lines without width or lanes: the width of their highway class (roads.OSM_CLASS_WIDTHS),
    else the default 6 m with a warning."""
    path = _osm_roads(tmp_path / "in" / "osm_roads.gpkg", 5186, shapely.from_wkt(
        ["LINESTRING(209000 543000,209300 543000)", "POINT(209100 543100)"]), highway)

    class Recorder(Feedback):
        def __init__(self):
            self.warnings, self.infos = [], []

        def warning(self, message):
            self.warnings.append(message)

        def info(self, message):
            self.infos.append(message)

    feedback = Recorder()
    result = draw_from_layers(tmp_path / "out", GivenLayers(roads=str(path)),
                              SampleConfig(ortho_pixel_size=1.0, with_dem=False), feedback)
    assert "roads: 1 of 2 feature(s) not drawn (no usable line or polygon)." in feedback.warnings
    defaulted = [w for w in feedback.warnings if "1 of 1 centre line(s) have no width, lane count or known class" in w]
    assert len(defaulted) == warned and all("default width 6 m" in w for w in defaulted)
    source = "default" if warned else f"highway={highway}"
    assert (f"Road width rule: OpenStreetMap roads: highway class default → default 6 m; 1 from {source}"
            in feedback.infos)
    geo = georeference_sheets([str(t) for t in result.ortho_tiles], tmp_path / "geo", RASTER_CRS, fmt="VRT")
    tiles = [(g.output, np.ones(3)) for g in geo]
    asphalt = _chroma(_PALETTE[ASPHALT])
    half = width / 2
    road = _pixels(tiles, shapely.box(209100.0, 543000.0 - half + 0.1, 209200.0, 543000.0 + half - 0.1))
    beside = [_pixels(tiles, shapely.box(209100.0, 543000.0 + s * (half + 0.1), 209200.0, 543000.0 + s * 5.0))
              for s in (-1, 1)]
    assert len(road) >= 500 and np.abs(_chroma(road) - asphalt).max() < 0.012
    assert all(np.abs(_chroma(b) - asphalt).sum(axis=1).min() > 0.03 for b in beside)


@pytest.mark.parametrize("layers,message", [
    (GivenLayers(), "Give a building or a road layer"),
    (GivenLayers(roads="ROADS", area=StudyArea.from_district_code("역삼동")), "needs the district"),
    (GivenLayers(roads="ROADS", area=StudyArea.circle(129.0756, 35.1796, 500.0)), "does not meet the given layers"),
    (GivenLayers(roads="missing.shp"), "does not exist"),
])
def test_bad_input_is_refused_up_front(layers, message, shared_dir, tmp_path):
    if layers.roads == "ROADS":
        layers = GivenLayers(roads=str(juso_roads(shared_dir)), area=layers.area)
    with pytest.raises(InputError, match=message):
        draw_from_layers(tmp_path / "out", layers, SampleConfig(ortho_pixel_size=4.0))
    assert not (tmp_path / "out").exists()


def test_an_output_folder_holding_an_input_is_refused(tmp_path, suseo_buildings):
    before = snapshot(suseo_buildings)
    with pytest.raises(InputError, match="holds the input"):
        draw_from_layers(suseo_buildings.parent, GivenLayers(buildings=str(suseo_buildings)), SampleConfig())
    assert snapshot(suseo_buildings) == before


def test_cancel_while_rendering_leaves_nothing_behind(tmp_path, suseo_buildings):
    class CancelLater(Feedback):
        seen = 0.0

        def progress(self, percent):
            self.seen = percent

        def is_canceled(self):
            return self.seen > 50.0

    with pytest.raises(CanceledError):
        draw_from_layers(tmp_path / "out", GivenLayers(buildings=str(suseo_buildings)),
                         SampleConfig(ortho_pixel_size=1.0), CancelLater())
    assert not (tmp_path / "out").exists()


def test_the_whole_chain_accepts_the_drawn_tiles_with_the_real_roads(drawn, shared_dir, tmp_path):
    """wit:citymodel's core on the same area: coverage passes, every surface is textured, the model is valid."""
    result = drawn["result"]
    report = run_city_model(
        ChainInputs(ortho=[str(result.ortho_tiles[0].parent)], dem=str(result.dem), buildings=str(drawn["buildings"]),
                    roads=str(drawn["roads"]),
                    districts=str(shared_dir / "data" / "juso_gangnam_11680_2019" / "TL_SCCO_EMD.shp")),
        ChainOptions(area=StudyArea.circle(*SUSEO, 250.0), max_edge=15.0, metrics=False), tmp_path / "model")
    assert report.valid and report.errors == 0 and report.untextured_outside == 0
    assert report.buildings == int(np.count_nonzero(shapely.contains(result.area, shapely.point_on_surface(
        _footprints(drawn["buildings"])))))
    roads = [e for e in etree.parse(report.gml).iter("{http://www.opengis.net/citygml/transportation/3.0}Road")]
    assert len(roads) >= 10
