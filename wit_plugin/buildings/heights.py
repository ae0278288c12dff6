"""Where a building's height comes from, for any real building layer.

A :class:`HeightRule` is an ordered list of sources; the first that gives a finite height > 0
wins, else the default (recorded per building, so the model says which buildings used it).

Order: the road-name-address floor count ``GRO_FLO_CO`` × storey height when the layer has it
(the national building layer's own count, the paper's height source), then the field and/or
expression the user chose; with none chosen, the height and floor fields of the common Korean and open
layers, recognised by name:

=====================================================  ==========================  ==================
layer                                                  height (m)                  floors (× storey)
=====================================================  ==========================  ==================
road-name-address buildings ``TL_SPBD_BULD`` (juso)    –                           ``GRO_FLO_CO``
NGII digital map / national base map buildings         –                           ``BFLR_CO``
(``N3A_B0010000``, ``TN_BULD``; coded fields)
NGII digital map buildings ``N3A_B0010000`` as NGII    –                           ``층수``
ships them (Korean field names 층수, 용도, 종류, 명칭)
GIS building-integrated information ``AL_D010``        ``A16`` (높이)               ``A26`` (지상층수)
(GIS건물통합정보, vworld; fields ``A0``…``A28``)
OpenStreetMap (GeoJSON, GeoPackage, osm2pgsql, …)      ``height``                  ``building:levels``
                                                                                   (``building_levels``)
Korean-named exports                                   ``높이``                     ``지상층수``, ``층수``
=====================================================  ==========================  ==================

Below-ground storeys: ``UND_FLO_CO`` (juso), ``A27`` (AL_D010). OpenStreetMap heights may carry a
unit (``"12 m"``, ``"40 ft"``, ``40'``); other height fields are numbers in metres. The NGII field
names follow the digital map's rule (수치지형도 작성 작업 및 성과에 관한 규정, 별표 2: 층수 BFLR_CO,
용도 BPRP_SE, 종류 BULD_SE, 명칭 BULD_NM).
"""
from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..infra.errors import InputError

FLOORS = "floors"
FIELD = "field"
EXPRESSION = "expression"
DEFAULT = "default"
KINDS = (FLOORS, FIELD, EXPRESSION, DEFAULT)

JUSO_FLOORS = "GRO_FLO_CO"


@dataclass(frozen=True)
class HeightSource:
    """One place a height can come from."""

    kind: str  # FLOORS, FIELD or EXPRESSION
    name: str  # field name, or the expression text
    layer: str = ""  # the recognised layer kind, for the log ("" when chosen by the user)


@dataclass(frozen=True)
class KnownLayer:
    """A building layer recognised by its field names."""

    label: str
    detect: tuple[str, ...]  # all of these fields present (case-insensitive)
    height: tuple[str, ...] = ()
    floors: tuple[str, ...] = ()
    basement: tuple[str, ...] = ()


KNOWN_LAYERS: tuple[KnownLayer, ...] = (
    KnownLayer("road-name-address building layer (TL_SPBD_BULD)", ("GRO_FLO_CO",), floors=("GRO_FLO_CO",),
               basement=("UND_FLO_CO",)),
    KnownLayer("NGII digital map buildings (N3A_B0010000)", ("BFLR_CO",), floors=("BFLR_CO",)),
    KnownLayer("NGII digital map buildings (N3A_B0010000, Korean field names)", ("층수", "종류"), floors=("층수",)),
    KnownLayer("NGII digital map buildings (N3A_B0010000, Korean field names)", ("층수", "용도"), floors=("층수",)),
    KnownLayer("GIS building-integrated information (AL_D010)", ("A0", "A1", "A16"), height=("A16",),
               floors=("A26",), basement=("A27",)),
    KnownLayer("OpenStreetMap buildings", ("height",), height=("height",),
               floors=("building:levels", "building_levels")),
    KnownLayer("OpenStreetMap buildings", ("building:levels",), floors=("building:levels",)),
    KnownLayer("OpenStreetMap buildings", ("building_levels",), floors=("building_levels",)),
    KnownLayer("Korean-named building layer", ("높이",), height=("높이",), floors=("지상층수", "층수")),
    KnownLayer("Korean-named building layer", ("지상층수",), floors=("지상층수",), basement=("지하층수",)),
    KnownLayer("Korean-named building layer", ("층수",), floors=("층수",)),
)


@dataclass
class HeightRule:
    """How a building's height is chosen: ``sources`` in order, else ``default_height``."""

    storey_height: float = 3.0
    default_height: float = 3.0
    sources: list[HeightSource] = field(default_factory=lambda: [HeightSource(FLOORS, JUSO_FLOORS)])
    expression: Callable[[dict], Any] | None = None  # evaluates the EXPRESSION source
    expression_column: str | None = None  # ... or the column it was evaluated into beforehand (tiles)
    floors_field: str | None = JUSO_FLOORS  # storeys above ground (con:storeysAboveGround)
    basement_field: str | None = "UND_FLO_CO"

    def describe(self) -> str:
        """One line for the log: what is tried, in order."""
        parts = [_label(s, self.storey_height) + (f" [{s.layer}]" if s.layer else "") for s in self.sources]
        return " → ".join(parts + [f"default {self.default_height:g} m"])

    def label(self, source: HeightSource | None) -> str:
        """The per-building record of the rule that gave its height (``step_layers.HEIGHT_RULE``)."""
        return _label(source, self.storey_height) if source else f"default {self.default_height:g} m"


def _label(source: HeightSource, storey_height: float) -> str:
    if source.kind == FLOORS:
        return f"{source.name} × {storey_height:g} m"
    if source.kind == FIELD:
        return f"{source.name} (m)"
    return f"expression {source.name}"


def _lookup(names: Sequence[str], wanted: Sequence[str]) -> str | None:
    """The layer's spelling of the first of ``wanted`` it has (case-insensitive)."""
    by_lower = {n.lower(): n for n in names}
    return next((by_lower[w.lower()] for w in wanted if w.lower() in by_lower), None)


def recognise(field_names: Sequence[str]) -> KnownLayer | None:
    """The first known layer whose detection fields are all present."""
    lower = {n.lower() for n in field_names}
    return next((k for k in KNOWN_LAYERS if all(d.lower() in lower for d in k.detect)), None)


@dataclass
class HeightOptions:
    """What the user chose (all optional); the rule itself depends on the layer's fields."""

    height_field: str | None = None
    expression_text: str | None = None
    expression: Callable[[dict], Any] | None = None  # evaluates ``expression_text`` on a building's attributes
    expression_column: str | None = None  # or: the field it was evaluated into beforehand (tiles: workers have no QGIS)
    storey_height: float = 3.0
    default_height: float = 3.0

    def rule_for(self, field_names: Sequence[str], layer: str = "the building layer") -> HeightRule:
        """The national floor count first (``GRO_FLO_CO``), then the user's field/expression, else recognition."""
        if not (self.storey_height > 0 and self.default_height > 0):
            raise InputError("Storey height and default height must be positive.")
        chosen = _lookup(field_names, [self.height_field]) if self.height_field else None
        if self.height_field and chosen is None:
            raise InputError(f"The height field {self.height_field!r} is not in {layer}; its fields are "
                             f"{', '.join(field_names) or 'none'}.")
        sources: list[HeightSource] = []
        juso = _lookup(field_names, [JUSO_FLOORS])
        if juso:
            sources.append(HeightSource(FLOORS, juso))
        if chosen:
            sources.append(HeightSource(FIELD, chosen))
        evaluated = self.expression is not None or bool(self.expression_column)
        if evaluated:
            sources.append(HeightSource(EXPRESSION, self.expression_text or "(expression)"))
        known = recognise(field_names)
        floors = basement = None
        if known is not None:
            floors, basement = _lookup(field_names, known.floors), _lookup(field_names, known.basement)
            if not (chosen or evaluated):
                for kind, names in ((FIELD, known.height), (FLOORS, known.floors)):
                    name = _lookup(field_names, names)
                    if name and all(s.name != name for s in sources):
                        sources.append(HeightSource(kind, name, known.label))
        return HeightRule(self.storey_height, self.default_height, sources, self.expression, self.expression_column,
                          floors or juso, basement or _lookup(field_names, ["UND_FLO_CO"]))


_NUMBER_UNIT = re.compile(r"^\s*([-+]?\d+(?:[.,]\d+)?)\s*(m|meters?|metres?|ft|feet|'|)\s*$", re.IGNORECASE)
_FEET = 0.3048


def parse_height(value: Any) -> float | None:
    """A height in metres from a number or a text with an optional unit; None when unusable or ≤ 0."""
    if isinstance(value, str):
        match = _NUMBER_UNIT.match(value)
        if not match:
            return None
        number = float(match.group(1).replace(",", "."))
        if match.group(2).lower() in ("ft", "feet", "'"):
            number *= _FEET
    elif (given := positive(value)) is not None:
        number = given
    else:
        return None
    return number if math.isfinite(number) and number > 0 else None


def positive(value: Any) -> float | None:
    """``value`` as a finite number > 0, else None (empty strings, NULL, text, zero…)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) and number > 0 else None


def building_height(attributes: dict, rule: HeightRule) -> tuple[float, HeightSource | None]:
    """(height, the source that gave it or None for the default) for one building."""
    for source in rule.sources:
        if source.kind == FLOORS:
            floors = positive(attributes.get(source.name))
            if floors is not None:
                return floors * rule.storey_height, source
        elif source.kind == FIELD:
            value = parse_height(attributes.get(source.name))
            if value is not None:
                return value, source
        else:
            value = positive(rule.expression(attributes) if rule.expression is not None
                             else attributes.get(rule.expression_column or ""))
            if value is not None:
                return value, source
    return rule.default_height, None
