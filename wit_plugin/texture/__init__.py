"""Texture roofs, terrain and roads from the merged orthoimage (``wit:wittexture``).

Inputs follow ``infra.step_layers``: the LoD1 faces layer (``lod1_faces``), the TIN layer (``tin``) and the
merged orthoimage (north-up RGB GeoTIFF; in another CRS than the layers', the window over them
is reprojected as it is read, bilinear, ``_Ortho.reproject_to``). Outputs, in ``output_dir`` (the texture
folder): JPEG or PNG images and ``texcoords.gpkg`` holding the attribute table ``texcoords``
(one row per textured ring, ``step_layers.TEX_*`` columns, image names relative to the folder).

What is textured, and how:

* **Roofs** (LoD1 faces ``roof``): each roof face is an *island* cut from the ortho over its 2D
  bounding box, packed into **roof atlases** (``roof_atlas_NNNN``) by shelf packing. Islands are
  padded by ``gutter`` texels of dilated edge pixels and placed on a grid of
  A = 2^⌊log2 gutter⌋ texels with slot sizes rounded up to A (the extra texels are dilated too),
  so mip levels 0…log2 A average texels of one island only: no neighbour bleeds in. An atlas is
  written when the next island does not fit; its sides are cropped to the next power of two of
  the used area (≤ ``atlas_size``).
* **Terrain and roads** (TIN triangles ``terrain`` and ``road``): a ``road`` triangle with a
  ``feature_id`` gets target ``road`` (the CityGML writer puts it in its road's traffic area),
  every other one target ``tin`` (it stays in the relief, as the writer places it). Triangles
  are grouped by **ground square**, a grid anchored on the ortho's origin whose side is 7/8
  of ``atlas_size`` texels. A triangle belongs to the square holding its first vertex;
  each non-empty square becomes one image (``ground_rRRRR_cCCCC``) covering the bounding box of its
  triangles plus ``gutter`` texels of real ortho context. Per-triangle islands would cost an
  island (and a gutter) per 5 m triangle; a ground square needs no packing and keeps neighbouring
  triangles continuous.
* A surface (or ground square) whose texture exceeds ``atlas_size`` (minus the gutters) is
  downscaled to fit, keeping its extent; the report counts such images (``downscaled``).
* **Not textured**: LoD1 ``wall`` faces (an orthoimage shows no facades: the CityGML writer gives
  walls no texture or a plain material), ``ground`` faces (never visible) and TIN ``footprint``
  triangles (under the buildings). The report counts them (``untextured``); the table has no rows
  for them.

UV mapping: for an image covering the ground extent [xmin, xmax] × [ymin, ymax],
U = (x − xmin)/(xmax − xmin), V = (y − ymin)/(ymax − ymin), V measured from the bottom (CityGML /
OpenGL). The half-pixel correction is built in: xmin…ymax are the *outer edges* of the image's
edge texels (their centres ± half a texel), so with S = 1 a vertex at the centre of ortho pixel i
gets u·W = i' + ½, the centre of the texel holding that pixel. In an atlas the island's extent
maps onto its texel rectangle and U, V are taken over the atlas.

Scale S: a texel is about 1/S ortho pixels; windows are snapped to multiples of round(1/S)
pixels, so S = 1/n averages exact n × n pixel blocks (GDAL average resampling). Every texture
window is read with a windowed ``ReadAsArray``; the ortho is never loaded whole, and GDAL's block
cache is capped during the run as in wit:mergerasters. Features are read in bulk (``bulk_read``): a
first pass places each in its ground square (4 bytes a feature kept), then runs of squares whose
points fit in ``_POINTS_IN_MEMORY`` are read together (one run for the 1 km demo's 592,000
triangles). Memory is bounded by the cache cap, one atlas and one run of squares, whatever the
size of the ortho. Images are encoded and table rows inserted in a worker thread.

Coverage: if a textured layer's extent is not inside the ortho's, the run stops before writing
anything (``InputError``): merge the orthoimage sheets that cover the study area or clip the study area.
NoData pixels inside the ortho are textured as they are.

Mipmaps (paper Table 10): ``mip_chain`` gives the box-filtered chain to 1 × 1 for any image;
with ``write_mipmaps`` each image's levels 1… are written as ``<image>_mip<k>.<ext>``. KTX2 is
not written: the Khronos Python binding (pyktx) is source-only and needs libktx, which Debian
does not package; the only installable wheel (alktx2) is a young single-author project.

Modules: ``config`` (settings, report, names), ``sources`` (the layers and the ortho as read),
``images`` (images, atlases and the texture-coordinate table as written); this one runs the step.
"""
from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
import shapely
from osgeo import ogr
from shapely.geometry.base import BaseGeometry

from ..infra import step_layers
from ..infra.errors import InputError
from ..infra.feedback import SILENT, Feedback
from ..infra.gc_pause import collector_paused
from ..infra.gdal_env import capped_block_cache
from ..infra.io import bulk_read
from ..infra.io.fileio import atomic_files
from ..infra.io.gpkg_bulk import BulkTable
from ..infra.io.vector_io import FieldDef
from ..infra.numtext import ring_texts
from .config import (
    BEYOND_ORTHO,
    FACADE_CHOICES,
    FACADES_GENERATED,
    FORMATS,
    ROAD_TARGET,
    ROOF_TARGET,
    TEXCOORDS_FILE,
    TEXTURED_TIN_SURFACES,
    TIN_TARGET,
    WALL_TARGET,
    TextureConfig,
    TextureReport,
)
from .facade import QUAD_POINTS, FacadeReport, FacadeSource, facade_images, plan_facades, wall_rows
from .images import UV_PAIR, _AtlasPacker, _Output
from .sources import _Grid, _Layer, _Ortho, _Rings


def texture_model(
    ortho: str,
    lod1_gpkg: str | None,
    tin_gpkg: str | None,
    output_dir: str,
    config: TextureConfig | None = None,
    feedback: Feedback = SILENT,
    coverage: BaseGeometry | None = None,
) -> TextureReport:
    """Cut roof, terrain and road textures from ``ortho`` into ``output_dir``; see the module docstring.

    Either layer file may be None (then its surfaces are not textured), not both. With ``coverage``
    (where the ortho has pixels, e.g. the union of its sheets), surfaces not inside it are left
    untextured and counted (``untextured["outside_ortho"]``) instead of refusing the layers. Raises
    ``InputError`` for unusable inputs or parameters and ``CanceledError`` on cancel; in both
    cases nothing is written to ``output_dir``.
    """
    config = config or TextureConfig()
    _check_config(config)
    if not lod1_gpkg and not tin_gpkg:
        raise InputError("Give the LoD1 faces layer, the TIN layer or both: there is nothing to texture.")
    with contextlib.ExitStack() as stack:  # datasets closed on any exit, not when a traceback dies
        stack.enter_context(collector_paused())
        image = _Ortho(ortho, config)
        stack.callback(image.close)
        roofs = tin = None
        untextured: dict[str, int] = {}
        if lod1_gpkg:
            roofs = _Layer(lod1_gpkg, step_layers.LOD1_LAYER, step_layers.FACE_TYPE,
                           (step_layers.WIT_ID, step_layers.FACE_TYPE, step_layers.FACE_NUMBER), (ROOF_TARGET,),
                           step_layers.LOD1_ROLE)
            stack.callback(roofs.close)
            untextured.update({k: roofs.count((k,)) for k in ("wall", "ground")})
        if tin_gpkg:
            tin = _Layer(tin_gpkg, step_layers.TIN_LAYER, step_layers.TIN_SURFACE,
                         (step_layers.TIN_TRIANGLE_ID, step_layers.TIN_SURFACE, step_layers.TIN_FEATURE_ID),
                         TEXTURED_TIN_SURFACES, step_layers.TIN_ROLE)
            stack.callback(tin.close)
            untextured["footprint"] = tin.count(("footprint",))
        layers = [layer for layer in (roofs, tin) if layer is not None]
        image.reproject_to(layers, feedback)
        for layer in layers:
            image.check_covers(layer, extent=coverage is None)
        inside = _Inside(coverage, untextured)
        if not any(layer.surfaces for layer in layers):
            raise InputError("Nothing to texture: the LoD1 layer has no 'roof' faces and the TIN no 'terrain' or "
                             "'road' triangles.")
        report = TextureReport(output_dir=str(output_dir), texcoords=str(Path(output_dir) / TEXCOORDS_FILE),
                               untextured=untextured, texel_size=image.texel_size,
                               texels_per_m2=1.0 / image.texel_size ** 2)
        facades = roofs is not None and config.facades == FACADES_GENERATED and untextured["wall"] > 0
        feedback.info(f"Texel {image.texel_size:g} m (S = {config.scale:g}); {roofs.surfaces if roofs else 0} roof "
                      f"face(s), {tin.surfaces if tin else 0} terrain/road triangle(s); walls: "
                      f"{'generated facades' if facades else 'not textured'}.")
        grid = _Grid(image, config)
        share = 100.0 * (roofs.surfaces if roofs else 0) / sum(layer.surfaces for layer in layers)
        walls = 10.0 if facades else 0.0
        with capped_block_cache(), atomic_files([report.texcoords]) as tmp:
            out = _Output(tmp, FORMATS[config.image_format.upper()], config, report)
            try:
                if roofs is not None:
                    _texture_roofs(roofs, image, grid, out, config, inside, feedback.scaled(0.0, share))
                if facades and lod1_gpkg:  # (facades: the roofs' layer is given)
                    _texture_walls(lod1_gpkg, tmp, out, feedback.scaled(share, share + walls))
                if tin is not None:
                    _texture_ground(tin, image, grid, out, config, inside, feedback.scaled(share + walls, 100.0))
                out.finish()
            finally:
                out.close()
            report.bytes_written = sum(p.stat().st_size for p in tmp.iterdir())
    if untextured.get(BEYOND_ORTHO):
        feedback.warning(f"{untextured[BEYOND_ORTHO]} surface(s) lie outside the orthoimage and are left untextured.")
    feedback.info(f"Wrote {len(report.images)} image(s) ({report.atlases} roof atlas(es), {report.ground_images} "
                  f"ground square(s)), {report.mip_files} mip file(s), {report.bytes_written / 1e6:.1f} MB.")
    feedback.progress(100.0)
    return report


def _texture_walls(lod1: str, folder: Path, out: _Output, feedback: Feedback) -> None:
    """Generated facades (``texture.facade``): the facade table, the images, then the walls' rows."""
    source = FacadeSource(lod1)
    plan = FacadeReport()
    try:
        table = BulkTable(folder / step_layers.FACADE_FILE, step_layers.FACADE_TABLE, _FACADE_FIELDS)
        try:
            for rows in plan_facades(source, plan):
                feedback.check_canceled()
                table.insert(rows)
        finally:
            table.close()
        for name, pixels in facade_images(plan):
            out.submit([], (name, pixels))
        total = out.report.untextured["wall"]
        for batch in wall_rows(source, plan):
            feedback.check_canceled()
            uv = ring_texts(np.concatenate([row[3] for row in batch]), np.full(len(batch), QUAD_POINTS), UV_PAIR)
            out.submit([(WALL_TARGET, wit_id, face, name, text) for (wit_id, name, face, _), text in zip(batch, uv)])
            feedback.progress(100.0 * plan.walls / total)
    finally:
        source.close()
    report = out.report
    report.untextured["wall"] = plan.untextured_walls
    report.facades = dict(sorted(plan.styles.items()))
    report.facade_images = len(plan.rows)
    feedback.info(f"Generated facades: {plan.buildings} building(s) ("
                  + ", ".join(f"{count} {style}" for style, count in plan.styles.most_common())
                  + f"), {plan.walls} wall(s) on {len(plan.rows)} shared image(s); storeys from the layer's floor "
                  f"count for {plan.buildings - plan.storeys_from_height}, from the height for "
                  f"{plan.storeys_from_height}. Use fields: {source.rule.describe()}.")
    if plan.untextured_walls:
        feedback.warning(f"{plan.untextured_walls} wall face(s) are not quads (as wit:extrudebuildings writes them) "
                         "and are left untextured.")


_FACADE_FIELDS = [FieldDef(name, ogr.OFTInteger if name == step_layers.FACADE_STOREYS else ogr.OFTString)
                  for name in step_layers.FACADE_FIELDS]


def _check_config(config: TextureConfig) -> None:
    if not 0.0 < config.scale <= 1.0:
        raise InputError(f"Texture scale S = {config.scale:g} is out of range: use 0 < S ≤ 1 (1 = ortho resolution).")
    if config.image_format.upper() not in FORMATS:
        raise InputError(f"Image format {config.image_format!r} is not supported: use one of {', '.join(FORMATS)}.")
    if not 1 <= config.jpeg_quality <= 100:
        raise InputError(f"JPEG quality {config.jpeg_quality} is out of range: use 1–100.")
    size = config.atlas_size
    if size < 64 or size > 16384 or size & (size - 1):
        raise InputError(f"Atlas size {size} must be a power of two between 64 and 16384.")
    if config.facades not in FACADE_CHOICES:
        raise InputError(f"Facades {config.facades!r}: use one of {', '.join(FACADE_CHOICES)}.")
    if not 0 <= config.gutter <= size // 8:
        raise InputError(f"Gutter {config.gutter} px is out of range: use 0–{size // 8} px for atlases of {size} px.")


class _Inside:
    """Keeps the surfaces inside the ortho's coverage (all when there is none) and counts the others."""

    def __init__(self, coverage: BaseGeometry | None, untextured: dict[str, int]):
        self.coverage, self.untextured = coverage, untextured
        if coverage is not None:
            shapely.prepare(coverage)

    def __call__(self, rings: _Rings) -> _Rings:
        if self.coverage is None or not len(rings):
            return rings
        keep = shapely.covers(self.coverage, shapely.box(*rings.bboxes().T))
        self.untextured[BEYOND_ORTHO] = self.untextured.get(BEYOND_ORTHO, 0) + int((~keep).sum())
        return rings.take(np.flatnonzero(keep))


def _texture_roofs(layer: _Layer, ortho: _Ortho, grid: _Grid, out: _Output, config: TextureConfig,
                   inside: _Inside, feedback: Feedback) -> None:
    """Roof islands square by square (spatial order), tallest first within a square for tighter shelves."""
    def roof(columns: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        wit_id, face_no = columns
        faces = np.ma.filled(face_no, 0).astype(object)  # as OGR's GetFieldAsInteger: NULL is 0
        return np.full(len(faces), ROOF_TARGET, dtype=object), np.array(bulk_read.texts(wit_id), dtype=object), faces

    packer = _AtlasPacker(config, out)
    limit = config.atlas_size - 2 * config.gutter
    count = len(grid.keys(layer.extent))
    for n, (_, rings) in enumerate(layer.squares(grid, (step_layers.WIT_ID, step_layers.FACE_NUMBER), roof)):
        feedback.check_canceled()
        rings = inside(rings)
        patches = [ortho.patch(rings.bbox(i), limit) for i in range(len(rings))]
        for i, patch in sorted(enumerate(patches), key=lambda ip: -ip[1].pixels.shape[0]):
            packer.add(rings.take(np.array([i])), patch)
            out.report.downscaled += patch.downscaled
        feedback.progress(100.0 * (n + 1) / count)
    packer.flush()


def _texture_ground(layer: _Layer, ortho: _Ortho, grid: _Grid, out: _Output, config: TextureConfig,
                    inside: _Inside, feedback: Feedback) -> None:
    """One image per non-empty ground square, covering its triangles' bounding box plus the gutter."""
    def triangle(columns: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        tri_id, surface, feature_id = columns
        on_road = (np.ma.filled(surface, b"") == b"road") & bulk_read.valid(feature_id)
        features = tri_id if not np.ma.is_masked(tri_id) else np.array(bulk_read.texts(tri_id), dtype=object)
        return (np.array([TIN_TARGET, ROAD_TARGET], dtype=object)[on_road.astype(np.intp)], np.asarray(features),
                np.full(len(on_road), None, dtype=object))

    count = len(grid.keys(layer.extent))
    squares = layer.squares(grid, (step_layers.TIN_TRIANGLE_ID, step_layers.TIN_SURFACE,
                                   step_layers.TIN_FEATURE_ID), triangle)
    for n, ((r, c), batch) in enumerate(squares):
        feedback.check_canceled()
        batch = inside(batch)
        if len(batch):
            bbox = (*batch.xy.min(axis=0), *batch.xy.max(axis=0))
            patch = ortho.patch(bbox, config.atlas_size, margin=config.gutter)
            h, w = patch.pixels.shape[:2]
            placement = np.array([(0, 0, w, h, *patch.extent)], dtype=np.float64)
            out.write(f"ground_r{r:04d}_c{c:04d}", patch.pixels, batch, placement)
            out.report.ground_images += 1
            out.report.downscaled += patch.downscaled
        feedback.progress(100.0 * (n + 1) / count)
