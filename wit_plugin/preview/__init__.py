"""Preview picture of the textured city model: a small numpy software renderer (PNG for a README).

Reads the step outputs named in ``infra.step_layers`` (LoD1 faces, optionally the TIN and the texture folder of
``wit:wittexture``) and draws the model seen obliquely through a perspective camera:

* **Geometry**: roof faces (holes included) are cut into triangles by a constrained Delaunay
  triangulation (``shapely.constrained_delaunay_triangles``); their z and texture coordinates are
  affine in x, y (planar faces, axis-aligned texture islands), fitted per face on the exterior ring;
  a self-intersecting roof is made valid first. Walls are fanned (quads in practice); ``ground``
  faces are never visible and are skipped; TIN triangles are drawn as they are (``footprint`` ones
  too, hidden under the buildings).
* **Camera**: placed at ``azimuth_deg`` (compass bearing from the model's centre to the camera) and
  ``elevation_deg`` above the horizon, at three times the model's radius; the focal length and
  principal point are fitted so that every vertex lies in the picture with a small margin.
* **Rasteriser**: triangles are bucketed by the power-of-two size of their pixel bounding box and
  processed in vectorised chunks (every candidate pixel of a chunk's boxes at once: barycentric
  coordinates, inside test, depth). Each chunk's fragments are resolved against a 32-bit z-buffer
  by one sort on (pixel, depth). The buffer keeps the triangle and two screen-space barycentrics
  per pixel; shading is deferred, once per visible pixel.
* **Shading**: texture coordinates are interpolated perspective-correctly and sampled bilinearly
  from the mip level matching each triangle's texel-to-pixel ratio (levels built with
  ``texture.images.mip_chain``, images read once and cached); untextured surfaces get a flat colour
  (walls beige, a little lighter or darker per building; terrain green-grey, roads dark grey).
  Lambert shading from a sun 65° clockwise of the camera: strong on walls, mild on roofs and
  terrain; building outlines (depth or building changes) are darkened a little, distance adds
  haze, the background is a sky gradient. The picture is rendered at twice the requested size and
  box-filtered down (anti-aliasing).

The PNG is written atomically: a cancelled or failed run leaves no file.

Modules: ``scene`` (the step outputs read into triangles), ``camera`` (the camera and the
rasteriser), ``shading`` (textures, colours, light, haze); this one renders and writes the PNG.
"""
from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np
from osgeo import gdal

from ..infra.errors import InputError, WitError
from ..infra.feedback import SILENT, Feedback, LoggingFeedback
from ..infra.io.fileio import atomic_file
from .camera import _Camera, _rasterise
from .scene import _KINDS, PreviewReport, _Mesh, _read_lod1, _read_tin, _TexTable
from .shading import _downsample, _ImageCache, _shade

SUPERSAMPLE = 2  # rendered at this multiple of the output size, then box-filtered down


def render_preview(lod1_gpkg: str, tin_gpkg: str | None, textures: str | None, output_png: str,
                   width: int = 1600, height: int = 1000, azimuth_deg: float = 135.0, elevation_deg: float = 40.0,
                   vertical_exaggeration: float = 1.0, feedback: Feedback = SILENT) -> PreviewReport:
    """Render the model to ``output_png``; see the module docstring.

    ``tin_gpkg`` and ``textures`` may be None (no terrain; flat colours). Raises ``InputError`` for
    unusable inputs or parameters and ``CanceledError`` on cancel; then no file is written.
    """
    if not (16 <= width <= 16384 and 16 <= height <= 16384):
        raise InputError(f"Picture size {width} × {height} is out of range: use 16–16384 pixels a side.")
    if not 5.0 <= elevation_deg <= 90.0:
        raise InputError(f"Camera elevation {elevation_deg:g}° is out of range: use 5–90°.")
    if not 0.0 < vertical_exaggeration <= 100.0:
        raise InputError(f"Vertical exaggeration {vertical_exaggeration:g} is out of range: use 0 < factor ≤ 100.")
    report = PreviewReport(output=str(output_png), width=width, height=height)
    start = time.perf_counter()
    images: list[str] = []
    table = _TexTable.read(textures, images) if textures else None
    buildings = _read_lod1(lod1_gpkg, table, report)
    feedback.check_canceled()
    meshes = [buildings] + ([_read_tin(tin_gpkg, table)] if tin_gpkg else [])
    mesh = _Mesh.concat(meshes)
    if len(mesh.xyz) == 0:
        raise InputError(f"Nothing to draw: {lod1_gpkg} has no roof or wall faces"
                         + (f" and {tin_gpkg} no triangles." if tin_gpkg else "."))
    report.triangles = {name: int(np.count_nonzero(mesh.kind == k)) for k, name in enumerate(_KINDS)}
    report.textured_triangles = int(np.count_nonzero(mesh.image >= 0))
    report.images = len(set(mesh.image[mesh.image >= 0].tolist()))
    feedback.info(f"Preview: {len(mesh.xyz)} triangles ({', '.join(f'{k} {v}' for k, v in report.triangles.items())}), "
                  f"{report.textured_triangles} textured from {report.images} image(s).")
    if report.untextured_roofs:
        feedback.warning(f"{report.untextured_roofs} roof face(s) have no texture row: drawn in a flat colour.")
    feedback.progress(10.0)
    report.seconds["read"] = time.perf_counter() - start

    mesh.xyz[:, :, 2] = (mesh.xyz[:, :, 2] - mesh.xyz[:, :, 2].min()) * vertical_exaggeration
    camera = _Camera.framing(mesh.xyz, width * SUPERSAMPLE, height * SUPERSAMPLE, azimuth_deg, elevation_deg)
    start = time.perf_counter()
    frame = _rasterise(camera, mesh.xyz, feedback.scaled(10.0, 75.0))
    report.seconds["raster"] = time.perf_counter() - start
    start = time.perf_counter()
    rgb = _shade(camera, mesh, frame, _ImageCache(Path(textures) if textures else None, images), azimuth_deg, feedback)
    picture = _downsample(rgb, SUPERSAMPLE)
    report.seconds["shade"] = time.perf_counter() - start
    feedback.check_canceled()
    start = time.perf_counter()
    _write_png(picture, output_png)
    report.seconds["write"] = time.perf_counter() - start
    feedback.info("Preview written to {} ({}).".format(
        output_png, ", ".join(f"{k} {v:.1f} s" for k, v in report.seconds.items())))
    feedback.progress(100.0)
    return report


def _write_png(picture: np.ndarray, output_png: str) -> None:
    h, w = picture.shape[:2]
    with atomic_file(output_png) as tmp:
        mem = gdal.GetDriverByName("MEM").Create("", w, h, 3, gdal.GDT_Byte)
        for b in range(3):
            mem.GetRasterBand(b + 1).WriteArray(picture[:, :, b])
        try:
            written = gdal.GetDriverByName("PNG").CreateCopy(str(tmp), mem)
        except RuntimeError as exc:  # with gdal.UseExceptions()
            raise InputError(f"Cannot write the preview {output_png}: {exc}") from exc
        if written is None:
            raise InputError(f"Cannot write the preview {output_png}: {gdal.GetLastErrorMsg()}")
        written = mem = None


def main(argv: list[str] | None = None) -> int:
    """``python -m wit_plugin.preview LOD1.gpkg TIN.gpkg TEXTURES_DIR OUT.png`` ("-" for no TIN / textures)."""
    parser = argparse.ArgumentParser(prog="python -m wit_plugin.preview", description=__doc__.split("\n")[0])
    parser.add_argument("lod1", help="LoD1 faces GeoPackage (wit:extrudebuildings)")
    parser.add_argument("tin", help="TIN GeoPackage (wit:triangulateterrain), or - for none")
    parser.add_argument("textures", help="texture folder (wit:wittexture), or - for none")
    parser.add_argument("output", help="PNG to write")
    parser.add_argument("--width", type=int, default=1600)
    parser.add_argument("--height", type=int, default=1000)
    parser.add_argument("--azimuth", type=float, default=135.0, help="compass bearing from the model to the camera")
    parser.add_argument("--elevation", type=float, default=40.0, help="camera elevation above the horizon, degrees")
    parser.add_argument("--exaggeration", type=float, default=1.0, help="vertical exaggeration")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        render_preview(args.lod1, None if args.tin == "-" else args.tin,
                       None if args.textures == "-" else args.textures, args.output, args.width, args.height,
                       args.azimuth, args.elevation, args.exaggeration, LoggingFeedback())
    except WitError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0
