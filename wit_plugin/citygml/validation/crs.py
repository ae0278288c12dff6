"""The units and axis order of a geometry's CRS, so that metre tolerances mean metres in any CRS.

The geometric checks (vertex matching, planarity, areas, volumes) compare distances with
tolerances in metres. Coordinates in a projected CRS are metres (or feet: scaled); coordinates in
a geographic CRS are degrees, where 0.001 would be 100 m. A ``Frame`` turns the positions of one
solid or triangle into local metres around its first vertex: east, north and up, scaled by the
metres per degree of the ellipsoid at that latitude (the error over a 1 km feature is below a
millimetre, and the frame stays right-handed whatever the CRS's axis order).

Axis order, as GDAL's GML reader reads it: the short form ``EPSG:n`` is longitude (easting) first;
the URN (``urn:ogc:def:crs:EPSG::n``) and URL (``http://www.opengis.net/def/crs/EPSG/0/n``) forms
follow EPSG's order — latitude first for EPSG:4326, 4979 and 6697 (Japan's PLATEAU), northing
first for the Korean belts (EPSG:5185–5188) and 5179. A solid read in the wrong order is a mirror
image: every face points inwards. Writers disagree about these CRSs, so such a finding says how
the file would read in the other order.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import re
from dataclasses import dataclass

import numpy as np

_SHORT_FORM = re.compile(r"^\s*EPSG:\d+\s*$", re.IGNORECASE)
_EPSG_CODE = re.compile(r"EPSG(?:/[\d.]+/|:[\d.]*:|:)(\d+)", re.IGNORECASE)
_METRE_UOMS = {"m", "metre", "meter", "urn:ogc:def:uom:EPSG::9001", "http://www.opengis.net/def/uom/EPSG/0/9001",
               "EPSG:9001"}


@dataclass(frozen=True)
class Frame:
    """How positions of one CRS become local metres (see the module docstring)."""
    name: str | None
    geographic: bool = False
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)  # metres per unit of x, y, z (not geographic)
    lat_axis: int = 1  # the axis holding latitude / northing (0: lat/lon, northing first; 1: lon/lat, easting first)
    semi_major: float = 6378137.0
    flattening: float = 1 / 298.257222101
    assumed: str | None = None  # what was assumed for a CRS that is not known offline (for a warning)
    disputed: bool = False  # EPSG's order is north first: files of this CRS are written both ways

    @property
    def order(self) -> str:
        """How the file's coordinates are read, for messages: e.g. "longitude first"."""
        first = ("latitude" if self.geographic else "northing") if self.lat_axis == 0 else (
            "longitude" if self.geographic else "easting")
        return f"{first} first"

    @property
    def other_order(self) -> str:
        return self.swapped().order

    @property
    def decimals(self) -> int:
        """Decimals that show a millimetre in messages."""
        return 8 if self.geographic else 3

    def swapped(self) -> Frame:
        """The same CRS read in the other horizontal axis order."""
        return dataclasses.replace(self, lat_axis=1 - self.lat_axis)

    def metres_per_unit(self, origins: np.ndarray) -> np.ndarray:
        """(n, 3) metres per unit of each axis at each origin (n, 3), in the CRS's axis order."""
        if not self.geographic:
            return np.broadcast_to(np.asarray(self.scale), origins.shape)
        lat = np.radians(origins[:, self.lat_axis])
        e2 = self.flattening * (2 - self.flattening)
        w = np.sqrt(1 - e2 * np.sin(lat) ** 2)
        per_deg_lat = math.pi / 180 * self.semi_major * (1 - e2) / w ** 3  # meridian radius of curvature
        per_deg_lon = math.pi / 180 * self.semi_major / w * np.cos(lat)  # prime vertical, on the parallel
        out = np.ones_like(origins, dtype=float)
        out[:, self.lat_axis] = per_deg_lat
        out[:, 1 - self.lat_axis] = per_deg_lon
        return out

    def to_local(self, points: np.ndarray, origin: np.ndarray, per_unit: np.ndarray) -> np.ndarray:
        """``points`` (…, 3) as east/north/up metres from ``origin`` (3,), given ``metres_per_unit`` there."""
        local = (points - origin) * per_unit
        return local[..., [1, 0, 2]] if self.lat_axis == 0 else local

    def from_local(self, local: np.ndarray, origin: np.ndarray, per_unit: np.ndarray) -> np.ndarray:
        """Inverse of ``to_local`` (for positions named in messages)."""
        if self.lat_axis == 0:
            local = local[..., [1, 0, 2]]
        return local / per_unit + origin


def frame_of(srs_name: str | None, inline_units: dict[str, bool] | None = None) -> Frame:
    """The frame of ``srs_name``; an unknown CRS is read as metres (``Frame.assumed`` says so).

    ``inline_units``: for CRSs defined in the document (``srsName="#id"``), whether all their axes
    are in metres.
    """
    if not srs_name:
        return Frame(None, assumed="no srsName is given")
    if srs_name.startswith("#"):
        if (inline_units or {}).get(srs_name[1:]):
            return Frame(srs_name)
        return Frame(srs_name, assumed="the CRS defined in the file has axes not in metres or could not be read")
    return _frame_of_name(srs_name)


@functools.lru_cache(maxsize=64)
def _frame_of_name(srs_name: str) -> Frame:
    codes = [int(c) for c in _EPSG_CODE.findall(srs_name)]
    if not codes:
        if _is_adv_projected(srs_name):
            return Frame(srs_name)
        return Frame(srs_name, assumed="the CRS is not an EPSG code known offline")
    import pyproj  # imported here: only files with an EPSG srsName need it
    try:
        horizontal = pyproj.CRS.from_epsg(codes[0])
        vertical = pyproj.CRS.from_epsg(codes[1]) if len(codes) > 1 else None
    except pyproj.exceptions.CRSError:
        return Frame(srs_name, assumed=f"EPSG:{codes[0]} is not in the PROJ database")
    axes = list(horizontal.axis_info) + (list(vertical.axis_info) if vertical is not None else [])
    north_first = axes[0].direction == "north"  # EPSG's order
    # "EPSG:n" is longitude / easting first by GIS custom (GDAL's GML reader); URNs and URLs follow EPSG's order
    lat_axis = 0 if north_first and not _SHORT_FORM.match(srs_name) else 1
    ellipsoid = horizontal.ellipsoid
    if horizontal.is_geographic and ellipsoid is not None:  # (a geographic CRS always has its ellipsoid)
        height = axes[2].unit_conversion_factor if len(axes) > 2 else 1.0
        return Frame(srs_name, True, (1.0, 1.0, height), lat_axis, ellipsoid.semi_major_metre,
                     1 / ellipsoid.inverse_flattening if ellipsoid.inverse_flattening else 0.0, disputed=north_first)
    factors = [a.unit_conversion_factor or 1.0 for a in axes] + [1.0] * 3
    return Frame(srs_name, scale=(factors[0], factors[1], factors[2]), lat_axis=lat_axis, disputed=north_first)


def _is_adv_projected(srs_name: str) -> bool:
    """German AdV CRS names (``urn:adv:crs:DE_DHDN_3GK4*DE_DHHN92_NH``, ``…ETRS89_UTM32…``): GK and UTM are metres."""
    if not srs_name.lower().startswith("urn:adv:crs:"):
        return False
    horizontal = srs_name.split(":")[-1].split("*")[0].upper()
    return "UTM" in horizontal or "GK" in horizontal


def metre_axes(uoms: list[str]) -> bool:
    """True when every axis unit of an inline CRS definition is the metre."""
    return bool(uoms) and all(u.strip() in _METRE_UOMS for u in uoms)
