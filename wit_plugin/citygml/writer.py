"""Streaming CityGML 3.0 writer: the core of ``wit:writecitygml``.

Reads the step outputs named in ``infra.step_layers`` (LoD1 faces, TIN, prepared roads and districts, the
texture table) and writes one ``core:CityModel``, element by element, with constant memory in
the number of buildings:

* ``bldg:Building`` (gml:id = wit_id): generic attributes (every source field, typed), a closed
  ``core:lod1Solid`` whose faces are written as stored (polygon ``<wit_id>_f<face_no>``, exterior
  ring ``…_r``, interior rings ``…_r1``, ``…_r2`` …), ``con:height``, storeys.
* ``tran:Road`` (gml:id = road wit_id) → ``tran:trafficSpace/tran:TrafficSpace`` (granularity
  "way") → ``core:boundary/tran:TrafficArea`` → ``core:lod2MultiSurface``: the TIN triangles with
  surface "road" of that road (already draped, Z from the TIN), each a ``gml:Polygon tri_<tri_id>``.
* ``dem:ReliefFeature`` → ``dem:TINRelief`` → ``gml:TriangulatedSurface DEM_tin_surface``: every
  other TIN triangle (terrain and building footprints). Road triangles are not repeated there, so
  relief + roads tile the terrain exactly once (closed, no z-fighting). ``gml:Triangle`` cannot
  carry a gml:id, so a terrain triangle is identified by its ring ``tri_<tri_id>_r``.
* ``grp:CityObjectGroup`` per legal dong (gml:id = district wit_id) listing the buildings whose
  footprint's representative point lies in it; districts without buildings are left out.
* Per image one ``core:appearanceMember`` / ``app:Appearance`` (after the city objects) with its
  ``app:ParameterizedTexture``; texture-table rows are read ORDER BY image. One member per image
  keeps what a member-by-member reader must hold to one image's associations.

Threading: lxml used from a QGIS Processing background thread has crashed QGIS on Windows
(qgis/QGIS#54751), so the Processing algorithm runs this writer in the main thread
(``FlagNoThreading``); the QGIS glue sets that flag.
"""
from __future__ import annotations

import contextlib
import math
import mimetypes
import os
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from itertools import chain, groupby, islice
from operator import itemgetter
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape  # nosec B406  # escapes what is written; nothing is parsed with it

import numpy as np
from lxml import etree
from osgeo import ogr

from ..infra import step_layers
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.gc_pause import collector_paused
from ..infra.io import bulk_read
from ..infra.io.fileio import atomic_file, copy_images
from ..infra.numtext import ring_texts
from ..infra.texcoords import parse_texcoord_column
from .inputs import (
    BULK,
    CityGMLInputs,
    FacadeRows,
    InputLayer,
    Membership,
    ModelLayers,
    checked_wit_id,
    clean_text,
    columns_of,
    fields_of,
    rises_in_table_order,
    tin_triangles,
    typed_attributes,
    uv_values,
)
from .namespaces import APP, BLDG, CON, CORE, DEM, GML, GML_ID, GRP, TRAN, URIS, XLINK, XSI
from .schemas import CITYGML_MODULES

APPEARANCE_THEME = "rgbTexture"
FACADE_THEME = "generatedFacade"  # the walls' textures: drawn by the plugin, kept apart from the measured theme
FACADE_DESCRIPTION = ("Generated facade: storey modules drawn by WIT City Model from the building's use and storey "
                      "count (not measured; an orthoimage does not see walls)")
DISTRICT_NAME_FIELD = "EMD_KOR_NM"  # legal-dong name in the Korean road-name-address data
RELIEF_ID, TIN_RELIEF_ID, TIN_SURFACE_ID = "DEM_relief", "DEM_tin", "DEM_tin_surface"
RELIEF_LOD, ROAD_LOD_PROPERTY = "1", "lod2MultiSurface"

NS = {prefix: URIS[prefix] for prefix in ("core", "bldg", "con", "tran", "dem", "app", "gen", "grp", "gml", "xlink",
                                          "xsi")}
"""The namespaces the model declares on its root (those of the modules it uses)."""

_BATCH = 10_000  # rows between progress/cancel checks


@dataclass
class WriteReport:
    """What was written, for the Processing log and the tests."""

    buildings: int = 0
    faces: int = 0
    roads: int = 0
    triangles: int = 0  # TIN triangles written (relief + road traffic areas)
    textures: int = 0  # ParameterizedTexture elements (one per image)
    textured_surfaces: int = 0  # rings with texture coordinates
    groups: int = 0
    group_members: int = 0
    envelope: tuple[float, float, float, float, float, float] | None = None  # min x y z, max x y z
    texture_folder: str | None = None


def write_citygml(inputs: CityGMLInputs, output: str, srs_name: str = "EPSG:5186",
                  feedback: Feedback = SILENT, copy_textures: bool = True) -> WriteReport:
    """Write the CityGML 3.0 model to ``output`` (atomically); see the module docstring."""
    srs_uri = srs_name_of(srs_name)
    report = WriteReport()
    out = Path(output)
    with contextlib.ExitStack() as stack:
        stack.enter_context(collector_paused())

        layers = ModelLayers.open(inputs, srs_name, stack)
        lod1, tin, roads, texcoords, images = layers.lod1, layers.tin, layers.roads, layers.texcoords, layers.images
        report.envelope = layers.envelope
        tex_dir = out.parent / f"{out.stem}_textures"
        uris = {image: image_uri(src, image, out.parent, tex_dir if copy_textures else None)
                for image, src in images.items()}
        members = stack.enter_context(Membership(layers.districts)) if layers.districts else None
        facades = (stack.enter_context(FacadeRows.open(Path(inputs.textures)))
                   if texcoords and inputs.textures else None)  # (texcoords: read from inputs.textures)
        total = sum(source.count() for source in (lod1, tin, texcoords) if source) or 1
        tmp = stack.enter_context(atomic_file(out))
        with open(tmp, "wb") as fh, _Writer.document(fh, srs_uri, report, _Progress(feedback, total)) as writer:
            if lod1:
                writer.buildings(lod1, members, facades)
            if roads or tin:
                writer.roads(roads, tin)
            if tin:
                writer.relief(tin)
            if members:
                writer.groups(members)
            if texcoords:
                writer.appearance(texcoords, uris)
        if copy_textures and images:
            copy_images(images, tex_dir)
            report.texture_folder = str(tex_dir)
    feedback.progress(100.0)
    feedback.info(f"CityGML: {report.buildings} buildings ({report.faces} faces), {report.roads} roads, "
                  f"{report.triangles} TIN triangles, {report.textures} textures, {report.groups} districts")
    return report


_ONE_EPSG_CODE = re.compile(r"(?i)(?:EPSG:|urn:ogc:def:crs:EPSG:[\d.]*:|https?://www\.opengis\.net/def/crs/EPSG/[\d.]+/)"
                            r"(\d+)")


def srs_name_of(srs_name: str) -> str:
    """The ``srsName`` written for the target CRS: ``EPSG:n`` for an EPSG CRS in any form.

    Coordinates are written as the layers hold them, easting (longitude) first. That is what the
    short form means to readers (GDAL's GML reader, the validator: ``citygml.validation.crs``); the
    URN and URL forms mean EPSG's axis order, northing first for the Korean belts (EPSG:5186), so
    GDAL would read a URL-named model with x and y swapped. Other CRS URIs and URNs pass unchanged.
    """
    name = srs_name.strip()
    match = _ONE_EPSG_CODE.fullmatch(name)
    if match:
        return f"EPSG:{match.group(1)}"
    if re.match(r"(?i)(https?://|urn:)\S+$", name):
        return name
    raise InputError(f"CRS '{srs_name}' is neither EPSG:<code> nor a CRS URI/URN (e.g. EPSG:5186).")


def image_uri(src: Path, image: str, out_dir: Path, tex_dir: Path | None) -> str:
    """Relative URI of the image from the .gml: in the copied folder, else the original file."""
    target = tex_dir / image if tex_dir else src
    try:
        return Path(os.path.relpath(target, out_dir)).as_posix()
    except ValueError:  # another drive on Windows: no relative path exists
        return target.resolve().as_uri()


def _poslist(points: list[tuple[float, ...]]) -> str:
    return " ".join(f"{x:.3f} {y:.3f} {z:.3f}" for x, y, z in points)


def _polygon(gml_id: str, geometry: ogr.Geometry) -> str:
    """A ``gml:Polygon`` with rings as stored; ring ids ``<id>_r`` (exterior), ``<id>_r<i>``."""
    return _polygon_markup(gml_id, [_poslist(geometry.GetGeometryRef(i).GetPoints())
                                    for i in range(geometry.GetGeometryCount())])


def _polygon_markup(gml_id: str, poslists: list[str]) -> str:
    """``_polygon`` from the rings' ready-made posList texts."""
    rings = "".join(f'<gml:{"interior" if i else "exterior"}><gml:LinearRing gml:id="{gml_id}_r{i or ""}">'
                    f'<gml:posList srsDimension="3">{poslist}</gml:posList></gml:LinearRing>'
                    f'</gml:{"interior" if i else "exterior"}>' for i, poslist in enumerate(poslists))
    return f'<gml:Polygon gml:id="{gml_id}">{rings}</gml:Polygon>'


def _batches(items: Iterable[Any], size: int) -> Iterator[list[Any]]:
    iterator = iter(items)
    while batch := list(islice(iterator, size)):
        yield batch


_TEXTURE_COLUMNS = (step_layers.TEX_IMAGE, step_layers.TEX_TARGET, step_layers.TEX_FEATURE, step_layers.TEX_FACE)
_UV_FORMAT = "%.7g %.7g"  # texture coordinates: 7 significant digits (a texel of a 10⁶-texel side)
_TRIANGLE_TARGETS = ("tin", "road")  # one texture row per triangle: 4 (u, v) pairs, closing pair included


def _texture_rows(batch: dict[str, np.ndarray], path: str) -> Iterator[tuple[str, str, str, str, str]]:
    """A batch of the texture table as (image, target, feature, face, uv) texts, uv checked and normalised to 7
    significant digits: the batch's texts parsed at once from their bytes (``parse_texcoord_column``), each
    distinct pair formatted once (``ring_texts``); a batch with a text to report is read text by text."""
    images, targets, features, faces = (bulk_read.texts(batch[name]) for name in _TEXTURE_COLUMNS)
    uv = _uv_texts(batch[step_layers.TEX_COORDS], targets, features, faces, path)
    return zip(images, targets, features, faces, uv)


def _uv_texts(column: np.ndarray, targets: list[str], features: list[str], faces: list[str], path: str) -> list[str]:
    try:
        values, counts = parse_texcoord_column(column)
    except ValueError:
        return _uv_texts_one_by_one(bulk_read.texts(column), targets, features, faces, path)
    triangle = np.isin(np.array(targets, dtype=object), _TRIANGLE_TARGETS)
    if (np.where(triangle, counts != 4, counts < 4)).any() or not np.isfinite(values).all():
        return _uv_texts_one_by_one(bulk_read.texts(column), targets, features, faces, path)
    return ring_texts(values, counts, _UV_FORMAT)


def _uv_texts_one_by_one(texts: list[str], targets: list[str], features: list[str], faces: list[str],
                         path: str) -> list[str]:
    """``_uv_texts`` text by text: the first row in the table's order that is wrong is reported (an unknown target,
    or texture coordinates that are not u v pairs)."""
    pairs, counts = [], []
    for text, target, feature, face in zip(texts, targets, features, faces):
        if target not in step_layers.TEX_TARGETS:
            raise _unknown_target(target, path)
        surface = (f"TIN triangle {feature}" if target == "tin" else f"road tri_{feature}" if target == "road"
                   else f"{target} {feature}_f{face}")

        def named(_row: int, name: str = f"{surface} in {path}") -> str:
            return name

        values, count = uv_values([text], named, target in _TRIANGLE_TARGETS)
        pairs.append(values)
        counts.append(count)
    return ring_texts(np.concatenate(pairs) if pairs else np.zeros((0, 2)),
                      np.concatenate(counts) if counts else np.zeros(0, dtype=np.int64), _UV_FORMAT)


def _unknown_target(target: str, path: str) -> InputError:
    """The refusal of a texture-table row naming no known target (both readings of the table raise it)."""
    return InputError(f"Texture table {path} has the unknown target {target!r}: use roof, wall, road or tin.")


class _Progress:
    def __init__(self, feedback: Feedback, total: int):
        self.feedback, self.total, self.done = feedback, total, 0

    def tick(self, count: int = 1) -> None:
        self.done += count
        if self.done % _BATCH < count:  # passed a multiple of _BATCH
            self.feedback.check_canceled()
            self.feedback.progress(min(99.0, 100.0 * self.done / self.total))


# --- writing ------------------------------------------------------------------------------------

SKIP_BUILDING_FIELDS = {step_layers.WIT_ID, step_layers.FACE_TYPE, step_layers.FACE_NUMBER, step_layers.HEIGHT,
                         step_layers.STOREYS_ABOVE, step_layers.STOREYS_BELOW}
_GEN_TYPES = {"int": "IntAttribute", "double": "DoubleAttribute", "date": "DateAttribute", "string": "StringAttribute"}
_CARRIAGE_RETURN = {"\r": "&#13;"}


def xml_text(text: str) -> str:
    """Element text escaped as lxml writes it: ``&``, ``<``, ``>`` and the carriage return (which a reader
    would otherwise take for a line end). ``text`` holds only characters XML can carry (``clean_text``)."""
    return escape(text, _CARRIAGE_RETURN)


class _Writer:
    """Writes the document through ``lxml.etree.xmlfile``, one element at a time, except the
    geometry that repeats hundreds of thousands of times (TIN and road triangles, faces, texture
    coordinates of the TIN), which goes out as ready-made markup (``raw``): one Python call per
    triangle instead of about ten. That markup holds only numbers and ids checked to be NCNames.
    """

    #: triangles (or texture entries) per ``raw`` write
    RAW_BATCH = 1024

    def __init__(self, xf: Any, fh: Any, report: WriteReport, progress: _Progress):
        self.xf, self.fh, self.report, self.progress = xf, fh, report, progress

    def raw(self, markup: str) -> None:
        """Append markup as it is: lxml's pending output first, so the order is kept."""
        self.xf.flush()
        self.fh.write(markup.encode("utf-8"))

    @classmethod
    @contextlib.contextmanager
    def document(cls, fh: Any, srs_uri: str, report: WriteReport, progress: _Progress) -> Iterator[_Writer]:
        """The CityModel with its envelope; members are written inside the ``with`` block."""
        locations = " ".join(f"{NS[p]} {CITYGML_MODULES[NS[p]]}"
                             for p in ("core", "bldg", "con", "tran", "dem", "app", "gen", "grp"))
        env = report.envelope
        if env is None:  # (set from the model's layers before the document is written)
            raise ValueError("The model's envelope is not known.")
        with etree.xmlfile(fh, encoding="utf-8") as xf:
            xf.write_declaration()
            with xf.element(CORE + "CityModel", {XSI + "schemaLocation": locations}, nsmap=NS):
                writer = cls(xf, fh, report, progress)
                with writer.el(GML + "boundedBy"), \
                        writer.el(GML + "Envelope", {"srsName": srs_uri, "srsDimension": "3"}):
                    writer.leaf(GML + "lowerCorner", _poslist([env[:3]]))
                    writer.leaf(GML + "upperCorner", _poslist([env[3:]]))
                yield writer
                xf.write("\n")

    # small helpers ------------------------------------------------------------------------------
    def el(self, tag: str, attrib: dict[str, str] | None = None) -> Any:
        return self.xf.element(tag, attrib or {})

    def leaf(self, tag: str, text: str, attrib: dict[str, str] | None = None) -> None:
        with self.xf.element(tag, attrib or {}):
            self.xf.write(text)

    @contextlib.contextmanager
    def member(self, tag: str, gml_id: str) -> Iterator[None]:
        """A ``core:cityObjectMember`` holding one city object, on its own line."""
        self.xf.write("\n")
        with self.el(CORE + "cityObjectMember"), self.el(tag, {GML_ID: gml_id}):
            yield

    def attributes(self, feature: ogr.Feature, fields: list[tuple[int, str, int]], skip: set[str]) -> None:
        """Every set, finite attribute as a typed ``gen:`` attribute (UTF-8, XML-clean), as ready-made markup:
        what lxml wrote element by element, at a tenth of the calls."""
        markup = "".join(
            f"<core:genericAttribute><gen:{_GEN_TYPES[kind]}><gen:name>{xml_text(name)}</gen:name>"
            f"<gen:value>{xml_text(repr(value) if kind == 'double' else str(value))}</gen:value>"
            f"</gen:{_GEN_TYPES[kind]}></core:genericAttribute>"
            for name, kind, value in typed_attributes(feature, fields, skip))
        if markup:
            self.raw(markup)

    # content ------------------------------------------------------------------------------------
    def buildings(self, lod1: InputLayer, members: Membership | None, facades: FacadeRows | None) -> None:
        with lod1.select(order=(step_layers.WIT_ID, step_layers.FACE_NUMBER)) as result:
            fields, col = fields_of(result), columns_of(result)
            key = col[step_layers.WIT_ID]
            for wit_id, faces in groupby(result, key=lambda f: f.GetFieldAsString(key)):
                self.building(checked_wit_id(wit_id, f"A face in {lod1.path}"), faces, fields, col, members,
                              facades)

    def building(self, wit_id: str, faces: Iterator[ogr.Feature], fields: list[tuple[int, str, int]],
                 col: dict[str, int], members: Membership | None, facades: FacadeRows | None) -> None:
        first = next(faces)
        number_col, type_col, last = col[step_layers.FACE_NUMBER], col[step_layers.FACE_TYPE], -1
        facade = facades.of(wit_id) if facades else None
        with self.member(BLDG + "Building", wit_id):
            self.attributes(first, fields, SKIP_BUILDING_FIELDS)
            if facade is not None and facades is not None:  # how the wall texture was made
                self.attributes(facade, facades.fields, {step_layers.WIT_ID, step_layers.FACADE_IMAGE})
            with self.el(CORE + "lod1Solid"), self.el(GML + "Solid", {GML_ID: f"{wit_id}_lod1"}), \
                    self.el(GML + "exterior"), self.el(GML + "Shell"):
                surfaces = []  # the faces' markup, written in one go
                for face in chain([first], faces):
                    number, geometry = face.GetFieldAsInteger(number_col), face.GetGeometryRef()
                    if not face.IsFieldSetAndNotNull(number_col) or number <= last:
                        raise InputError(f"Building {wit_id} has a face without a unique {step_layers.FACE_NUMBER}: "
                                         "re-run wit:extrudebuildings.")
                    if geometry is None or geometry.IsEmpty():
                        raise InputError(f"Face {number} of building {wit_id} has no geometry: "
                                         "re-run wit:extrudebuildings.")
                    surfaces.append(f"\n<gml:surfaceMember>{_polygon(f'{wit_id}_f{number}', geometry)}"
                                    "</gml:surfaceMember>")
                    if members and face.GetFieldAsString(type_col) == "ground":
                        members.add(wit_id, bytes(geometry.ExportToIsoWkb()))
                    last = number
                    self.report.faces += 1
                    self.progress.tick()
                self.raw("".join(surfaces))
            self.height(first, col)
            for name, tag in ((step_layers.STOREYS_ABOVE, "storeysAboveGround"),
                              (step_layers.STOREYS_BELOW, "storeysBelowGround")):
                if name in col and first.IsFieldSetAndNotNull(col[name]):
                    self.leaf(BLDG + tag, str(first.GetFieldAsInteger64(col[name])))
        self.report.buildings += 1

    def height(self, feature: ogr.Feature, col: dict[str, int]) -> None:
        """``con:height``: measured when it came from a height field, else estimated."""
        if step_layers.HEIGHT not in col or not feature.IsFieldSetAndNotNull(col[step_layers.HEIGHT]):
            return
        value = feature.GetFieldAsDouble(col[step_layers.HEIGHT])
        if not math.isfinite(value):
            return
        source = feature.GetFieldAsString(col[step_layers.HEIGHT_SOURCE]) if step_layers.HEIGHT_SOURCE in col else None
        with self.el(CON + "height"), self.el(CON + "Height"):
            self.leaf(CON + "highReference", "highestRoofEdge")
            self.leaf(CON + "lowReference", "lowestGroundPoint")
            self.leaf(CON + "status", "measured" if source == "field" else "estimated")
            self.leaf(CON + "value", f"{value:.3f}", {"uom": "m"})

    def roads(self, roads: InputLayer | None, tin: InputLayer | None) -> None:
        """One ``tran:Road`` per road wit_id in the road layer or among the road triangles."""
        fields: list[tuple[int, str, int]] = []
        with contextlib.ExitStack() as stack:
            road_rows: Iterator[tuple[str, Any]] = iter(())
            tri_rows: Iterator[tuple[str, Any]] = iter(())
            if roads:
                result = stack.enter_context(roads.select(order=(step_layers.WIT_ID,)))
                fields, key = fields_of(result), columns_of(result)[step_layers.WIT_ID]
                road_rows = ((k, next(g)) for k, g in groupby(result, key=lambda f: f.GetFieldAsString(key)))
            if tin:
                triangles = chain.from_iterable(
                    zip(bulk_read.texts(batch[step_layers.TIN_FEATURE_ID]), ids, poslists) for ids, poslists, batch in
                    tin_triangles(tin, ROAD_TRIANGLES, (step_layers.TIN_FEATURE_ID, step_layers.TIN_TRIANGLE_ID)))
                tri_rows = groupby(triangles, key=itemgetter(0))
            for wit_id, road, triangles in join_sorted(road_rows, tri_rows):
                self.road(checked_wit_id(wit_id, "A road"), road, fields, triangles)

    def road(self, wit_id: str, road: ogr.Feature | None, fields: list[tuple[int, str, int]],
             triangles: Iterator[tuple[str, str, str]] | None) -> None:
        """A road with its attributes and its triangles: (road wit_id, triangle id, posList) each."""
        with self.member(TRAN + "Road", wit_id):
            if road is not None:
                self.attributes(road, fields, {step_layers.WIT_ID})
            if triangles is not None:
                with self.el(TRAN + "trafficSpace"), self.el(TRAN + "TrafficSpace", {GML_ID: f"{wit_id}_space"}):
                    with self.el(CORE + "boundary"), self.el(TRAN + "TrafficArea", {GML_ID: f"{wit_id}_area"}), \
                            self.el(CORE + ROAD_LOD_PROPERTY), self.el(GML + "MultiSurface"):
                        for batch in _batches(triangles, self.RAW_BATCH):
                            self.raw("".join(f"\n<gml:surfaceMember>{_polygon_markup(gml_id, [poslist])}"
                                             "</gml:surfaceMember>" for _, gml_id, poslist in batch))
                            self.report.triangles += len(batch)
                            self.progress.tick(len(batch))
                    self.leaf(TRAN + "granularity", "way")
        self.report.roads += 1

    def relief(self, tin: InputLayer) -> None:
        """The TIN triangles not written as road surfaces, as one ``dem:TINRelief``."""
        where = f"NOT ({ROAD_TRIANGLES})"
        exists = f"SELECT EXISTS (SELECT 1 FROM {tin.table} WHERE {where})"  # nosec B608  # quoted layer, our where
        if not tin.scalar(exists):
            return
        with self.member(DEM + "ReliefFeature", RELIEF_ID):
            self.leaf(DEM + "lod", RELIEF_LOD)
            with self.el(DEM + "reliefComponent"), self.el(DEM + "TINRelief", {GML_ID: TIN_RELIEF_ID}):
                self.leaf(DEM + "lod", RELIEF_LOD)
                with self.el(DEM + "tin"), self.el(GML + "TriangulatedSurface", {GML_ID: TIN_SURFACE_ID}), \
                        self.el(GML + "patches"):
                    in_order = rises_in_table_order(tin, step_layers.TIN_TRIANGLE_ID)
                    for ids, poslists, _ in tin_triangles(tin, where, (step_layers.TIN_TRIANGLE_ID,),
                                                          _relief_rows if in_order else None):
                        self.raw("".join(
                            f'\n<gml:Triangle><gml:exterior><gml:LinearRing gml:id="{gml_id}_r">'
                            f'<gml:posList srsDimension="3">{poslist}'
                            "</gml:posList></gml:LinearRing></gml:exterior></gml:Triangle>"
                            for gml_id, poslist in zip(ids, poslists)))
                        self.report.triangles += len(ids)
                        self.progress.tick(len(ids))

    def groups(self, members: Membership) -> None:
        for wit_id, district, buildings in members.groups():
            with self.member(GRP + "CityObjectGroup", wit_id):
                index = district.GetFieldIndex(DISTRICT_NAME_FIELD)
                if index >= 0 and district.IsFieldSetAndNotNull(index):
                    self.leaf(GML + "name", clean_text(district.GetFieldAsString(index)))
                self.attributes(district, members.fields, {step_layers.WIT_ID})
                for building in buildings:
                    with self.el(GRP + "groupMember"), self.el(GRP + "Role"), \
                            self.el(GRP + "groupMember", {XLINK + "href": f"#{building}"}):
                        pass
                    self.report.group_members += 1
            self.report.groups += 1

    def appearance(self, texcoords: InputLayer, uris: dict[str, str]) -> None:
        """Per image one ``app:Appearance`` (``app_1``…) with its ``ParameterizedTexture`` (``tex_1``…)."""
        with texcoords.select(order=_TEXTURE_COLUMNS) as result:
            batches = bulk_read.batches(result, BULK)
            rows = chain.from_iterable(_texture_rows(batch, texcoords.path) for batch in batches)
            for number, (image, group) in enumerate(groupby(rows, key=itemgetter(0)), 1):
                # one appearanceMember per image: a reader (or validator) streaming member by member
                # then holds one image's associations, not the whole model's
                first = next(group)
                group, generated = chain([first], group), first[1] == step_layers.TEX_WALL
                self.xf.write("\n")
                with self.el(CORE + "appearanceMember"), self.el(APP + "Appearance", {GML_ID: f"app_{number}"}):
                    if generated:
                        self.leaf(GML + "description", FACADE_DESCRIPTION)
                    self.leaf(APP + "theme", FACADE_THEME if generated else APPEARANCE_THEME)
                    with self.el(APP + "surfaceData"), \
                            self.el(APP + "ParameterizedTexture", {GML_ID: f"tex_{number}"}):
                        self.leaf(APP + "imageURI", uris[image])
                        mime = mimetypes.guess_type(image)[0]
                        if mime:
                            self.leaf(APP + "mimeType", mime)
                        if generated:  # storey modules repeat along the wall
                            self.leaf(APP + "wrapMode", "wrap")
                        for target, target_rows in groupby(group, key=itemgetter(1)):
                            self.textured(target, target_rows, texcoords.path)
                self.report.textures += 1

    def textured(self, target: str, rows: Iterator[tuple[str, ...]], path: str) -> None:
        """Texture associations: one per roof or wall face / road triangle, one for all TIN triangles.

        ``rows``: (image, target, feature, face, uv) texts, uv checked and normalised (``_texture_rows``). The TIN's
        association lists the ring ids after all coordinates, so those ids (not the coordinates) are held for one
        image's terrain triangles. The associations' markup is ready-made (``raw``), a batch at a time.
        """
        if target not in step_layers.TEX_TARGETS:
            raise _unknown_target(target, path)
        refs: list[str] = []
        with contextlib.ExitStack() as stack:
            if target == "tin":
                stack.enter_context(self.association(f"#{TIN_SURFACE_ID}"))
            for batch in _batches(rows, self.RAW_BATCH):
                if target in ("roof", step_layers.TEX_WALL):
                    self.raw("".join(_ASSOCIATION.format(surface=xml_text(f"{row[2]}_f{row[3]}"), uv=row[4])
                                     for row in batch))
                elif target == "tin":
                    self.raw("".join(f"<app:textureCoordinates>{row[4]}</app:textureCoordinates>" for row in batch))
                    refs.extend(f"<app:ring>#tri_{escape(row[2])}_r</app:ring>" for row in batch)
                else:
                    self.raw("".join(_ASSOCIATION.format(surface=f"tri_{escape(row[2])}", uv=row[4]) for row in batch))
                self.report.textured_surfaces += len(batch)
                self.progress.tick(len(batch))
            for start in range(0, len(refs), self.RAW_BATCH):
                self.raw("".join(refs[start:start + self.RAW_BATCH]))

    @contextlib.contextmanager
    def association(self, target: str) -> Iterator[None]:
        """``app:TextureAssociation`` → ``app:TexCoordList``; the caller writes coordinates, then rings."""
        self.xf.write("\n")
        with self.el(APP + "textureParameterization"), self.el(APP + "TextureAssociation"):
            self.leaf(APP + "target", target)
            with self.el(APP + "textureParameterization"), self.el(APP + "TexCoordList"):
                yield


ROAD_TRIANGLES = f"\"{step_layers.TIN_SURFACE}\" = 'road' AND \"{step_layers.TIN_FEATURE_ID}\" IS NOT NULL"
"""Triangles written into their road's traffic area; every other triangle goes into the relief."""


def _relief_rows(batch: dict[str, np.ndarray]) -> np.ndarray:
    """The rows of a TIN batch that ``NOT (ROAD_TRIANGLES)`` selects, as SQLite decides it: a triangle with a road
    feature id and no surface is neither (NULL), so left out."""
    surface, feature = batch[step_layers.TIN_SURFACE], batch[step_layers.TIN_FEATURE_ID]
    known = bulk_read.valid(surface)
    other = known & (np.asarray(np.ma.getdata(surface)) != b"road")
    return ~bulk_read.valid(feature) | other


_ASSOCIATION = (
    "\n<app:textureParameterization><app:TextureAssociation><app:target>#{surface}</app:target>"
    "<app:textureParameterization><app:TexCoordList><app:textureCoordinates>{uv}</app:textureCoordinates>"
    "<app:ring>#{surface}_r</app:ring></app:TexCoordList></app:textureParameterization></app:TextureAssociation>"
    "</app:textureParameterization>")
"""What ``association`` writes for a face or a road triangle (its ring ``<surface>_r``), as ready-made markup."""


def join_sorted(left: Iterator[tuple[str, Any]], right: Iterator[tuple[str, Any]]
                 ) -> Iterator[tuple[str, Any, Any]]:
    """Full outer merge of two key-sorted streams with unique keys: (key, left or None, right or None)."""
    a, b = next(left, None), next(right, None)
    while a is not None or b is not None:
        if a is not None and (b is None or a[0] < b[0]):  # (b None: a is not)
            yield a[0], a[1], None
            a = next(left, None)
        elif b is not None and (a is None or b[0] < a[0]):  # (a None: b is not)
            yield b[0], None, b[1]
            b = next(right, None)
        elif a is not None and b is not None:  # (always, here: the same key on both sides)
            yield a[0], a[1], b[1]
            a, b = next(left, None), next(right, None)
