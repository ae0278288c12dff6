"""The official CityJSON 2.0 schemas, shipped in ``schemas/2.0`` (see its NOTICE.md), compiled for validation.

Engine: ``fastjsonschema`` (PyPI and Debian; pure Python, BSD-3-Clause), which compiles a schema into Python
code. Measured on ``make demo``'s model (14.8 MB, 83,503 TIN triangles): the whole document through the
schemas' ``oneOf`` of city object types took 23 s with it and 34 s with ``jsonschema`` 4.10, object by object
against its own type's definition 3.6 s with it. So each city object is checked against the definition its
``type`` names (``cityobjects.schema.json#/<type>``) — what the ``oneOf`` comes to, as the types' ``type``
constants exclude each other — and the document (or a feature) against its schema with its city objects
left out. The engine reports the first problem of each object. It is optional at run time: without it the
validator reports that the schema was not checked (a warning) and does every other check.
"""
from __future__ import annotations

import functools
import json
from collections.abc import Callable
from pathlib import Path

SCHEMA_DIR = Path(__file__).parent / "schemas" / "2.0"
_BASE = "https://www.cityjson.org/schemas/2.0.2/"
DOCUMENT, FEATURE, OBJECTS = "cityjson.schema.json", "cityjsonfeature.schema.json", "cityobjects.schema.json"
INSTALL = "python -m pip install fastjsonschema"


class SchemaError(Exception):
    """A document does not follow the schema: ``where`` (a JSON path) and what is wrong."""

    def __init__(self, where: str, message: str):
        super().__init__(f"{where}: {message}")
        self.where, self.message = where, message


def available() -> bool:
    try:
        import fastjsonschema  # noqa: F401
    except ImportError:
        return False
    return True


@functools.cache
def _schemas() -> dict[str, dict]:
    return {data["$id"]: data for data in (json.loads(path.read_text(encoding="utf-8"))
                                           for path in sorted(SCHEMA_DIR.glob("*.schema.json")))}


@functools.cache
def city_object_types() -> frozenset[str]:
    """The city object types the schema defines (not the abstract ones)."""
    return frozenset(name for name in _schemas()[_BASE + OBJECTS] if name[:1].isupper())


@functools.cache
def _compiled(ref: str) -> Callable[[object], object]:
    import fastjsonschema

    def handler(uri: str) -> dict:
        return _schemas()[uri.split("#")[0]]

    return fastjsonschema.compile({"$ref": _BASE + ref}, handlers={"https": handler})


def check(instance: object, ref: str, where: str) -> None:
    """Raise ``SchemaError`` when ``instance`` does not follow the schema ``ref`` (e.g. ``cityjson.schema.json``)."""
    import fastjsonschema

    try:
        _compiled(ref)(instance)
    except fastjsonschema.JsonSchemaException as exc:
        name = getattr(exc, "name", None) or "data"  # e.g. data.geometry[0]: where in the instance
        place = where + name[len("data"):] if name.startswith("data") else where
        message = exc.message[len(name):].strip() if exc.message.startswith(name) else exc.message
        raise SchemaError(place, message) from None


def check_city_object(city_object: object, where: str) -> None:
    """A city object against the definition of its type (what the schema's ``oneOf`` of types comes to)."""
    kind = city_object.get("type") if isinstance(city_object, dict) else None
    if kind not in city_object_types():
        raise SchemaError(where, f"type {kind!r} is not a CityJSON 2.0 city object type")
    check(city_object, f"{OBJECTS}#/{kind}", where)
