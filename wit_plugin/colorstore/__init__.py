"""The vector-based colour store (``wit:buildcolorstore``, ``wit:querycolorstore``).

The paper (§4.1, Table 14) stores, per cell, the RGB colours at the cell's four corners (LB, RB,
RT, LT) and its resolution in a spatial database, and answers "colour(s) at this place" with a
query instead of loading an image. This module defines that store precisely:

* **Lattice.** Cells live on the lattice of pixel *centres*: lattice point (c, r) is the centre of
  pixel column c, row r, at x = X0 + (c + ½)·px, y = Y0 − (r + ½)·py. A cell spans lattice
  columns c0…c1 and rows r0…r1 (c1 > c0, r1 > r0); its corner colours are the source pixels at
  its four corner points, exactly, so the reconstruction is exact at cell corners. Neighbouring
  cells share their edge lattice lines. The stored domain is the image extent shrunk by half a
  pixel; queries in that outer half-pixel border take the colour at the nearest domain point.
* **Reconstruction.** Inside a cell, colour = LB(1−u)(1−v) + RB·u(1−v) + RT·uv + LT(1−u)v with
  u = (c − c0)/(c1 − c0) from left to right and v = (r1 − r)/(r1 − r0) from bottom to top.
* **Adaptive quadtree.** The image is processed in root blocks of ``block_size`` lattice
  intervals (level 0), each read with one windowed ``ReadAsArray``. A cell is split into four
  while its reconstruction error over the source pixels it covers (all channels, 0–255 units)
  exceeds ``tolerance`` and it is above ``max_depth`` and wider than one lattice interval (such a
  cell has all its pixels as corners: exact). The error is the root mean square (``rms``, the
  default: sensor noise and fine texture average out) or the largest (``max``: a hard bound, but
  on real orthophotos it splits most cells down to a few pixels). Cells of a level are evaluated
  at once with numpy, grouped by shape (edge blocks are clipped to the image).
* **Guarantee** (``max``). Every stored cell within ``max_depth`` errs by at most ``tolerance``
  at every pixel centre. Within one pixel square both the store and the source's bilinear
  interpolation are bilinear, so the store is within ``tolerance`` of the source's bilinear
  interpolation *everywhere* in the domain; rounding the answer to integers adds at most ½.
  With ``rms`` the same holds for each cell's root mean square over its pixels.
* **Storage.** A GeoPackage by default (OGR's GPKG driver, which builds the R-tree): table
  ``table`` with the cell rectangle (Polygon, ortho CRS) as geometry and INTEGER columns
  ``level``, ``c0 r0 c1 r1`` (the lattice bounds, so that interpolation is exact whatever the
  float rounding of the geometry) and ``lb_r lb_g lb_b rb_* rt_* lt_*``; table ``<table>_meta``
  (key, JSON value) with the source, grid, CRS, tolerance and build figures. Or PostGIS when a
  connection string is given: the same tables (``geometry(Polygon, srid)`` with a GiST index,
  smallint colours), written with COPY in one transaction.
* **Queries.** A point finds one containing cell through the R-tree / GiST index (then filtered
  exactly on the lattice bounds); a patch fetches all cells meeting the requested box and
  rasterises them with the bilinear formula above, vectorised over texels.

Atomicity: a GeoPackage is written under a temporary name and renamed when complete; a PostGIS
store is created (replacing a previous one of the same name) in a single transaction, rolled back
on error or cancel. Memory is bounded by one root block, the capped GDAL cache and one batch.
PostgreSQL is reached through psycopg2 (Debian's python3-psycopg2, which QGIS's Python already
depends on), imported only when a PostGIS store is used.

Modules: ``schema`` (tables, columns, cells), ``build`` (the quadtree, ``build_color_store``),
``backends`` (GeoPackage and PostGIS writers and readers), ``query`` (``ColorStore`` and the queries).
"""
from .build import BuildReport, build_color_store
from .query import ColorStore, export_patch, query_patch, query_point
from .schema import CELL_COLUMNS, DEFAULT_BLOCK_SIZE, DEFAULT_TABLE, DEFAULT_TOLERANCE, METRICS

__all__ = ["CELL_COLUMNS", "DEFAULT_BLOCK_SIZE", "DEFAULT_TABLE", "DEFAULT_TOLERANCE", "METRICS", "BuildReport",
           "ColorStore", "build_color_store", "export_patch", "query_patch", "query_point"]
