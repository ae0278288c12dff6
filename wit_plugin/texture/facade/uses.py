"""Which facade a building gets: its use class from the national use codes, NGII's names, OSM, else its storeys.

A facade *style* is a family of storey modules drawn by ``modules``; it is chosen from what the building
layer says of the building's use, first that applies:

1. a building-use code (건축물 용도코드, five digits: ``BDTYP_CD`` of the road-name-address layer, ``A8`` of
   the building-integrated information ``AL_D010``, Korean-named exports' ``주용도코드``): the class of the
   first two digits (건축법 시행령 별표 1), the sub-code where it matters (01001 단독주택 ≠ 01003 다가구주택);
2. a use or kind *name* as NGII writes it (``용도``, ``종류`` of the digital map ``N3A_B0010000``; ``A9`` of
   ``AL_D010``; ``주용도``): the Korean names of the same classes (아파트, 다세대주택, 제1종근린생활시설 …);
3. OpenStreetMap's ``building`` tag (apartments, house, retail, office, school, industrial, …);
4. else, and for generic values (공동주택, OSM ``residential`` / ``yes``), the storey count: 1–2 a house,
   3–4 a multi-household house (빌라), 5 and more an apartment block — the Korean legal line between
   연립·다세대주택 (at most 4 storeys of housing) and 아파트 (5 and more).

Offices of ``CURTAIN_WALL_STOREYS`` storeys or more get a curtain wall instead of window bands. Each style
has its typical storey height, used for the storey count of a building whose layer gives none.
"""
from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

HOUSE, VILLA, APARTMENT, RETAIL, OFFICE, CURTAIN_WALL, PUBLIC, INDUSTRIAL, OTHER = (
    "house", "villa", "apartment", "retail", "office", "curtain_wall", "public", "industrial", "other")
#: every style, in the order of their images
STYLES = (HOUSE, VILLA, APARTMENT, RETAIL, OFFICE, CURTAIN_WALL, PUBLIC, INDUSTRIAL, OTHER)

#: typical storey height (m) of each style: storeys = height / it where the layer gives no storey count
STOREY_HEIGHT = {HOUSE: 3.0, VILLA: 2.8, APARTMENT: 2.8, RETAIL: 3.6, OFFICE: 3.8, CURTAIN_WALL: 4.0,
                 PUBLIC: 3.8, INDUSTRIAL: 6.0, OTHER: 3.0}
CURTAIN_WALL_STOREYS = 12
VARIANTS = 4  # drawn variants (colour, window rhythm) of each style

#: class of a building-use code's first two digits (건축법 시행령 별표 1); 01 and 02 by sub-code below
_CODE_CLASSES = {
    "03": RETAIL, "04": RETAIL, "07": RETAIL, "16": RETAIL,  # 근린생활시설 1·2종, 판매, 위락
    "14": OFFICE, "15": OFFICE,  # 업무, 숙박
    "05": PUBLIC, "06": PUBLIC, "08": PUBLIC, "09": PUBLIC, "10": PUBLIC, "11": PUBLIC, "12": PUBLIC,
    "13": PUBLIC, "23": PUBLIC, "24": PUBLIC, "28": PUBLIC,  # 문화·종교·운수·의료·교육·노유자·수련·운동·교정·방송·장례
    "17": INDUSTRIAL, "18": INDUSTRIAL, "19": INDUSTRIAL, "20": INDUSTRIAL, "21": INDUSTRIAL, "22": INDUSTRIAL,
    "25": INDUSTRIAL,  # 공장, 창고, 위험물, 자동차, 동식물, 자원순환, 발전
}
#: housing by sub-code: 단독주택, 단독, 공관; 다중, 다가구; 아파트, 기숙사; 연립, 다세대 (02000 공동주택: by storeys)
_HOUSING_CODES = {"01000": HOUSE, "01001": HOUSE, "01004": HOUSE, "01002": VILLA, "01003": VILLA,
                  "02001": APARTMENT, "02004": APARTMENT, "02002": VILLA, "02003": VILLA}

#: Korean use and kind names (NGII 용도/종류, AL_D010 A9) → style; None: housing of no stated kind (by storeys)
_NAMES: tuple[tuple[str, str | None], ...] = (
    ("아파트", APARTMENT), ("기숙사", APARTMENT), ("연립", VILLA), ("다세대", VILLA), ("다가구", VILLA),
    ("다중주택", VILLA), ("단독", HOUSE), ("일반주택", HOUSE), ("공관", HOUSE), ("공동주택", None), ("주택", None),
    ("근린생활", RETAIL), ("판매", RETAIL), ("위락", RETAIL), ("상가", RETAIL), ("시장", RETAIL),
    ("업무", OFFICE), ("숙박", OFFICE), ("사무", OFFICE),
    ("교육", PUBLIC), ("학교", PUBLIC), ("문화", PUBLIC), ("집회", PUBLIC), ("종교", PUBLIC), ("의료", PUBLIC),
    ("병원", PUBLIC), ("노유자", PUBLIC), ("수련", PUBLIC), ("운동", PUBLIC), ("운수", PUBLIC), ("교정", PUBLIC),
    ("군사", PUBLIC), ("방송", PUBLIC), ("장례", PUBLIC), ("관공서", PUBLIC), ("공공", PUBLIC),
    ("공장", INDUSTRIAL), ("창고", INDUSTRIAL), ("위험물", INDUSTRIAL), ("자동차", INDUSTRIAL), ("발전", INDUSTRIAL),
    ("자원순환", INDUSTRIAL), ("분뇨", INDUSTRIAL), ("동물", INDUSTRIAL), ("식물", INDUSTRIAL),
)

#: OpenStreetMap ``building`` values → style; None: housing of no stated kind (by storeys)
_OSM: dict[str, str | None] = {
    **dict.fromkeys(("house", "detached", "bungalow", "semidetached_house", "farm", "cabin", "hut"), HOUSE),
    **dict.fromkeys(("terrace", "dormitory_house"), VILLA),
    **dict.fromkeys(("apartments", "dormitory"), APARTMENT),
    **dict.fromkeys(("residential", "yes"), None),
    **dict.fromkeys(("commercial", "retail", "kiosk", "supermarket", "shop"), RETAIL),
    **dict.fromkeys(("office", "hotel"), OFFICE),
    **dict.fromkeys(("school", "university", "college", "kindergarten", "public", "civic", "government", "hospital",
                     "church", "chapel", "cathedral", "temple", "mosque", "shrine", "train_station", "transportation",
                     "sports_hall", "sports_centre", "stadium", "fire_station", "museum", "library"), PUBLIC),
    **dict.fromkeys(("industrial", "warehouse", "factory", "manufacture", "hangar", "storage_tank", "garage",
                     "garages", "barn", "shed", "greenhouse", "service"), INDUSTRIAL),
}

#: fields read, by kind, in the order they are tried (matched case-insensitively)
CODE_FIELDS = ("BDTYP_CD", "주용도코드", "용도코드", "건물용도코드")
NAME_FIELDS = ("종류", "용도", "주용도", "주용도명", "건물용도", "용도명", "건축물용도명", "BULD_SE", "BPRP_SE")
OSM_FIELDS = ("building",)
_AL_D010 = ("A0", "A1", "A16")  # the building-integrated information layer, whose A8 / A9 are the use code / name


@dataclass(frozen=True)
class Facade:
    """A building's facade: its style and variant, its storeys and where each came from."""

    style: str
    variant: int
    storeys: int
    storeys_source: str  # the layer's floor field, or "height ÷ <typical storey> m"
    rule: str  # what chose the style, e.g. "BDTYP_CD 02001", "용도 공동주택, 15 storeys"
    phase: float  # where the module starts along the footprint ring, in modules [0, 1)

    @property
    def image(self) -> str:
        return f"{self.style}_{self.variant}"


class UseRule:
    """The use fields of one building layer (``for_fields``) and the facade they give each building."""

    def __init__(self, codes: Sequence[str], names: Sequence[str], osm: Sequence[str]):
        self.codes, self.names, self.osm = list(codes), list(names), list(osm)

    @classmethod
    def for_fields(cls, field_names: Sequence[str]) -> UseRule:
        lower = {name.lower(): name for name in field_names}

        def present(candidates: Sequence[str]) -> list[str]:
            return [lower[c.lower()] for c in candidates if c.lower() in lower]

        codes, names = present(CODE_FIELDS), present(NAME_FIELDS)
        if all(f.lower() in lower for f in _AL_D010):
            codes, names = codes + present(("A8",)), names + present(("A9",))
        return cls(codes, names, present(OSM_FIELDS))

    @property
    def fields(self) -> list[str]:
        return self.codes + self.names + self.osm

    def describe(self) -> str:
        """One line for the log: the fields tried, in order."""
        return " → ".join(self.fields + ["storeys"])

    def facade(self, wit_id: str, attributes: Mapping[str, Any], height: float, storeys: int | None,
               floors_field: str | None) -> Facade:
        """The facade of one building (``storeys``: the layer's count above ground, from ``floors_field``)."""
        style, rule = self._style(attributes)
        counted = storeys if storeys is not None and storeys >= 1 else None
        if not math.isfinite(height) or height <= 0:  # (the extrusion always gives one; another layer may not)
            height = (counted or 1) * STOREY_HEIGHT[style or VILLA]
        if style is None:  # housing of no stated kind, or no use at all: by storeys
            guess = counted or max(1, round(height / STOREY_HEIGHT[VILLA]))
            style = HOUSE if guess <= 2 else VILLA if guess <= 4 else APARTMENT
            rule = f"{rule}, {guess} storeys" if rule else f"{guess} storeys (no use field)"
        if counted:
            count, source = int(counted), str(floors_field)
        else:
            count = max(1, round(height / STOREY_HEIGHT[style]))
            source = f"height ÷ {STOREY_HEIGHT[style]:g} m"
        if style == OFFICE and count >= CURTAIN_WALL_STOREYS:
            style, rule = CURTAIN_WALL, f"{rule}, {count} storeys"
        digest = hashlib.blake2b(wit_id.encode("utf-8"), digest_size=4).digest()
        return Facade(style, digest[0] % VARIANTS, count, source, rule, digest[1] / 256.0)

    def _style(self, attributes: Mapping[str, Any]) -> tuple[str | None, str]:
        for field in self.codes:
            code = _text(attributes.get(field))
            if re.fullmatch(r"\d{4}", code):  # a code read as a number lost its leading zero
                code = code.zfill(5)
            if re.fullmatch(r"\d{5}", code):
                style = _HOUSING_CODES.get(code) or _CODE_CLASSES.get(code[:2])
                if style is not None or code[:2] in ("01", "02"):
                    return style, f"{field} {code}"
                if "01" <= code[:2] <= "29":  # a use of the table without a drawing of its own
                    return OTHER, f"{field} {code}"
        for field in self.names:
            name = re.sub(r"[\s·ㆍ.,/()]", "", _text(attributes.get(field)))
            if "주택외" in name:  # NGII's 종류 주택외건물, "a building other than housing": its 용도 tells
                continue
            for key, style in _NAMES:
                if key in name:
                    return style, f"{field} {name}"
        for field in self.osm:
            value = _text(attributes.get(field)).lower()
            if value in _OSM:
                return _OSM[value], f"{field}={value}"
        return None, ""


def _text(value: Any) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return ""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    return str(value).strip()
