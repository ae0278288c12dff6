"""Real-shaped national layers for the tests, made here (no shipped data).

The NGII digital map (수치지도 1:5,000 v2) as NGII ships it: one shapefile per layer named by its
code, Korean field names in CP949 (with an ``EUC-KR``/``CP949`` ``.cpg``, or none), EPSG:5187 for
the East Belt. Field lists as the digital-map rule defines them (수치지형도 작성 작업 및 성과에 관한
규정, 별표 2), under the Korean names NGII ships: buildings ``N3A_B0010000`` (명칭, 구분, 종류, 용도, 주기,
층수, 측량방법, UFID), road centre lines ``N3L_A0020000`` (도로번호, 명칭, 도로구분, …, 차로수, 도로폭, …,
UFID), road boundaries ``N3A_A0010000`` (polygons; their attributes are not used). OpenStreetMap roads
as osm2pgsql / GeoFabrik exports give them (``highway``, ``width``, ``lanes``, ``osm_id``).

The scene lies across the border of two 1:5,000 sheets near Gyeongju (129.2°E, 35.85°N): sheet
35901058 (west) and 35901059 (east), each holding one block of buildings; a road strip crosses the border.
"""
from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from osgeo import gdal, ogr, osr

EPSG = 5187
BORDER_X = 218064.0  # the sheets' common edge (lon 129.2°) near y 361,900 in EPSG:5187
#: (x, y) of the lower-left corner of each building: a west and an east block, 6 each
CORNERS = [(217900.0 + 45 * i, 361800.0 + 60 * j) for j in range(2) for i in range(3)] + \
          [(218110.0 + 45 * i, 361800.0 + 60 * j) for j in range(2) for i in range(3)]
FLOORS = [1, 2, 3, 4, 5, 6, 7, 2, 3, 12, 1, 4]
USES = ["단독주택", "공동주택", "제1종근린생활시설", "업무시설", "공동주택", "교육연구시설"] * 2
KINDS = ["일반주택", "아파트", "주택외건물", "주택외건물", "아파트", "주택외건물"] * 2
NAMES = ["똠방각하", "햇살아파트", "", "경주상가", "", "동국초등학교"] * 2  # 똠: a syllable only CP949 has
BUILDING_FIELDS = [("명칭", ogr.OFTString, 100), ("구분", ogr.OFTString, 20), ("종류", ogr.OFTString, 20),
                   ("용도", ogr.OFTString, 40), ("주기", ogr.OFTString, 50), ("층수", ogr.OFTInteger, 10),
                   ("측량방법", ogr.OFTString, 20), ("UFID", ogr.OFTString, 34)]
CENTRE_LINE_FIELDS = [("도로번호", ogr.OFTString, 30), ("명칭", ogr.OFTString, 100), ("도로구분", ogr.OFTString, 20),
                      ("시점", ogr.OFTString, 50), ("종점", ogr.OFTString, 50), ("포장재질", ogr.OFTString, 20),
                      ("분리대유무", ogr.OFTString, 20), ("차로수", ogr.OFTInteger, 5), ("도로폭", ogr.OFTReal, 13),
                      ("일방통행", ogr.OFTString, 20), ("자동차전용", ogr.OFTString, 20), ("기타", ogr.OFTString, 50),
                      ("UFID", ogr.OFTString, 34)]
ROAD_BOUNDARY_FIELDS = [("명칭", ogr.OFTString, 100), ("UFID", ogr.OFTString, 34)]
#: the road surfaces: a strip along the blocks across the sheets' border, and a cross street in the west block
ROAD_POLYGONS = ["POLYGON((217880 361872,218250 361872,218250 361884,217880 361884,217880 361872))",
                 "POLYGON((217982 361790,217990 361790,217990 361872,217982 361872,217982 361790))"]
#: centre lines: (WKT, 차로수, 도로폭)
CENTRE_LINES = [("LINESTRING(217880 361878,218250 361878)", 4, 12.0),
                ("LINESTRING(217986 361790,217986 361872)", 2, None),
                ("LINESTRING(218190 361790,218190 361872)", None, None)]


def srs(epsg: int = EPSG) -> osr.SpatialReference:
    ref = osr.SpatialReference()
    ref.ImportFromEPSG(epsg)
    return ref


@contextlib.contextmanager
def shapefile_text(encoding: str) -> Iterator[None]:
    """GDAL writes a shapefile's text in ``encoding`` only if ``SHAPE_ENCODING`` agrees: QGIS sets it to ""
    (no recoding), which then wins over the ``ENCODING`` creation option (UTF-8 bytes under a CP949
    .cpg); set for this thread while writing."""
    before = gdal.GetThreadLocalConfigOption("SHAPE_ENCODING", None)
    gdal.SetThreadLocalConfigOption("SHAPE_ENCODING", encoding)
    try:
        yield
    finally:
        gdal.SetThreadLocalConfigOption("SHAPE_ENCODING", before)


def building_wkt(x: float, y: float, size: float = 20.0) -> str:
    return f"POLYGON(({x} {y},{x + size} {y},{x + size} {y + size},{x} {y + size},{x} {y}))"


def write_shapefile(path: Path, geometry: int, fields: list[tuple[str, int, int]], rows: list[dict],
                    wkts: list[str], cpg: str | None = "CP949", epsg: int = EPSG) -> Path:
    """A shapefile in CP949 with the given ``.cpg`` text (None: no .cpg, language-driver byte 0, as NGII
    and juso.go.kr ship theirs)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with shapefile_text("CP949"):
        ds = ogr.GetDriverByName("ESRI Shapefile").CreateDataSource(str(path))
        layer = ds.CreateLayer(path.stem, srs(epsg), geometry, options=["ENCODING=CP949"])
        for name, kind, width in fields:
            definition = ogr.FieldDefn(name, kind)
            definition.SetWidth(width)
            if kind == ogr.OFTReal:
                definition.SetPrecision(2)
            layer.CreateField(definition)
        for row, wkt in zip(rows, wkts):
            feature = ogr.Feature(layer.GetLayerDefn())
            for name, value in row.items():
                if value is not None:
                    feature.SetField(name, value)
            feature.SetGeometry(ogr.CreateGeometryFromWkt(wkt))
            layer.CreateFeature(feature)
        del layer, ds
    cpg_file = path.with_suffix(".cpg")
    if cpg is None:
        cpg_file.unlink(missing_ok=True)
        with open(path.with_suffix(".dbf"), "r+b") as dbf:  # language driver 0: nothing declared
            dbf.seek(29)
            dbf.write(b"\x00")
    else:
        cpg_file.write_text(cpg, encoding="ascii")
    return path


def buildings(folder: Path, cpg: str | None = "EUC-KR", name: str = "N3A_B0010000") -> Path:
    rows = [{"명칭": NAMES[k] or None, "구분": "건물", "종류": KINDS[k], "용도": USES[k], "주기": None,
             "층수": FLOORS[k], "측량방법": "사진측량", "UFID": f"B0012021{35901058 + (x > BORDER_X):08d}{k:05d}"}
            for k, (x, _) in enumerate(CORNERS)]
    return write_shapefile(folder / f"{name}.shp", ogr.wkbPolygon, BUILDING_FIELDS, rows,
                           [building_wkt(x, y) for x, y in CORNERS], cpg)


def road_polygons(folder: Path, cpg: str | None = None, name: str = "N3A_A0010000") -> Path:
    rows = [{"명칭": "화랑로", "UFID": "A0012021359010580000001"}, {"명칭": None, "UFID": "A0012021359010580000002"}]
    return write_shapefile(folder / f"{name}.shp", ogr.wkbPolygon, ROAD_BOUNDARY_FIELDS, rows, ROAD_POLYGONS, cpg)


def centre_lines(folder: Path, cpg: str | None = "CP949", name: str = "N3L_A0020000") -> Path:
    rows = [{"도로번호": "35", "명칭": "화랑로", "도로구분": "국도", "포장재질": "아스팔트", "차로수": lanes,
             "도로폭": width,
             "일방통행": "양방통행", "자동차전용": "일반", "UFID": f"A00220213590105800000{k + 1:02d}"}
            for k, (_, lanes, width) in enumerate(CENTRE_LINES)]
    return write_shapefile(folder / f"{name}.shp", ogr.wkbLineString, CENTRE_LINE_FIELDS, rows,
                           [wkt for wkt, _, _ in CENTRE_LINES], cpg)


def area(folder: Path, name: str = "대상지역") -> Path:
    """A study-area polygon shapefile (Korean file and field name) around both blocks."""
    return write_shapefile(folder / f"{name}.shp", ogr.wkbPolygon, [("이름", ogr.OFTString, 20)],
                           [{"이름": "시험지역"}],
                           ["POLYGON((217870 361780,218260 361780,218260 361940,217870 361940,217870 361780))"])


def dem(path: Path, epsg: int = EPSG, cell: float = 5.0) -> Path:
    """A gently sloping DEM around the scene (40 m at x 217,600 in EPSG:5187, rising 2 cm per m east and 1 cm
    per m north), on a grid of ``cell`` metres in ``epsg``: the same ground in any CRS."""
    import pyproj

    to_scene = pyproj.Transformer.from_crs(epsg, EPSG, always_xy=True)
    west, south, east, north = pyproj.Transformer.from_crs(EPSG, epsg, always_xy=True).transform_bounds(
        217600.0, 361400.0, 218600.0, 362200.0)
    x0, y1 = np.floor(west / cell) * cell, np.ceil(north / cell) * cell
    size = (int(np.ceil((east - x0) / cell)), int(np.ceil((y1 - south) / cell)))
    xs = x0 + (np.arange(size[0]) + 0.5) * cell
    ys = y1 - (np.arange(size[1]) + 0.5) * cell
    sx, sy = to_scene.transform(*np.meshgrid(xs, ys))
    ds = gdal.GetDriverByName("GTiff").Create(str(path), size[0], size[1], 1, gdal.GDT_Float32)
    ds.SetGeoTransform((x0, cell, 0, y1, 0, -cell))
    ds.SetProjection(srs(epsg).ExportToWkt())
    ds.GetRasterBand(1).WriteArray((40 + 0.02 * (sx - 217600.0) + 0.01 * (sy - 361000.0)).astype(np.float32))
    ds.GetRasterBand(1).SetNoDataValue(-9999)
    ds = None
    return path
