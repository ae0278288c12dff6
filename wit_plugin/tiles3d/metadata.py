"""The metadata schema of the tileset's buildings (3D Tiles 1.1 / ``EXT_structural_metadata``).

One class, ``building``, with a property per field of the LoD1 layer except the per-face ones
(``face``, ``face_no``): the chain's own (``wit_id``, ``height``, ``height_src``, storeys, ``base_z``)
and every source attribute kept by wit:extrudebuildings (e.g. ``BULD_NM``, the building's name, in
Korean), then those of the texture step's facade table (``wit_facade`` = generated, its style, rule and
storeys: the walls' texture is generated, not measured). OGR strings → STRING (UTF-8), integers →
INT32 / INT64, reals → FLOAT64, anything else → its text. A NULL is stored as the property's ``noData``
value (the empty string for text). No property is ``required``; every tile's table holds every numeric
property, and a text property is left out of a tile's table only when it is empty for all its buildings:
it then reads as its ``default``, the empty string (3D Tiles 1.1 metadata: a missing or noData value reads
as the ``default``).
"""
from __future__ import annotations

import re

from osgeo import ogr

from ..infra import step_layers

BUILDING_CLASS = "building"
SCHEMA_ID = "wit_citymodel"
INT32_NO_DATA = -(2 ** 31)
INT64_NO_DATA = -(2 ** 63)
FLOAT_NO_DATA = -3.4028234663852886e38

#: descriptions of the fields a user looks for first (the others keep their source name only)
DESCRIPTIONS = {
    step_layers.WIT_ID: "Stable building id (the CityGML gml:id)",
    step_layers.HEIGHT: "Building height (m)",
    step_layers.HEIGHT_SOURCE: "Where the height comes from: floors, field, expression or default",
    step_layers.STOREYS_ABOVE: "Storeys above ground",
    step_layers.STOREYS_BELOW: "Storeys below ground",
    step_layers.BASE_Z: "Ground height at the footprint (m)",
    step_layers.FACADE: "How the wall texture was made: generated (drawn by the plugin, not measured)",
    step_layers.FACADE_STYLE: "Generated facade style, from the building's use",
    step_layers.FACADE_RULE: "What chose the facade style (use code, use name, OSM tag or storeys)",
    step_layers.FACADE_STOREYS: "Storeys drawn on the walls",
    step_layers.FACADE_STOREYS_SOURCE: "Where the storeys drawn come from: the layer's floor field, or the height",
    "BULD_NM": "Building name",
    "BD_MGT_SN": "Building management number",
}


def property_id(name: str) -> str:
    """A field name as a metadata property id (letters, digits, underscore; not starting with a digit)."""
    clean = re.sub(r"\W", "_", name, flags=re.ASCII)
    return clean if re.match(r"[A-Za-z_]", clean) else f"_{clean}"


def building_schema(fields: list[tuple[str, int]]) -> dict:
    """The schema for the LoD1 layer's building-level ``fields`` ((name, OGR type) in layer order)."""
    properties: dict[str, dict] = {}
    for name, kind in fields:
        spec: dict = {"name": name}
        if kind == ogr.OFTInteger:
            spec.update(type="SCALAR", componentType="INT32", noData=INT32_NO_DATA)
        elif kind == ogr.OFTInteger64:
            spec.update(type="SCALAR", componentType="INT64", noData=INT64_NO_DATA)
        elif kind == ogr.OFTReal:
            spec.update(type="SCALAR", componentType="FLOAT64", noData=FLOAT_NO_DATA)
        else:
            spec.update(type="STRING", noData="", default="")
        if name in DESCRIPTIONS:
            spec["description"] = DESCRIPTIONS[name]
        key = property_id(name)
        while key in properties:  # two names that differ in characters an id cannot hold
            key += "_"
        properties[key] = spec
    if property_id(step_layers.WIT_ID) not in properties:  # the id is there whatever the layer holds
        properties[property_id(step_layers.WIT_ID)] = {"name": step_layers.WIT_ID, "type": "STRING", "noData": "",
                                                       "default": "", "description": DESCRIPTIONS[step_layers.WIT_ID]}
    return {"id": SCHEMA_ID, "classes": {BUILDING_CLASS: {"name": "Building", "properties": properties}}}


def property_columns(schema: dict, ids: list[str], attributes: list[list]) -> dict[str, list]:
    """Columns of the property table: one list per property, one value per building (row = feature id)."""
    properties = schema["classes"][BUILDING_CLASS]["properties"]
    columns: dict[str, list] = {}
    for position, (key, spec) in enumerate(properties.items()):
        if spec["name"] == step_layers.WIT_ID:
            columns[key] = list(ids)
        elif spec["type"] == "STRING":
            columns[key] = [None if row[position] is None else str(row[position]) for row in attributes]
        else:
            columns[key] = [row[position] for row in attributes]
    return columns
