"""Model CRS → Earth-centred frames for 3D Tiles: ECEF, local east-north-up frames, regions.

3D Tiles places content in ECEF (EPSG:4978). Vertices are stored in a *tile-local* east-north-up
frame whose origin is the tile's centre, so float32 positions keep sub-millimetre precision; the
tile's ``transform`` (ECEF ← local) carries the origin in float64. Heights of the model (the
national DEM's, orthometric) are taken as ellipsoidal heights: the whole model sits about one geoid
undulation (≈ 25 m in Korea) off the WGS84 ellipsoid, which an offline viewer without a globe
terrain does not show, and the tileset round-trips to the model's coordinates exactly.
"""
from __future__ import annotations

import math

import numpy as np
from pyproj import CRS, Transformer
from pyproj.exceptions import CRSError

from ..infra.errors import InputError

#: glTF is y-up; 3D Tiles runtimes turn glTF (x, y, z) into (x, −z, y). Local ENU (e, n, u) is
#: therefore stored as (e, u, −n).
ENU_TO_GLTF = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
REGION_MARGIN_RAD = 1e-8  # ≈ 6 cm on the ground: regions are computed from vertices
REGION_MARGIN_M = 0.1


class Georeference:
    """Transforms from one projected model CRS (metres) to ECEF and geographic coordinates."""

    def __init__(self, crs: str):
        try:
            source = CRS.from_user_input(crs)
        except CRSError as exc:
            raise InputError(f"CRS '{crs}' is not known to PROJ: give an EPSG code such as EPSG:5186.") from exc
        if not source.is_projected or source.axis_info[0].unit_name not in ("metre", "meter"):
            raise InputError(f"CRS '{crs}' is not a projected CRS in metres: the model's layers must be in one "
                             "(default EPSG:5186).")
        self.crs = source
        self._ecef = Transformer.from_crs(source, "EPSG:4978", always_xy=True)
        self._geographic = Transformer.from_crs(source, "EPSG:4979", always_xy=True)

    def ecef(self, xyz: np.ndarray) -> np.ndarray:
        """(n, 3) model coordinates → (n, 3) ECEF metres."""
        x, y, z = self._ecef.transform(xyz[:, 0], xyz[:, 1], xyz[:, 2])
        return np.column_stack([x, y, z])

    def model_from_ecef(self, ecef: np.ndarray) -> np.ndarray:
        """Inverse of ``ecef`` (for checks)."""
        x, y, z = self._ecef.transform(ecef[:, 0], ecef[:, 1], ecef[:, 2], direction="INVERSE")
        return np.column_stack([x, y, z])

    def frame(self, x: float, y: float, z: float) -> np.ndarray:
        """4 × 4 matrix ECEF ← local east-north-up at the model point (x, y, z)."""
        lon, lat, _ = self._geographic.transform(x, y, z)
        origin = self.ecef(np.array([[x, y, z]]))[0]
        lam, phi = math.radians(lon), math.radians(lat)
        east = [-math.sin(lam), math.cos(lam), 0.0]
        north = [-math.sin(phi) * math.cos(lam), -math.sin(phi) * math.sin(lam), math.cos(phi)]
        up = [math.cos(phi) * math.cos(lam), math.cos(phi) * math.sin(lam), math.sin(phi)]
        matrix = np.eye(4)
        matrix[:3, 0], matrix[:3, 1], matrix[:3, 2], matrix[:3, 3] = east, north, up, origin
        return matrix

    def local(self, frame: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        """(n, 3) model coordinates → glTF (y-up) positions in ``frame``, float64."""
        return self.local_of_ecef(frame, self.ecef(xyz))

    @staticmethod
    def local_of_ecef(frame: np.ndarray, ecef: np.ndarray) -> np.ndarray:
        """(n, 3) ECEF points → glTF (y-up) positions in ``frame``, float64 (``local`` of points already in ECEF)."""
        return ((ecef - frame[:3, 3]) @ frame[:3, :3]) @ ENU_TO_GLTF.T

    def region(self, xyz: np.ndarray) -> list[float]:
        """3D Tiles region [west, south, east, north, min height, max height] (radians, metres) around points."""
        lon, lat, h = self._geographic.transform(xyz[:, 0], xyz[:, 1], xyz[:, 2])
        lon, lat = np.radians(lon), np.radians(lat)
        return [float(lon.min()) - REGION_MARGIN_RAD, float(lat.min()) - REGION_MARGIN_RAD,
                float(lon.max()) + REGION_MARGIN_RAD, float(lat.max()) + REGION_MARGIN_RAD,
                float(np.min(h)) - REGION_MARGIN_M, float(np.max(h)) + REGION_MARGIN_M]


def union_region(regions: list[list[float]]) -> list[float]:
    """The smallest region holding all ``regions``."""
    a = np.array(regions)
    return [float(a[:, 0].min()), float(a[:, 1].min()), float(a[:, 2].max()), float(a[:, 3].max()),
            float(a[:, 4].min()), float(a[:, 5].max())]


def gltf_to_model(georef: Georeference, frame: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """glTF positions of a tile with world matrix ``frame`` → model coordinates (the inverse of ``local``)."""
    enu = positions @ ENU_TO_GLTF
    return georef.model_from_ecef(enu @ frame[:3, :3].T + frame[:3, 3])


def column_major(matrix: np.ndarray) -> list[float]:
    """A 4 × 4 matrix as 3D Tiles writes a ``transform``: 16 numbers, column after column."""
    return [float(v) for v in np.asarray(matrix).T.ravel()]
