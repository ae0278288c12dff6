"""Where a road's surface comes from, for any real road layer, as ``heights`` does for buildings.

Road polygons — the NGII digital map's road boundary ``N3A_A0010000`` or any other polygon layer —
are the road surfaces as they are (repaired, cut to the study area). Centre lines are buffered by
width / 2; the width of a line is the first of its layer's rule that gives a finite number > 0:
its width field (metres; a unit such as ``"7 m"`` or ``24'`` is understood), else its lane count ×
``LANE_WIDTH``, else the default of its class, else ``PrepareConfig.default_road_width``.

=========================================================  ============  ==============  =====================
layer (recognised by its fields)                           width (m)     lanes           class default
=========================================================  ============  ==============  =====================
NGII digital map road centre lines ``N3L_A0020000``,       ``ROAD_BT``   ``CARTRK_CO``   –
coded fields (수치지형도 작성 작업 및 성과에 관한 규정,
별표 2: 도로폭 ROAD_BT, 차로수 CARTRK_CO)
the same with the Korean field names NGII ships            ``도로폭``     ``차로수``       –
NGII continuous digital map (연속수치지형도) centre lines     ``RVWD``      ``RDLN``        –
road-name-address roads ``TL_SPRD_MANAGE`` (juso)          ``ROAD_BT``   –               ``ROA_CLS_SE``
                                                                                         (``JUSO_CLASS_WIDTHS``)
OpenStreetMap ``highway`` lines (osm2pgsql, GeoFabrik,     ``width``     ``lanes``       ``highway``
GeoJSON, GeoPackage…)                                                                    (``OSM_CLASS_WIDTHS``)
any other line layer                                       –             –               –
=========================================================  ============  ==============  =====================

The rule each layer got is logged; each road records the source of its width (``step_layers.ROAD_WIDTH_SOURCE``).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..buildings.heights import parse_height, positive

#: m per lane when only the lane count is known: the middle of the 3.0–3.5 m that the Korean road
#: design rule (도로의 구조·시설 기준에 관한 규칙, art. 10) sets by design speed and area
LANE_WIDTH = 3.25
#: ROA_CLS_SE (도로구간 구분) → m: 1 고속도로 (expressway: 4 lanes, shoulders, median), 2 대로 (≥ 40 m by
#: the road-name-address rules), 3 로 (12–40 m: the lower bound); 4 길 and others take the default width
JUSO_CLASS_WIDTHS = {"1": 25.0, "2": 40.0, "3": 12.0}
#: OpenStreetMap ``highway`` → m of paved surface when a way has neither ``width`` nor ``lanes``: the
#: usual lanes of the class × ``LANE_WIDTH`` (a motorway's two carriageways with shoulders and median),
#: links one lane wider than their minimum, paths and tracks their typical width
OSM_CLASS_WIDTHS = {
    "motorway": 25.0, "trunk": 20.0, "primary": 15.0, "secondary": 12.0, "tertiary": 9.0,
    "motorway_link": 8.0, "trunk_link": 8.0, "primary_link": 7.0, "secondary_link": 7.0, "tertiary_link": 6.5,
    "unclassified": 6.5, "residential": 6.5, "road": 6.5, "busway": 6.5, "living_street": 5.0,
    "service": 4.0, "pedestrian": 5.0, "track": 3.0, "cycleway": 2.5, "footway": 2.0, "path": 2.0,
    "bridleway": 2.0, "steps": 2.0,
}


@dataclass(frozen=True)
class RoadSchema:
    """A road centre-line layer recognised by its field names."""

    label: str
    detect: tuple[str, ...]  # all of these fields present (case-insensitive)
    width: tuple[str, ...] = ()
    lanes: tuple[str, ...] = ()
    class_field: str | None = None
    class_widths: dict[str, float] = field(default_factory=dict)


NGII_CODED = "NGII digital map road centre lines (N3L_A0020000)"
NGII_KOREAN = "NGII digital map road centre lines (N3L_A0020000, Korean field names)"
NGII_CONTINUOUS = "NGII continuous digital map road centre lines (N3L_A0020000)"
JUSO = "road-name-address roads (TL_SPRD_MANAGE)"
OSM = "OpenStreetMap roads"
UNKNOWN = "line layer without a known width field"

KNOWN_ROAD_LAYERS: tuple[RoadSchema, ...] = (
    RoadSchema(NGII_CODED, ("CARTRK_CO",), width=("ROAD_BT",), lanes=("CARTRK_CO",)),
    RoadSchema(NGII_KOREAN, ("도로폭",), width=("도로폭",), lanes=("차로수",)),
    RoadSchema(NGII_KOREAN, ("차로수",), lanes=("차로수",)),
    RoadSchema(NGII_CONTINUOUS, ("RVWD",), width=("RVWD",), lanes=("RDLN",)),
    RoadSchema(NGII_CONTINUOUS, ("RDLN",), lanes=("RDLN",)),
    RoadSchema(JUSO, ("ROAD_BT",), width=("ROAD_BT",), class_field="ROA_CLS_SE", class_widths=JUSO_CLASS_WIDTHS),
    RoadSchema(JUSO, ("ROA_CLS_SE",), class_field="ROA_CLS_SE", class_widths=JUSO_CLASS_WIDTHS),
    RoadSchema(OSM, ("highway",), width=("width",), lanes=("lanes",), class_field="highway",
               class_widths=OSM_CLASS_WIDTHS),
)


def _lookup(names: Sequence[str], wanted: Sequence[str]) -> str | None:
    """The layer's spelling of the first of ``wanted`` it has (case-insensitive)."""
    by_lower = {n.lower(): n for n in names}
    return next((by_lower[w.lower()] for w in wanted if w.lower() in by_lower), None)


def recognise(field_names: Sequence[str]) -> RoadSchema:
    """The first known road layer whose detection fields are all present, else the plain one."""
    lower = {n.lower() for n in field_names}
    return next((k for k in KNOWN_ROAD_LAYERS if all(d.lower() in lower for d in k.detect)), RoadSchema(UNKNOWN, ()))


@dataclass(frozen=True)
class WidthRule:
    """The width rule of one layer: its fields (as the layer spells them), in order."""

    schema: RoadSchema
    width: str | None
    lanes: str | None
    class_field: str | None
    default_width: float

    @classmethod
    def of(cls, field_names: Sequence[str], default_width: float) -> WidthRule:
        schema = recognise(field_names)
        return cls(schema, _lookup(field_names, schema.width), _lookup(field_names, schema.lanes),
                   _lookup(field_names, [schema.class_field] if schema.class_field else []), default_width)

    def describe(self) -> str:
        """One line for the log: what is tried, in order."""
        parts = [f"{self.width} (m)"] if self.width else []
        parts += [f"{self.lanes} × {LANE_WIDTH:g} m"] if self.lanes else []
        parts += [f"{self.class_field} class default"] if self.class_field else []
        return f"{self.schema.label}: " + " → ".join(parts + [f"default {self.default_width:g} m"])

    def width_of(self, row: dict[str, Any]) -> tuple[float, str]:
        """(width in m, its source: the field, ``<lanes field> × lane width``, ``<class field>=<value>``
        or ``default``) of one centre line from its attributes."""
        if self.width and (width := parse_height(row.get(self.width))) is not None:
            return width, self.width
        lanes = positive(row.get(self.lanes)) if self.lanes else None
        if lanes is not None:
            return lanes * LANE_WIDTH, f"{self.lanes} × {LANE_WIDTH:g} m"
        value = field_text(row.get(self.class_field)) if self.class_field else None
        if value is not None and value in self.schema.class_widths:
            return self.schema.class_widths[value], f"{self.class_field}={value}"
        return self.default_width, "default"


def field_text(value: Any) -> str | None:
    """An attribute value as text, as a code or an id part: ``3.0`` → ``"3"``, text stripped; None when
    empty or not finite."""
    if value is None:
        return None
    if isinstance(value, float):
        if not math.isfinite(value):
            return None
        value = int(value) if value.is_integer() else value
    text = str(value).strip()
    return text or None


def widths(columns: dict[str, list], count: int, rule: WidthRule) -> tuple[np.ndarray, list[str]]:
    """Width and its source for each of ``count`` centre lines (``columns``: the layer's attribute columns)."""
    used = [name for name in (rule.width, rule.lanes, rule.class_field) if name]
    out, sources = np.empty(count), []
    for i in range(count):
        out[i], source = rule.width_of({name: columns[name][i] for name in used})
        sources.append(source)
    return out, sources
