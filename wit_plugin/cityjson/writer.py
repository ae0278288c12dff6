"""CityJSON 2.0 writer (``wit:exportcityjson``, ``CITYJSON`` of ``wit:citymodel``): one ``.city.json`` file, or a
CityJSONSeq ``.city.jsonl`` (a CityJSON header line, then one ``CityJSONFeature`` a line) for a tile of a run.

The objects are ``objects.ModelObjects``'s, the CityGML writer's: ``Building`` with a LoD1 ``Solid`` whose
surfaces are ``GroundSurface`` / ``RoofSurface`` / ``WallSurface``, every generic attribute, ``height`` with
``heightStatus`` and its references (the CityGML's ``con:height``) and storeys; ``Road`` with its draped
triangles as a lod 2 ``MultiSurface`` of ``TrafficArea``; ``TINRelief`` (the other TIN triangles, a
``CompositeSurface``); a ``CityObjectGroup`` per legal dong, its buildings naming it in ``parents``.
Textures: the same images and texture coordinates, in the themes of the CityGML (``rgbTexture``: the
orthoimage, ``specific``; ``generatedFacade``: the walls, ``typical``, ``wrapMode`` wrap). Coordinates are
integers on the millimetre grid (``transform``); the CRS is ``metadata.referenceSystem`` (an OGC CRS URL),
with the extent and the lineage.

Memory and streaming: objects are written as they are read. In a ``.city.json`` the vertices and the (u, v)
pairs are global arrays after the objects, so they are spooled to temporary files as each object is
written and appended at the end: memory stays flat in the number of buildings (the TIN's relief is one
object, held while it is written; see ``objects``). In a ``.city.jsonl`` every feature carries its own
vertices and images. Either file is written atomically: a failed or cancelled run leaves none.
"""
from __future__ import annotations

import contextlib
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np

from ..citygml.inputs import CityGMLInputs, FacadeRows, Membership, ModelLayers
from ..citygml.writer import image_uri, srs_name_of
from ..infra import step_layers
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.gc_pause import collector_paused
from ..infra.io.fileio import atomic_file, copy_images
from .encoding import Transform, encode, geometry_text, json_text, uv_text, vertices_text
from .objects import THEMES, CityObject, ModelObjects

VERSION = "2.0"
SEQUENCE_SUFFIX = ".city.jsonl"
FILE_SUFFIXES = (".city.json", ".json")
TITLE = "WIT City Model: textured LoD1 city model"
LINEAGE = [{
    "source": [{"description": "The chain's step layers: LoD1 faces extruded from the building layer, the terrain "
                               "TIN from the DEM, prepared roads and legal dongs, textures cut from the orthoimage "
                               "and generated facades"}],
    "processStep": {"description": "Written by WIT City Model (QGIS plugin) beside its CityGML 3.0 model: the same "
                                   "objects, ids, attributes, semantics and textures"}}]
_IMAGE_TYPES = {".png": "PNG", ".jpg": "JPG", ".jpeg": "JPG"}


@dataclass(frozen=True)
class SequencePart:
    """A tile's share of a run's CityJSONSeq: the run's ``translate``, the suffix of the ids it shares with its
    neighbours (roads, relief, districts) and the path from the run's folder to its own (for image paths)."""

    translate: tuple[float, float, float]
    suffix: str
    folder: str


@dataclass
class CityJSONReport:
    """What was written, for the log and the tests."""

    path: str = ""
    buildings: int = 0
    roads: int = 0
    triangles: int = 0  # TIN triangles (relief and roads)
    groups: int = 0
    vertices: int = 0
    textures: int = 0  # texture images referred to
    features: int = 0  # CityJSONFeature lines (a sequence)
    counts: dict[str, int] = field(default_factory=dict)  # city objects by type


def is_sequence(path: str | Path) -> bool:
    return str(path).lower().endswith(SEQUENCE_SUFFIX)


def texture_folder_of(output: Path) -> Path:
    """``model.city.json`` → ``model_textures`` beside it (the CityGML's ``model.gml`` uses the same folder)."""
    name = output.name
    for suffix in (SEQUENCE_SUFFIX, *FILE_SUFFIXES):
        if name.lower().endswith(suffix):
            name = name[:-len(suffix)]
            break
    return output.parent / f"{name}_textures"


def crs_url(srs_name: str) -> str | None:
    """The OGC CRS URL CityJSON's ``referenceSystem`` wants, for an EPSG CRS in any form (else None)."""
    name = srs_name_of(srs_name)
    return f"https://www.opengis.net/def/crs/EPSG/0/{name[5:]}" if name.upper().startswith("EPSG:") else None


def header(srs_name: str, envelope: tuple[float, ...], transform: Transform) -> dict:
    """The CityJSON object without its city objects: version, transform, metadata."""
    metadata: dict = {"title": TITLE}
    url = crs_url(srs_name)
    if url:
        metadata["referenceSystem"] = url
    metadata["geographicalExtent"] = [round(v, 3) for v in envelope]
    metadata["lineage"] = LINEAGE
    return {"type": "CityJSON", "version": VERSION, "transform": transform.as_json(), "metadata": metadata}


def write_cityjson(inputs: CityGMLInputs, output: str, srs_name: str = "EPSG:5186", feedback: Feedback = SILENT,
                   copy_textures: bool = True, images_in: str | None = None,
                   part: SequencePart | None = None) -> CityJSONReport:
    """Write the model to ``output``: CityJSON (``.city.json``) or CityJSONSeq (``.city.jsonl``), atomically.

    Images: ``images_in`` names a folder that already holds them (the CityGML writer's copy) to refer to;
    else they are copied into ``<name>_textures`` beside the output (``copy_textures``), or referred to where
    they are. ``part``: the output is a tile's sequence of a run (its transform and id suffix; image paths
    from the run's folder).
    """
    out = Path(output)
    sequence = is_sequence(out)
    if not sequence and not out.name.lower().endswith(FILE_SUFFIXES):
        raise InputError(f"{out.name}: a CityJSON file ends with .city.json (CityJSONSeq: .city.jsonl).")
    if part is not None and not sequence:
        raise InputError(f"{out.name}: a tile's share of a run is written as a CityJSONSeq (.city.jsonl).")
    report = CityJSONReport(path=str(out))
    with contextlib.ExitStack() as stack:
        stack.enter_context(collector_paused())
        layers = ModelLayers.open(inputs, srs_name, stack)
        for name in layers.images:
            if Path(name).suffix.lower() not in _IMAGE_TYPES:
                raise InputError(f"Texture image {name} is neither PNG nor JPEG, the image types CityJSON allows.")
        transform = Transform(part.translate) if part else Transform.around(layers.envelope)
        names = sorted(layers.images)
        folder = Path(images_in) if images_in else texture_folder_of(out) if copy_textures else None
        uris = [image_uri(layers.images[name], name, out.parent, folder) for name in names]
        if part is not None:
            uris = [f"{part.folder.rstrip('/')}/{uri}" for uri in uris]
        textures = [_texture(name, uri) for name, uri in zip(names, uris)]
        members = stack.enter_context(Membership(layers.districts)) if layers.districts else None
        facades = (stack.enter_context(FacadeRows.open(Path(inputs.textures)))
                   if layers.texcoords and inputs.textures else None)  # (texcoords: read from inputs.textures)
        objects = ModelObjects(layers.lod1, layers.tin, layers.roads, members, layers.texcoords, facades,
                               {name: i for i, name in enumerate(names)}, part.suffix if part else "")
        total = sum(source.count() for source in (layers.lod1, layers.tin) if source) or 1
        progress = _Progress(feedback, total)
        tmp = stack.enter_context(atomic_file(out))
        with open(tmp, "w", encoding="utf-8") as fh:
            start = header(srs_name, layers.envelope, transform)
            if sequence:
                sink: _File | _Sequence = _Sequence(fh, start, transform, textures)
            else:
                spool = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix=".wit-cityjson-", dir=out.parent)))
                sink = _File(fh, start, transform, textures, *(stack.enter_context(
                    open(spool / name, "w+", encoding="utf-8")) for name in ("vertices", "uv")))
            for city_object in objects.all():
                sink.add(city_object)
                _count(report, city_object)
                progress.tick(sum(len(g.rings) for g in city_object.geometries) or 1)
            sink.close()
        report.vertices, report.features = sink.vertex_count, sink.features
        report.textures = len(textures)
        if folder is not None and not images_in:
            copy_images({name: layers.images[name] for name in names}, folder)
    feedback.progress(100.0)
    feedback.info(f"CityJSON: {report.buildings} buildings, {report.roads} roads, {report.triangles} TIN triangles, "
                  f"{report.groups} districts, {report.vertices} vertices, {report.textures} texture images"
                  + (f", {report.features} features" if sequence else ""))
    return report


def _texture(name: str, uri: str) -> dict:
    """The Texture Object of an image: the walls' generated facades repeat along the wall."""
    texture = {"type": _IMAGE_TYPES[Path(name).suffix.lower()], "image": uri}
    if Path(name).name.startswith(step_layers.FACADE_IMAGE_PREFIX):
        texture.update(wrapMode="wrap", textureType="typical")
    else:
        texture["textureType"] = "specific"
    return texture


def _count(report: CityJSONReport, city_object: CityObject) -> None:
    report.counts[city_object.type] = report.counts.get(city_object.type, 0) + 1
    if city_object.type == "Building":
        report.buildings += 1
    elif city_object.type == "Road":
        report.roads += 1
    elif city_object.type == "CityObjectGroup":
        report.groups += 1
    if city_object.type in ("Road", "TINRelief"):
        report.triangles += sum(len(g.rings) for g in city_object.geometries)


def object_text(city_object: CityObject, geometries: list[Iterator[str]]) -> Iterator[str]:
    """``"id":{…}`` of a city object, each of its geometries given as text pieces."""
    members: dict[str, object] = {"type": city_object.type}
    if city_object.attributes:
        members["attributes"] = city_object.attributes
    if city_object.parents:
        members["parents"] = city_object.parents
    if city_object.children is not None:
        members["children"] = city_object.children
    text = json_text(members)
    yield f"{json_text(city_object.id)}:{text[:-1]}"
    if geometries:
        yield ',"geometry":['
        for number, pieces in enumerate(geometries):
            yield "," if number else ""
            yield from pieces
        yield "]"
    yield "}"


class _File:
    """One CityJSON object: city objects as they come, then the vertices and (u, v) pairs spooled meanwhile."""

    def __init__(self, fh: IO[str], start: dict, transform: Transform, textures: list[dict], vertices: IO[str],
                 uv: IO[str]):
        self.fh, self.transform, self.textures, self.vertices, self.uv = fh, transform, textures, vertices, uv
        self.vertex_count = self.uv_count = self.features = 0
        self.first = True
        fh.write(json_text(start)[:-1] + ',"CityObjects":{')

    def add(self, city_object: CityObject) -> None:
        texts = []
        for geometry in city_object.geometries:
            encoded = encode(geometry, self.transform)
            texts.append(geometry_text(geometry, encoded, self.vertex_count, self.uv_count))
            _append(self.vertices, vertices_text(encoded.vertices), self.vertex_count)
            _append(self.uv, uv_text(encoded.uv), self.uv_count)
            self.vertex_count += len(encoded.vertices)
            self.uv_count += len(encoded.uv)
        self.fh.write("\n" if self.first else ",\n")
        self.fh.writelines(object_text(city_object, texts))
        self.first = False

    def close(self) -> None:
        self.fh.write('\n},"vertices":[')
        _copy(self.vertices, self.fh)
        self.fh.write("]")
        if self.textures:
            self.fh.write(f',"appearance":{{"default-theme-texture":"{THEMES[0]}","textures":'
                          f'{json_text(self.textures)},"vertices-texture":[')
            _copy(self.uv, self.fh)
            self.fh.write("]}")
        self.fh.write("}\n")


class _Sequence:
    """A CityJSONSeq: the header line, then each city object as a ``CityJSONFeature`` with its own vertices and
    images (a district's group is a feature of its own, its buildings in theirs)."""

    def __init__(self, fh: IO[str], start: dict, transform: Transform, textures: list[dict]):
        self.fh, self.transform, self.textures = fh, transform, textures
        self.vertex_count = self.features = 0
        fh.write(json_text({**start, "CityObjects": {}, "vertices": []}) + "\n")

    def add(self, city_object: CityObject) -> None:
        fh, geometries = self.fh, city_object.geometries
        images = [g.image[g.image >= 0] for g in geometries if g.image is not None]
        used = np.unique(np.concatenate(images)) if images else np.zeros(0, dtype=np.int64)
        local = np.full(len(self.textures), -1, dtype=np.int64)
        local[used] = np.arange(len(used))
        encoded = [encode(geometry, self.transform) for geometry in geometries]
        vertex_offsets = np.r_[0, np.cumsum([len(e.vertices) for e in encoded])].tolist()
        uv_offsets = np.r_[0, np.cumsum([len(e.uv) for e in encoded])].tolist()
        texts = [geometry_text(g, e, v, u, local) for g, e, v, u in zip(geometries, encoded, vertex_offsets,
                                                                       uv_offsets)]
        fh.write(f'{{"type":"CityJSONFeature","id":{json_text(city_object.id)},"CityObjects":{{')
        fh.writelines(object_text(city_object, texts))
        fh.write('},"vertices":[')
        fh.write(",".join(text for e in encoded for text in vertices_text(e.vertices) if text))
        fh.write("]")
        if len(used):
            fh.write(f',"appearance":{{"default-theme-texture":"{THEMES[0]}","textures":'
                     f'{json_text([self.textures[i] for i in used.tolist()])},"vertices-texture":[')
            fh.write(",".join(text for e in encoded for text in uv_text(e.uv) if text))
            fh.write("]}")
        fh.write("}\n")
        self.vertex_count += vertex_offsets[-1]
        self.features += 1

    def close(self) -> None:
        """Nothing to add: every line is complete."""


def _append(spool: IO[str], pieces: Iterator[str], before: int) -> None:
    for piece in pieces:
        if piece:
            spool.write("," if before else "")
            spool.write(piece)
            before = 1


def _copy(spool: IO[str], fh: IO[str]) -> None:
    spool.seek(0)
    shutil.copyfileobj(spool, fh, 1 << 20)


class _Progress:
    def __init__(self, feedback: Feedback, total: int):
        self.feedback, self.total, self.done, self.next = feedback, total, 0, 0

    def tick(self, count: int) -> None:
        self.done += count
        if self.done >= self.next:
            self.feedback.check_canceled()
            self.feedback.progress(min(99.0, 100.0 * self.done / self.total))
            self.next = self.done + 10_000

