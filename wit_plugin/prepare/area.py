"""The study area of a run: a circle, a polygon, the union of a polygon layer, or a legal dong."""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyproj
import shapely

from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.io.vector_io import VectorLayer, non_finite, read_layer
from ..infra.polygons import polygonal, transform

CIRCLE_QUAD_SEGS = 64  # 256-gon: at most 0.08 m inside a 1 km circle


@dataclass(frozen=True)
class StudyArea:
    """Where to build: a circle, a polygon, the union of a polygon layer, or a legal dong."""

    kind: str  # "circle", "polygon", "layer" or "district"
    x: float = 0.0
    y: float = 0.0
    radius: float = 0.0
    crs: str | None = None  # circle: CRS of x/y; polygon: CRS of the WKT; layer: source CRS if the file has none
    path: str | None = None
    layer: str | None = None
    code: str | None = None  # district: its code (EMD_CD) or its name (역삼동, Yeoksam-dong)
    wkt: str | None = None
    code_field: str | None = None  # district layers of another schema: the code / name fields
    name_field: str | None = None

    @classmethod
    def circle(cls, x: float, y: float, radius: float, crs: str = "EPSG:4326") -> StudyArea:
        """Centre (lon/lat by default, or x/y in ``crs``) and radius in metres of the target CRS."""
        if not (radius > 0 and math.isfinite(radius)):
            raise InputError(f"The study-area radius must be a positive number of metres, not {radius}.")
        return cls("circle", x=float(x), y=float(y), radius=float(radius), crs=crs)

    @classmethod
    def polygon(cls, geometry: shapely.Geometry | str, crs: str) -> StudyArea:
        """A polygon (or its WKT) in ``crs``: a bounding box, a map-sheet tile."""
        wkt = geometry if isinstance(geometry, str) else shapely.to_wkt(geometry)
        return cls("polygon", wkt=wkt, crs=crs)

    @classmethod
    def from_layer(cls, path: str | os.PathLike, layer: str | None = None, crs: str | None = None) -> StudyArea:
        """The union of a polygon layer's features."""
        return cls("layer", path=str(path), layer=layer, crs=crs)

    @classmethod
    def from_district_code(cls, code: str | int, code_field: str | None = None,
                           name_field: str | None = None) -> StudyArea:
        """A legal dong by its code (EMD_CD, 8 digits) or its name, looked up in the district layer.

        ``code_field`` / ``name_field`` name the fields of a district layer of another schema.
        """
        return cls("district", code=str(code).strip(), code_field=code_field or None, name_field=name_field or None)

    def geometry(self, target: pyproj.CRS, districts: VectorLayer | None = None,
                 feedback: Feedback = SILENT) -> shapely.Geometry:
        """The area as one polygon in ``target``; ``districts`` (already in ``target``) for a code."""
        if self.kind in ("circle", "polygon"):
            try:
                source_crs = pyproj.CRS.from_user_input(self.crs)
            except pyproj.exceptions.CRSError as exc:
                raise InputError(f"Unknown CRS {self.crs!r} for the study area: {exc}") from exc
            if self.kind == "polygon":
                try:
                    shape = shapely.from_wkt(self.wkt)
                except shapely.errors.GEOSException as exc:
                    raise InputError(f"The study-area polygon is not valid WKT: {exc}") from exc
                area = transform(np.array([shape], dtype=object), source_crs, target)[0]
            else:
                x, y = pyproj.Transformer.from_crs(source_crs, target, always_xy=True).transform(self.x, self.y)
                if not (math.isfinite(x) and math.isfinite(y)):
                    raise InputError(f"The study-area centre ({self.x}, {self.y}) is outside the area of use "
                                     f"of {self.crs}; check the coordinate order (x/lon first).")
                area = shapely.Point(x, y).buffer(self.radius, quad_segs=CIRCLE_QUAD_SEGS)
        elif self.kind == "layer":
            if self.path is None:  # (from_layer always sets it)
                raise InputError("A study-area layer needs the path of its file.")
            src = read_layer(self.path, self.layer, crs=self.crs, feedback=feedback)
            geoms = transform(src.geoms, src.crs, target)
            polys = geoms[np.isin(shapely.get_type_id(geoms), (3, 6))]
            bad = non_finite(polys)
            if bad.any():
                feedback.warning(f"The study-area layer {self.path}: {int(bad.sum())} polygon(s) with ±inf or NaN "
                                 "coordinates left out.")
                polys = polys[~bad]
            if len(polys) == 0:
                raise InputError(f"The study-area layer {self.path} has no polygons.")
            area = shapely.union_all(shapely.make_valid(polys))
        elif self.kind == "district":
            area = self._district(districts)
        else:
            raise InputError(f"Unknown study-area kind {self.kind!r}.")
        area = polygonal(np.array([area], dtype=object))[0]
        if area is None or area.is_empty or area.area <= 0:
            raise InputError("The study area is empty.")
        return area

    def _district(self, districts: VectorLayer | None) -> shapely.Geometry:
        """The dong whose code, or else whose (Korean or English) name, is ``self.code``."""
        if districts is None:
            raise InputError("A district code needs the district (legal-dong, TL_SCCO_EMD) layer as input.")
        if self.code is None:  # (from_district_code always sets it)
            raise InputError("A district study area needs the district's code or name.")
        layer = Path(districts.path).name
        code_fields = [self.code_field] if self.code_field else ["EMD_CD"]
        name_fields = [self.name_field] if self.name_field else ["EMD_KOR_NM", "EMD_ENG_NM"]
        found = districts.field_map(code_fields + name_fields)
        for wanted in (self.code_field, self.name_field):
            if wanted and wanted not in found:
                raise InputError(f"The district layer {layer} has no field {wanted!r}; its fields are "
                                 f"{', '.join(f.name for f in districts.fields)}.")
        if not found:
            raise InputError(f"The district layer {layer} has none of the fields {', '.join(code_fields + name_fields)}"
                             "; name its code and name fields (DISTRICT_CODE_FIELD, DISTRICT_NAME_FIELD).")

        def values(name: str | None) -> list[str]:
            column = districts.columns[found[name]] if name in found else [None] * len(districts)
            return [str(v).strip() if v is not None else "" for v in column]

        codes = values(code_fields[0])
        names = [values(n) for n in name_fields]
        wanted = self.code.casefold()
        hits = [i for i, c in enumerate(codes) if c == self.code]
        if not hits:
            hits = [i for i in range(len(districts)) if any(column[i].casefold() == wanted for column in names)]
        labels = [" ".join(v for v in (codes[i], names[0][i]) if v) for i in range(len(districts))]
        if not hits:
            raise InputError(f"District {self.code!r} is neither a code nor a name in {layer}; it has "
                             f"{', '.join(labels[:8])}{' …' if len(labels) > 8 else ''}.")
        if len({codes[i] for i in hits}) > 1:
            raise InputError(f"The name {self.code!r} is ambiguous in {layer}: give the code of one of "
                             f"{', '.join(labels[i] for i in hits)}.")
        return shapely.union_all(districts.geoms[hits])
