"""The checks of a CityJSON model, fed a document (a ``.city.json``, or a sequence's header) and features.

Geometry is checked by the CityGML validator's own code (``citygml.validation.geometry``: solids in
batches; TIN triangles' areas) in local metres of the file's CRS, x (easting, longitude) first as CityJSON
prescribes; ids, references, vertex indices, semantics and textures here.
"""
from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..citygml.validation.crs import frame_of
from ..citygml.validation.geometry import SolidBatch, SolidCheck, Where, triangle_areas
from ..citygml.validation.names import IssueList
from ..infra.feedback import Feedback
from . import schema

_REMOTE = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]+://")
_EPSG_URL = re.compile(r"(?i)^https?://www\.opengis\.net/def/crs/EPSG/[\d.]+/(\d+)$")
_SURFACE_DEPTH: dict[object, int] = {"MultiSurface": 0, "CompositeSurface": 0, "Solid": 1, "MultiSolid": 2,
                                     "CompositeSolid": 2}  # (looked up with any JSON value)
_SOLID_BATCH = 2_000  # solids checked together


class ModelCheck:
    """Every check but the reading; issues go to ``issues``."""

    def __init__(self, issues: IssueList, images: tuple[Path, str], tolerances: tuple[float, float, float],
                 feedback: Feedback):
        """``images``: the folder relative image paths start from, and a prefix they have there is removed."""
        self.issues, self.feedback = issues, feedback
        self.image_folder, self.image_prefix = images
        self.planarity_tol, self.vertex_tol, self.min_area = tolerances
        self.schema = schema.available()
        self.scale, self.translate = np.ones(3), np.zeros(3)
        self.frame = frame_of(None)
        self.ids: set[str] = set()
        self.links: list[tuple[str, str, str, int | None]] = []  # (object, "parents"/"children", other, line)
        self.images: dict[str, bool] = {}  # image path → exists
        self.solids: list[tuple[Where, list[list[np.ndarray]], list[Where]]] = []  # faces: their rings

    # documents and features ----------------------------------------------------------------------
    def document(self, document: dict, line: int | None) -> None:
        """A CityJSON object: a whole file, or a sequence's first line (its city objects then empty)."""
        self._schema({**document, "CityObjects": {}}, schema.DOCUMENT, "the file", line)  # objects: one by one
        transform = document.get("transform")
        if isinstance(transform, dict):
            try:
                self.scale = np.asarray(transform["scale"], dtype=np.float64).reshape(3)
                self.translate = np.asarray(transform["translate"], dtype=np.float64).reshape(3)
            except (KeyError, TypeError, ValueError):
                pass  # the schema says what is wrong
        reference = (document.get("metadata") or {}).get("referenceSystem") if isinstance(
            document.get("metadata"), dict) else None
        code = _EPSG_URL.match(reference) if isinstance(reference, str) else None
        self.frame = frame_of(f"EPSG:{code.group(1)}" if code else reference)
        if self.frame.assumed:
            self.issues.add("crs", line, None, f"CRS {reference!r}: {self.frame.assumed}; the geometric tolerances "
                            "take the coordinates as metres.", "warning")
        self._objects(document, line)

    def feature(self, feature: dict, line: int | None) -> None:
        """A CityJSONFeature of a sequence: its own vertices and appearance."""
        self._schema({**feature, "CityObjects": {}}, schema.FEATURE, f"line {line}", line)
        objects = feature.get("CityObjects")
        if isinstance(objects, dict) and feature.get("id") not in objects:
            self.issues.add("reference", line, str(feature.get("id")), f"The feature's id {feature.get('id')!r} "
                            "names none of its city objects.")
        self._objects(feature, line)

    def finish(self) -> None:
        self._run_solids()
        for owner, kind, other, line in self.links:
            if other not in self.ids:
                self.issues.add("reference", line, owner, f"{owner} lists {other!r} among its {kind}, which is no "
                                "city object of this file.")
        listed = {(owner, kind, other) for owner, kind, other, _ in self.links}
        for owner, kind, other, line in self.links:
            back = "children" if kind == "parents" else "parents"
            if other in self.ids and (other, back, owner) not in listed:
                self.issues.add("reference", line, owner, f"{owner} lists {other!r} among its {kind}, but {other} "
                                f"does not list {owner} among its {back}.")

    # the parts ----------------------------------------------------------------------------------------
    def _schema(self, value: object, ref: str, where: str, line: int | None, owner: str | None = None) -> None:
        if not self.schema:
            return
        try:
            if ref == schema.OBJECTS:
                schema.check_city_object(value, where)
            else:
                schema.check(value, ref, where)
        except schema.SchemaError as exc:
            self.issues.add("schema", line, owner, f"{exc.where}: {exc.message}")

    def _objects(self, container: dict, line: int | None) -> None:
        vertices = self._vertices(container.get("vertices"), line)
        appearance = container.get("appearance")
        if not isinstance(appearance, dict):
            appearance = {}
        textures = appearance.get("textures")
        if not isinstance(textures, list):
            textures = []
        uv_count = len(appearance.get("vertices-texture") or [])
        for texture in textures:
            self._image(texture.get("image") if isinstance(texture, dict) else None, line)
        objects = container.get("CityObjects")
        if not isinstance(objects, dict):
            return
        for object_id, city_object in objects.items():
            self.feedback.check_canceled()
            self._schema(city_object, schema.OBJECTS, f"CityObjects.{object_id}", line, object_id)
            if object_id in self.ids:
                self.issues.add("duplicate-id", line, object_id, f"City object id '{object_id}' is used more than "
                                "once; every id must be unique in the model.")
            self.ids.add(object_id)
            if not isinstance(city_object, dict):
                continue
            for kind in ("parents", "children"):
                for other in city_object.get(kind) or []:
                    self.links.append((object_id, kind, str(other), line))
            for number, geometry in enumerate(city_object.get("geometry") or []):
                if isinstance(geometry, dict):
                    self._geometry(object_id, city_object.get("type"), number, geometry, vertices,
                                   len(textures), uv_count, line)

    def _vertices(self, vertices: object, line: int | None) -> np.ndarray:
        try:
            array = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
        except (TypeError, ValueError):
            self.issues.add("vertices", line, None, "The vertices are not a list of [x, y, z] numbers.")
            return np.zeros((0, 3))
        return array * self.scale + self.translate

    def _image(self, uri: object, line: int | None) -> None:
        if not isinstance(uri, str) or uri in self.images:
            return
        if _REMOTE.match(uri):
            self.images[uri] = True
            self.issues.add("texture-image", line, None, f"Texture image {uri} is remote and was not checked.",
                            "warning")
            return
        path = self.image_folder / (uri[len(self.image_prefix):] if uri.startswith(self.image_prefix) else uri)
        self.images[uri] = path.is_file()
        if not self.images[uri]:
            self.issues.add("texture-image", line, None, f"Texture image '{uri}' does not exist (looked for {path}).")

    def _geometry(self, object_id: str, object_type: object, number: int, geometry: dict, vertices: np.ndarray,
                  textures: int, uv_count: int, line: int | None) -> None:
        depth = _SURFACE_DEPTH.get(geometry.get("type"))
        boundaries = geometry.get("boundaries")
        if depth is None or not isinstance(boundaries, list):
            return  # points and lines: the schema checks their form
        label = f"{object_id} geometry {number}"
        try:
            shells = list(_surfaces_of(boundaries, depth))  # [(shell, [surface rings])]
            rings = [np.asarray(ring, dtype=np.int64) for _, surface in shells for ring in surface]
        except (TypeError, ValueError):
            return  # not lists of integers: the schema says so
        if any(len(r) and (r.min() < 0 or r.max() >= len(vertices)) for r in rings):
            self.issues.add("vertex-index", line, object_id, f"{label} refers to a vertex that does not exist "
                            f"(the file has {len(vertices)}).")
            return
        surfaces = [surface for _, surface in shells]
        self._semantics(geometry.get("semantics"), len(surfaces), label, object_id, line)
        self._textures(geometry.get("texture"), depth, surfaces, textures, uv_count, label, object_id, line)
        if geometry.get("type") == "Solid":
            faces = [[vertices[r] for r in surface] for surface in surfaces]
            self.solids.append((Where(line, object_id, label), faces,
                                [Where(line, object_id, f"{label} surface {k}") for k in range(len(faces))]))
            if len(self.solids) >= _SOLID_BATCH:
                self._run_solids()
        elif object_type == "TINRelief":
            self._triangles(surfaces, vertices, label, object_id, line)

    def _semantics(self, semantics: object, count: int, label: str, object_id: str, line: int | None) -> None:
        if not isinstance(semantics, dict):
            return
        kinds = len(semantics.get("surfaces") or [])
        values = list(_flatten(semantics.get("values") or []))
        if len(values) != count or any(v is not None and not 0 <= v < kinds for v in values
                                       if isinstance(v, int)):
            self.issues.add("semantics", line, object_id, f"{label}: its semantic values do not give each of its "
                            f"{count} surfaces one of its {kinds} semantic surfaces (or null).")

    def _textures(self, texture: object, depth: int, surfaces: list[list[np.ndarray]], textures: int, uv_count: int,
                  label: str, object_id: str, line: int | None) -> None:
        if not isinstance(texture, dict):
            return
        for theme, content in texture.items():
            values = content.get("values") if isinstance(content, dict) else None
            try:
                given = [surface for _, surface in _surfaces_of(values, depth)] if isinstance(values, list) else None
            except (TypeError, ValueError):
                given = None
            if given is None or [len(s) for s in given] != [len(s) for s in surfaces]:
                self.issues.add("texture-coordinates", line, object_id, f"{label}: the texture values of theme "
                                f"'{theme}' do not follow its boundaries (a list per ring of each surface).")
                continue
            for k, (rings, values_of_rings) in enumerate(zip(surfaces, given)):
                for ring, value in zip(rings, values_of_rings):
                    if not value or value[0] is None:
                        continue
                    bad = len(value) != len(ring) + 1 or not all(isinstance(v, int) for v in value) \
                        or not 0 <= value[0] < textures or any(not 0 <= v < uv_count for v in value[1:])
                    if bad:
                        self.issues.add("texture-coordinates", line, object_id, f"{label} surface {k}, theme "
                                        f"'{theme}': {value[:8]} is not a texture (of {textures}) and one "
                                        f"texture vertex (of {uv_count}) per corner of its {len(ring)}-corner ring.")
                        return

    def _triangles(self, surfaces: list[list[np.ndarray]], vertices: np.ndarray, label: str, object_id: str,
                   line: int | None) -> None:
        """A TIN's triangles: one ring of 3 corners each, with an area above the minimum."""
        triangles = [rings[0] for rings in surfaces if len(rings) == 1 and len(rings[0]) == 3]
        if len(triangles) < len(surfaces):
            self.issues.add("degenerate-triangle", line, object_id, f"{label}: {len(surfaces) - len(triangles)} "
                            "surface(s) of the TIN are not triangles (one ring of 3 corners).")
        if not triangles:
            return
        areas, swapped = triangle_areas(vertices[np.array(triangles)], [self.frame] * len(triangles))
        for k in np.flatnonzero(areas <= self.min_area)[:50].tolist():
            self.issues.add("degenerate-triangle", line, object_id, f"{label} triangle {k} is degenerate (area "
                            f"{areas[k]:.3g} m² ≤ {self.min_area:g} m²): its corners coincide or are collinear.")

    def _run_solids(self) -> None:
        """The solids gathered so far, checked together by the CityGML validator's ``SolidCheck``."""
        if not self.solids:
            return
        rings: list[np.ndarray] = []
        ring_face: list[int] = []
        face_solid: list[int] = []
        wheres: list[Where] = []
        for s, (_, faces, face_wheres) in enumerate(self.solids):
            for face, ring_list in enumerate(faces):
                for ring in ring_list:
                    rings.append(np.vstack([ring, ring[:1]]) if len(ring) else ring)
                    ring_face.append(len(face_solid))
                face_solid.append(s)
                wheres.append(face_wheres[face])
        batch = SolidBatch(solids=[where for where, _, _ in self.solids], frames=[self.frame] * len(self.solids),
                           points=np.concatenate(rings) if rings else np.zeros((0, 3)),
                           ring_len=np.array([len(r) for r in rings], dtype=np.int64),
                           ring_face=np.array(ring_face, dtype=np.int64),
                           face_solid=np.array(face_solid, dtype=np.int64), face_where=wheres.__getitem__)
        SolidCheck(batch, self.issues, self.vertex_tol, self.planarity_tol).run()
        self.solids = []


def _surfaces_of(boundaries: list, depth: int) -> Iterator[tuple[int, list]]:
    """(shell number, the surface's rings) of every surface, ``depth`` list levels above the surfaces."""
    if depth == 0:
        for surface in boundaries:
            if not isinstance(surface, list):
                raise TypeError("not a surface")
            yield 0, surface
        return
    for number, part in enumerate(boundaries):
        for _, surface in _surfaces_of(part, depth - 1):
            yield number, surface


def _flatten(values: list) -> Iterator[object]:
    for value in values:
        if isinstance(value, list):
            yield from _flatten(value)
        else:
            yield value
