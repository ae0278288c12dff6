"""The web profile of a tileset: each tile's geometry quantized and compressed for the browser.

Every ``.glb`` keeps its materials, images (the same JPEG/PNG files) and building metadata; only
its vertex and index data change (glTF extensions, both *required*, so a reader either decodes
them or refuses the tile — QGIS's 3D Tiles layer reads neither, hence the default stays plain):

* ``KHR_mesh_quantization``: positions on a 16-bit grid of the tile (one uniform step, carried by
  the node's ``scale`` and ``translation``, so normals are not skewed), when that step is at most
  ``MAX_POSITION_STEP`` (a 256 m leaf: 4 mm, so within 2 mm of the plain profile); larger tiles keep
  float positions. Normals as signed bytes, texture coordinates as 16-bit fractions of the image
  (when they lie in [0, 1]); those of a generated facade, which repeat along the wall (u up to a module
  count), as 16-bit steps of 1/``REPEAT_STEPS`` from their least value, scaled back by their material's
  ``KHR_texture_transform`` (then required too); feature ids stay float (exact).
* ``EXT_meshopt_compression``: each attribute and index buffer encoded with meshoptimizer's codecs
  (vertex codec version 0, index codec ``TRIANGLES``), after meshoptimizer's vertex-cache order and
  first-use vertex order (the triangles are the same, in another order). A ``fallback`` buffer
  without data stands for the decoded bytes, as the extension specifies.

meshoptimizer (MIT) comes from PyPI's ``meshoptimizer`` package (the library's own Python bindings,
built from source on install); it is needed only when the web profile is asked for.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pygltflib as gl

from ..infra.deps import require
from ..infra.feedback import SILENT, Feedback
from ..infra.io.fileio import atomic_file
from .glb import glb_bytes

MESHOPT = "EXT_meshopt_compression"
QUANTIZATION = "KHR_mesh_quantization"
TEXTURE_TRANSFORM = "KHR_texture_transform"
REPEAT_STEPS = 512  # steps per image width of repeating texture coordinates: 1.25 cm on a 6.4 m facade module
MAX_POSITION_STEP = 0.04  # m: half of it (2 cm) stays inside the regions' margins (6 cm, 10 cm)
ALIGN = 8
_GRID = 65535
_DTYPE = {gl.FLOAT: np.float32, gl.UNSIGNED_INT: np.uint32, gl.UNSIGNED_SHORT: np.uint16}
_WIDTH = {gl.SCALAR: 1, gl.VEC2: 2, gl.VEC3: 3}


def require_web_profile() -> None:
    """Raise ``MissingDependencyError`` (with the install command) when meshoptimizer is missing."""
    require(("meshoptimizer",))


def compress_tiles(folder: Path, feedback: Feedback = SILENT) -> int:
    """Every .glb under ``folder`` in the web profile, each replaced whole; returns the number of files."""
    files = sorted(Path(folder).rglob("*.glb"))
    for file in files:
        feedback.check_canceled()
        compressed = compress_glb(file.read_bytes())
        with atomic_file(file) as tmp:
            tmp.write_bytes(compressed)
    return len(files)


def compress_glb(data: bytes) -> bytes:
    """The web profile of one tile's .glb (as written by ``GlbBuilder``)."""
    require_web_profile()
    import meshoptimizer

    meshoptimizer.encode_vertex_version(0)  # EXT_meshopt_compression reads version 0 only
    gltf = gl.GLTF2.load_from_bytes(data)
    blob = gltf.binary_blob()
    primitives = gltf.meshes[0].primitives if gltf.meshes else []
    geometry = {a for p in primitives for a in [p.indices, *_attributes(p).values()]}
    geometry_views = {gltf.accessors[a].bufferView for a in geometry}
    writer = _Buffers()
    kept = {}
    for view_number, view in enumerate(gltf.bufferViews):  # images and metadata: as they are
        if view_number not in geometry_views:
            kept[view_number] = writer.plain(blob[view.byteOffset or 0:(view.byteOffset or 0) + view.byteLength])
    _renumber_views(gltf, kept)

    positions = [_read(gltf, blob, p.attributes.POSITION) for p in primitives]
    origin, step = _position_grid(positions)
    accessors: list[gl.Accessor] = []
    extensions = {MESHOPT, QUANTIZATION}
    for primitive, position in zip(primitives, positions):
        indices = _read(gltf, blob, primitive.indices).ravel().astype(np.uint32)
        order = np.empty_like(indices)
        meshoptimizer.optimize_vertex_cache(order, indices, len(indices), len(position))
        keep = order[np.sort(np.unique(order, return_index=True)[1])]  # the vertices in order of first use
        number = np.empty(len(position), dtype=np.uint32)
        number[keep] = np.arange(len(keep), dtype=np.uint32)
        indices = number[order]
        for name, accessor in _attributes(primitive).items():
            values = position if name == "POSITION" else _read(gltf, blob, accessor)[keep]
            if name == "POSITION":
                values = values[keep]
            elif name == "TEXCOORD_0" and (values.min() < 0.0 or values.max() > 1.0):
                values = _repeating(gltf.materials[primitive.material], values)
                if values.dtype == np.uint16:
                    extensions.add(TEXTURE_TRANSFORM)
            setattr(primitive.attributes, name, writer.attribute(accessors, meshoptimizer, name, values, origin, step))
        primitive.indices = writer.indices(accessors, meshoptimizer, indices, len(keep))
    gltf.accessors = accessors
    gltf.bufferViews = [view for _, view in sorted(writer.views.items())]
    if origin is not None and step is not None:
        gltf.nodes[0].translation, gltf.nodes[0].scale = [float(v) for v in origin], [float(step)] * 3
    gltf.extensionsUsed = sorted(set(gltf.extensionsUsed or []) | extensions)
    gltf.extensionsRequired = sorted(set(gltf.extensionsRequired or []) | extensions)
    writer.blob.extend(b"\0" * (-len(writer.blob) % 4))
    gltf.buffers = [gl.Buffer(byteLength=len(writer.blob)),
                    gl.Buffer(byteLength=writer.fallback, extensions={MESHOPT: {"fallback": True}})]
    return glb_bytes(gltf, bytes(writer.blob))  # (pygltflib's own writer would merge the fallback buffer in)


def _repeating(material: gl.Material, uv: np.ndarray) -> np.ndarray:
    """Repeating texture coordinates as 16-bit steps from their least value, the material's base colour texture
    transformed back (its material is this primitive's alone, as ``GlbBuilder`` writes them); as they are when
    their span needs more than 16 bits."""
    low = np.floor(uv.min(axis=0) * REPEAT_STEPS) / REPEAT_STEPS
    steps = np.rint((uv - low) * REPEAT_STEPS)
    if steps.max() > _GRID:
        return uv
    info = material.pbrMetallicRoughness.baseColorTexture
    info.extensions = {**(info.extensions or {}),
                       TEXTURE_TRANSFORM: {"offset": [float(v) for v in low], "scale": [1 / REPEAT_STEPS] * 2}}
    return steps.astype(np.uint16)


def _attributes(primitive: gl.Primitive) -> dict[str, int]:
    return {name: index for name, index in vars(primitive.attributes).items() if index is not None}


def _read(gltf: gl.GLTF2, blob: bytes, index: int) -> np.ndarray:
    accessor = gltf.accessors[index]
    view = gltf.bufferViews[accessor.bufferView]
    width = _WIDTH[accessor.type]
    return np.frombuffer(blob, dtype=_DTYPE[accessor.componentType], count=accessor.count * width,
                         offset=(view.byteOffset or 0) + (accessor.byteOffset or 0)).reshape(accessor.count, width)


def _position_grid(positions: list[np.ndarray]) -> tuple[np.ndarray | None, float | None]:
    """(origin, step) of the tile's 16-bit position grid, or (None, None) when the step would exceed
    ``MAX_POSITION_STEP`` (positions then stay float)."""
    if not positions:
        return None, None
    points = np.concatenate(positions).astype(np.float64)
    lo, hi = points.min(axis=0), points.max(axis=0)
    step = max(float((hi - lo).max()) / _GRID, 1e-6)
    return (lo, step) if step <= MAX_POSITION_STEP else (None, None)


def _renumber_views(gltf: gl.GLTF2, kept: dict[int, int]) -> None:
    """Point images and property tables at the kept buffer views' new numbers."""
    for image in gltf.images:
        if image.bufferView is not None:
            image.bufferView = kept[image.bufferView]
    metadata = (gltf.extensions or {}).get("EXT_structural_metadata")
    for table in (metadata or {}).get("propertyTables", []):
        for spec in table["properties"].values():
            for key in ("values", "stringOffsets", "arrayOffsets"):
                if key in spec:
                    spec[key] = kept[spec[key]]


class _Buffers:
    """The new binary chunk (compressed geometry and the plain views) and the fallback buffer's size."""

    def __init__(self) -> None:
        self.blob = bytearray()
        self.views: dict[int, gl.BufferView] = {}
        self.fallback = 0

    def _append(self, data: bytes) -> int:
        self.blob.extend(b"\0" * (-len(self.blob) % ALIGN))
        offset = len(self.blob)
        self.blob.extend(data)
        return offset

    def plain(self, data: bytes) -> int:
        number = len(self.views)
        self.views[number] = gl.BufferView(buffer=0, byteOffset=self._append(data), byteLength=len(data))
        return number

    def _compressed(self, encoded: bytes, count: int, stride: int, mode: str, target: int) -> int:
        offset = self._append(encoded)
        self.fallback += -self.fallback % ALIGN
        view = gl.BufferView(buffer=1, byteOffset=self.fallback, byteLength=count * stride, target=target,
                             byteStride=stride if mode == "ATTRIBUTES" else None,
                             extensions={MESHOPT: {"buffer": 0, "byteOffset": offset, "byteLength": len(encoded),
                                                   "byteStride": stride, "mode": mode, "count": count}})
        self.fallback += count * stride
        number = len(self.views)
        self.views[number] = view
        return number

    def attribute(self, accessors: list[gl.Accessor], codec, name: str, values: np.ndarray,
                  origin: np.ndarray | None, step: float | None) -> int:
        """One vertex attribute, quantized where its kind allows, as a compressed view; its accessor number."""
        accessor = gl.Accessor(count=len(values), type=_TYPE[values.shape[1]], componentType=gl.FLOAT)
        if name == "POSITION" and step is not None:
            values = np.rint((values - origin) / step).clip(0, _GRID).astype(np.uint16)
            accessor.componentType = gl.UNSIGNED_SHORT
        elif name == "NORMAL":
            values = np.rint(np.clip(values, -1.0, 1.0) * 127).astype(np.int8)
            accessor.componentType, accessor.normalized = gl.BYTE, True
        elif name.startswith("TEXCOORD") and values.dtype == np.uint16:  # repeating: steps of a transform
            accessor.componentType = gl.UNSIGNED_SHORT
        elif name.startswith("TEXCOORD") and values.min() >= 0.0 and values.max() <= 1.0:
            values = np.rint(values * _GRID).astype(np.uint16)
            accessor.componentType, accessor.normalized = gl.UNSIGNED_SHORT, True
        if name == "POSITION":
            accessor.min, accessor.max = values.min(axis=0).tolist(), values.max(axis=0).tolist()
            if values.dtype == np.float32:
                accessor.min, accessor.max = [float(v) for v in accessor.min], [float(v) for v in accessor.max]
        rows = np.ascontiguousarray(values).view(np.uint8).reshape(len(values), -1)
        stride = -rows.shape[1] % 4 + rows.shape[1]  # vertex attributes are 4-byte aligned
        padded = np.zeros((len(rows), stride), dtype=np.uint8)
        padded[:, :rows.shape[1]] = rows
        accessor.bufferView = self._compressed(codec.encode_vertex_buffer(padded), len(values), stride, "ATTRIBUTES",
                                               gl.ARRAY_BUFFER)
        accessors.append(accessor)
        return len(accessors) - 1

    def indices(self, accessors: list[gl.Accessor], codec, indices: np.ndarray, vertices: int) -> int:
        size = 2 if vertices < 65536 else 4
        encoded = codec.encode_index_buffer(indices.astype(np.uint32), len(indices), vertices)
        view = self._compressed(encoded, len(indices), size, "TRIANGLES", gl.ELEMENT_ARRAY_BUFFER)
        accessors.append(gl.Accessor(bufferView=view, count=len(indices), type=gl.SCALAR,
                                     componentType=gl.UNSIGNED_SHORT if size == 2 else gl.UNSIGNED_INT))
        return len(accessors) - 1


_TYPE = {1: gl.SCALAR, 2: gl.VEC2, 3: gl.VEC3}
