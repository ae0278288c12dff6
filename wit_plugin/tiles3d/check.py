"""Our own check of a written tileset: what the official 3D Tiles validator (CesiumGS
``3d-tiles-validator``, not on a package registry) checks of our files, so that tests and users can
run it anywhere.

* **Metadata** (``EXT_structural_metadata``, ``EXT_mesh_features``) of every glTF: each property of a
  class is in each of its property tables — a missing one is tolerated only for a non-numeric, not
  required property whose class gives its ``default`` (the validator 0.6.1 rejects any missing numeric
  property, ``default`` or not) —; types and component types known, ``noData``/``default`` of the
  property's type; buffer views of the table's ``count`` (values, string offsets ascending and ending
  at the values' length), aligned to their component; no empty buffer view; feature ids integers in
  the table's rows, no more distinct ones than ``featureCount``.
* **Structure** of the tileset and of every external tileset it refers to: each content on disk, each
  region well formed and holding its children's regions, errors not growing downwards, transforms
  of 16 finite numbers.

``check_tileset`` returns a ``TilesetCheck``: the problems (empty when all is well) and what was seen.
"""
from __future__ import annotations

import json
import math
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from typing import TypeGuard  # (Python 3.10; annotations only)

METADATA = "EXT_structural_metadata"
MESH_FEATURES = "EXT_mesh_features"
COMPONENT_BYTES = {"INT8": 1, "UINT8": 1, "INT16": 2, "UINT16": 2, "INT32": 4, "UINT32": 4, "INT64": 8, "UINT64": 8,
                   "FLOAT32": 4, "FLOAT64": 8}
COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
NUMERIC = set(COMPONENTS)
_ACCESSOR_DTYPE = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_ACCESSOR_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
_ID = re.compile(r"^[a-zA-Z_][a-zA-Z0-9_]*$")
REGION_TOLERANCE_RAD = 1e-9
REGION_TOLERANCE_M = 1e-3


@dataclass
class TilesetCheck:
    problems: list[str] = field(default_factory=list)
    tilesets: dict[str, int] = field(default_factory=dict)
    """Each tileset file (relative path) → its bytes."""
    tiles: int = 0
    contents: int = 0
    property_tables: int = 0


def read_glb(data: bytes) -> tuple[dict, bytes]:
    """The JSON and the binary chunk of a .glb; ValueError if it is not one."""
    if len(data) < 20 or data[:4] != b"glTF":
        raise ValueError("not a binary glTF (no 'glTF' magic)")
    _magic, version, length = struct.unpack_from("<III", data, 0)
    if version != 2 or length != len(data):
        raise ValueError(f"glTF version {version}, length {length} for {len(data)} bytes")
    chunk_length, chunk_type = struct.unpack_from("<II", data, 12)
    if chunk_type != 0x4E4F534A:
        raise ValueError("the first chunk is not JSON")
    document = json.loads(data[20:20 + chunk_length].decode("utf-8"))
    blob = b""
    offset = 20 + chunk_length
    if offset + 8 <= len(data):
        blob_length, blob_type = struct.unpack_from("<II", data, offset)
        if blob_type == 0x004E4942:
            blob = data[offset + 8:offset + 8 + blob_length]
    return document, blob


def check_glb_metadata(gltf: dict, blob: bytes) -> tuple[list[str], int]:
    """Problems of one glTF's metadata and feature ids; (problems, property tables seen)."""
    problems: list[str] = []
    views = gltf.get("bufferViews", [])
    for k, view in enumerate(views):
        if view.get("byteLength", 0) < 1:
            problems.append(f"bufferView {k} has byteLength {view.get('byteLength')} (glTF: at least 1)")
    metadata = gltf.get("extensions", {}).get(METADATA)
    tables = []
    if metadata is not None:
        if METADATA not in gltf.get("extensionsUsed", []):
            problems.append(f"{METADATA} is used but not in extensionsUsed")
        classes = metadata.get("schema", {}).get("classes", {})
        for class_name, cls in classes.items():
            problems += _check_class(class_name, cls)
        tables = metadata.get("propertyTables", [])
        for t, table in enumerate(tables):
            cls = classes.get(table.get("class"))
            if cls is None:
                problems.append(f"propertyTables[{t}]: class {table.get('class')!r} is not in the schema")
                continue
            problems += [f"propertyTables[{t}] ({table['class']}): {p}" for p in _check_table(table, cls, views, blob)]
    for m, mesh in enumerate(gltf.get("meshes", [])):
        for p, primitive in enumerate(mesh.get("primitives", [])):
            features = primitive.get("extensions", {}).get(MESH_FEATURES)
            if features is not None:
                problems += [f"meshes[{m}].primitives[{p}]: {x}"
                             for x in _check_features(features, primitive, gltf, blob, tables)]
    return problems, len(tables)


def _check_class(name: str, cls: dict) -> list[str]:
    problems = []
    for key, spec in cls.get("properties", {}).items():
        where = f"class {name}, property {key}"
        if not _ID.match(key):
            problems.append(f"{where}: not a valid property id")
        kind = spec.get("type")
        if kind in NUMERIC:
            if spec.get("componentType") not in COMPONENT_BYTES:
                problems.append(f"{where}: type {kind} needs a componentType, not {spec.get('componentType')!r}")
        elif kind not in ("STRING", "BOOLEAN", "ENUM"):
            problems.append(f"{where}: unknown type {kind!r}")
        for value_name in ("noData", "default"):
            if value_name in spec and not _of_type(spec[value_name], kind):
                problems.append(f"{where}: {value_name} {spec[value_name]!r} is not a {kind} value")
        if spec.get("required") and "default" in spec:
            problems.append(f"{where}: a required property cannot have a default")
    return problems


def _of_type(value, kind: str) -> bool:
    if kind == "STRING":
        return isinstance(value, str)
    if kind == "BOOLEAN":
        return isinstance(value, bool)
    if kind in NUMERIC:
        values = value if isinstance(value, list) else [value]
        return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    return True


def _check_table(table: dict, cls: dict, views: list[dict], blob: bytes) -> list[str]:
    problems = []
    count = table.get("count")
    if not isinstance(count, int) or count < 1:
        return [f"count {count!r} is not a positive integer"]
    declared = cls.get("properties", {})
    present = table.get("properties", {})
    for key in present:
        if key not in declared:
            problems.append(f"property {key} is not declared by the class")
    for key, spec in declared.items():
        if key not in present:
            if spec.get("required"):
                problems.append(f"the required property {key} is missing")
            elif spec.get("type") in NUMERIC or "default" not in spec:
                problems.append(f"the property {key} is missing"
                                + (" (a numeric property: the official validator needs it in every table)"
                                   if spec.get("type") in NUMERIC else " and the class gives no default"))
            continue
        problems += [f"property {key}: {p}" for p in _check_column(present[key], spec, count, views, blob)]
    return problems


def _view(index, views: list[dict], blob: bytes) -> tuple[dict | None, bytes]:
    if not isinstance(index, int) or not 0 <= index < len(views):
        return None, b""
    view = views[index]
    start = view.get("byteOffset", 0)
    return view, blob[start:start + view.get("byteLength", 0)]


def _check_column(column: dict, spec: dict, count: int, views: list[dict], blob: bytes) -> list[str]:
    if spec.get("array"):
        return []  # the writer makes no arrays
    kind = spec["type"]
    values, data = _view(column.get("values"), views, blob)
    if values is None:
        return [f"values {column.get('values')!r} is not a buffer view"]
    if len(data) != values.get("byteLength", 0):
        return ["the values buffer view runs past the binary chunk"]
    if kind in NUMERIC:
        return _check_numeric_values(values, data, spec, count)
    if kind == "STRING":
        return _check_strings(column, data, count, views, blob)
    if kind == "BOOLEAN" and len(data) != math.ceil(count / 8):
        return [f"values hold {len(data)} bytes for {count} booleans"]
    return []


def _check_numeric_values(values: dict, data: bytes, spec: dict, count: int) -> list[str]:
    problems = []
    kind = spec["type"]
    size = COMPONENT_BYTES.get(spec.get("componentType", ""), 1)
    if values.get("byteOffset", 0) % size:
        problems.append(f"values start at byte {values.get('byteOffset', 0)}, not aligned to {size}")
    expected = count * COMPONENTS[kind] * size
    if len(data) != expected:
        problems.append(f"values hold {len(data)} bytes for {count} rows of {kind} "
                        f"{spec.get('componentType')} ({expected} expected)")
    return problems


def _check_strings(column: dict, data: bytes, count: int, views: list[dict], blob: bytes) -> list[str]:
    offset_type = column.get("stringOffsetType", "UINT32")
    size = COMPONENT_BYTES.get(offset_type)
    if size is None or not offset_type.startswith("UINT"):
        return [f"stringOffsetType {offset_type!r}"]
    view, raw = _view(column.get("stringOffsets"), views, blob)
    if view is None:
        return ["no stringOffsets buffer view"]
    problems = []
    if view.get("byteOffset", 0) % size:
        problems.append(f"stringOffsets start at byte {view.get('byteOffset', 0)}, not aligned to {size}")
    if len(raw) != (count + 1) * size:
        return problems + [f"stringOffsets hold {len(raw)} bytes for {count} rows ({(count + 1) * size} expected)"]
    offsets = np.frombuffer(raw, dtype=f"<u{size}").astype(np.int64)
    if (np.diff(offsets) < 0).any():
        problems.append("stringOffsets are not ascending")
    if offsets[-1] != len(data):
        problems.append(f"the last string offset is {offsets[-1]}, the values hold {len(data)} bytes")
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        problems.append("the strings are not UTF-8")
    return problems


def _check_features(features: dict, primitive: dict, gltf: dict, blob: bytes, tables: list[dict]) -> list[str]:
    problems = []
    for f, feature_id in enumerate(features.get("featureIds", [])):
        where = f"featureIds[{f}]"
        count = feature_id.get("featureCount")
        if not isinstance(count, int) or count < 1:
            problems.append(f"{where}: featureCount {count!r}")
            continue
        table = feature_id.get("propertyTable")
        if table is not None and not (isinstance(table, int) and 0 <= table < len(tables)):
            problems.append(f"{where}: propertyTable {table!r} does not exist")
            continue
        if "attribute" not in feature_id:
            continue
        accessor_index = primitive.get("attributes", {}).get(f"_FEATURE_ID_{feature_id['attribute']}")
        if accessor_index is None:
            problems.append(f"{where}: no _FEATURE_ID_{feature_id['attribute']} attribute")
            continue
        ids = _accessor(gltf, blob, accessor_index)
        if ids is None:
            problems.append(f"{where}: the feature id accessor cannot be read")
            continue
        if (ids != np.round(ids)).any():
            problems.append(f"{where}: feature ids that are not integers")
            continue
        distinct = set(np.unique(ids).astype(np.int64).tolist()) - {feature_id.get("nullFeatureId")}
        if len(distinct) > count:
            problems.append(f"{where}: {len(distinct)} distinct feature ids, featureCount {count}")
        if table is not None and distinct and (min(distinct) < 0 or max(distinct) >= tables[table]["count"]):
            problems.append(f"{where}: feature ids {min(distinct)}–{max(distinct)} outside the table's "
                            f"{tables[table]['count']} rows")
    return problems


def _accessor(gltf: dict, blob: bytes, index: int) -> np.ndarray | None:
    try:
        accessor = gltf["accessors"][index]
        view = gltf["bufferViews"][accessor["bufferView"]]
        dtype = np.dtype(_ACCESSOR_DTYPE[accessor["componentType"]])
        width = _ACCESSOR_WIDTH[accessor["type"]]
        stride = view.get("byteStride") or dtype.itemsize * width
        start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
        count = accessor["count"]
        if count and start + stride * (count - 1) + dtype.itemsize * width > len(blob):
            return None
        rows: np.ndarray = np.ndarray((count, width), dtype=dtype.newbyteorder("<"), buffer=blob, offset=start,
                          strides=(stride, dtype.itemsize))
        return rows.astype(np.float64).ravel()
    except (KeyError, IndexError, TypeError):
        return None


def check_tileset(path: str | Path, glb_metadata: bool = True) -> TilesetCheck:
    """Check ``path`` (a tileset.json, or a folder holding one) and every tileset and content it refers to."""
    path = Path(path)
    if path.is_dir():
        path = path / "tileset.json"
    result = TilesetCheck()
    _check_file(path.resolve(), path.resolve().parent, result, glb_metadata, None)
    return result


def _check_file(path: Path, top: Path, result: TilesetCheck, glb_metadata: bool, parent: dict | None) -> None:
    name = _relative(path, top)
    if name in result.tilesets:
        result.problems.append(f"{name} is referred to twice")
        return
    try:
        raw = path.read_bytes()
        document = json.loads(raw.decode("utf-8"))
    except (OSError, ValueError) as exc:
        result.problems.append(f"{name}: cannot be read as JSON ({exc})")
        return
    result.tilesets[name] = len(raw)
    if document.get("asset", {}).get("version") not in ("1.0", "1.1"):
        result.problems.append(f"{name}: asset.version {document.get('asset', {}).get('version')!r}")
    root = document.get("root")
    if not isinstance(root, dict):
        result.problems.append(f"{name}: no root tile")
        return
    if not _number(document.get("geometricError")) or document["geometricError"] < root.get("geometricError", 0):
        result.problems.append(f"{name}: the tileset's geometricError {document.get('geometricError')} is below "
                               f"its root's {root.get('geometricError')}")
    _check_tile(root, f"{name}:root", path.parent, top, result, glb_metadata, parent)


def _check_tile(tile: dict, where: str, base: Path, top: Path, result: TilesetCheck, glb_metadata: bool,
                parent: dict | None) -> None:
    result.tiles += 1
    error = tile.get("geometricError")
    if not _number(error) or error < 0:
        result.problems.append(f"{where}: geometricError {error!r}")
        error = 0.0
    region = tile.get("boundingVolume", {}).get("region")
    if not _region(region):
        result.problems.append(f"{where}: boundingVolume.region {region!r} is not a region")
        region = None
    if "transform" in tile:
        matrix = tile["transform"]
        if not (isinstance(matrix, list) and len(matrix) == 16 and all(_number(v) for v in matrix)):
            result.problems.append(f"{where}: transform is not 16 finite numbers")
    if parent is not None:
        if error > parent["error"] * (1 + 1e-9) + 1e-9:
            result.problems.append(f"{where}: geometricError {error} above its parent's {parent['error']}")
        if region is not None and parent["region"] is not None and not region_inside(region, parent["region"]):
            result.problems.append(f"{where}: region {region} is not inside its parent's {parent['region']}")
    if tile.get("refine", "REPLACE") not in ("ADD", "REPLACE"):
        result.problems.append(f"{where}: refine {tile.get('refine')!r}")
    here = {"error": error, "region": region}
    content = tile.get("content")
    if content is not None:
        _check_content(content.get("uri", ""), where, base, top, result, glb_metadata, here)
    for k, child in enumerate(tile.get("children", [])):
        _check_tile(child, f"{where}/children/{k}", base, top, result, glb_metadata, here)


def _check_content(uri: str, where: str, base: Path, top: Path, result: TilesetCheck, glb_metadata: bool,
                   here: dict) -> None:
    """A tile's content: an external tileset checked in turn, or a .glb (its metadata with ``glb_metadata``)."""
    target = (base / uri).resolve()
    if not target.is_file():
        result.problems.append(f"{where}: the content {uri} is missing")
        return
    if uri.endswith(".json"):
        _check_file(target, top, result, glb_metadata, here)
        return
    result.contents += 1
    if not (glb_metadata and uri.endswith(".glb")):
        return
    try:
        gltf, blob = read_glb(target.read_bytes())
    except ValueError as exc:
        result.problems.append(f"{_relative(target, top)}: {exc}")
        return
    problems, tables = check_glb_metadata(gltf, blob)
    result.property_tables += tables
    result.problems += [f"{_relative(target, top)}: {p}" for p in problems]


def region_inside(inner: list[float], outer: list[float]) -> bool:
    """``inner`` lies in ``outer`` (3D Tiles regions), to a nanoradian and a millimetre."""
    t, m = REGION_TOLERANCE_RAD, REGION_TOLERANCE_M
    return (inner[0] >= outer[0] - t and inner[1] >= outer[1] - t and inner[2] <= outer[2] + t
            and inner[3] <= outer[3] + t and inner[4] >= outer[4] - m and inner[5] <= outer[5] + m)


def _region(region) -> bool:
    if not (isinstance(region, list) and len(region) == 6 and all(_number(v) for v in region)):
        return False
    west, south, east, north, low, high = region
    return (-math.pi <= west <= math.pi and -math.pi <= east <= math.pi
            and -math.pi / 2 <= south <= north <= math.pi / 2 and west <= east and low <= high)


def _number(value: object) -> TypeGuard[float]:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _relative(path: Path, top: Path) -> str:
    try:
        return path.relative_to(top).as_posix()
    except ValueError:
        return path.as_posix()
