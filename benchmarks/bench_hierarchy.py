"""The tileset of a tiled run at district and city scale: the groups above the tiles (``wit_plugin.tiles3d.combine``).

Measures the time to write the groups and the run's tileset, the bytes of the run's ``tileset.json``
and of the largest tileset file, the groups' levels, contents and errors, then the offline viewer in
headless Chromium from afar (the whole run in view, ``--range`` radii of its bounding sphere): the
bytes and requests of the tileset's files until the first view is loaded, and a screenshot.

    .venv/bin/python benchmarks/bench_hierarchy.py --district    # the run of bench_tiles.py --district --tiles3d
    .venv/bin/python benchmarks/bench_hierarchy.py --generated    # ≥ 1,000 stand-in tiles, see below

``--district``: the output of ``bench_tiles.py --district --tiles3d`` (a real tiled run of the generated
40 km² district, out/bench/tiles/district-run): its groups and tileset are written again (the tiles
are not touched).

``--generated``: a city of ~20 × 20 km west of Suseo (across the 127°E line and 37.5°N: two 1° blocks,
four 1:50,000 sheets) cut into its 1:1,000 sheets, **whose tiles are stand-ins**, not chain runs
(which would take hours here): the generated city (60,000 buildings, ≈ 6.6 km a side) repeated
3 × 3; each tile's tileset is one quad of ground, and its ``lod1.gpkg`` holds its share of the
buildings (ground faces, heights from their floors); the DEM is synthetic (smooth hills, 30 m) and
so are the orthoimage sheets (a 128² pattern per 1:5,000 sheet). The groups above the tiles are
written and measured exactly as in a real run. Data cached in out/bench/hierarchy/.

Results: out/bench/hierarchy-<case>.json and the screenshot beside it; a Markdown table printed.
"""
from __future__ import annotations

import argparse
import json
import math
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out" / "bench"
sys.path.insert(0, str(ROOT))

GENERATED_CENTRE = (127.015, 37.495)  # EPSG:4737 degrees: the copies reach across 127°E and 37.5°N
GENERATED_COPIES = 3  # the generated city (≈ 6.6 km a side) repeated 3 × 3
GENERATED_BUILDINGS = 60_000
CRS = "EPSG:5186"


def generated_run(folder: Path) -> tuple[Path, dict]:
    """The stand-in run (cached): (run folder, its DEM and orthoimage folder)."""
    import numpy as np
    import pyproj
    import shapely
    from osgeo import gdal, ogr, osr

    from wit_plugin.infra import step_layers
    from wit_plugin.infra.io.vector_io import read_layer
    from wit_plugin.infra.mapsheet import sheets_covering
    from wit_plugin.infra.polygons import transform
    from wit_plugin.sample import SampleConfig, generate_sample
    from wit_plugin.sheetrun.plan import owners, plan_tiles
    from wit_plugin.tiles3d.geo import Georeference, column_major
    from wit_plugin.tiles3d.glb import GlbBuilder

    sample, run = folder / "sample", folder / "run"
    if not (sample / "sample_manifest.json").is_file():
        print(f"generating the sample {sample} (not timed)", flush=True)
        shutil.rmtree(sample, ignore_errors=True)
        generate_sample(sample, SampleConfig(center_lon=GENERATED_CENTRE[0], center_lat=GENERATED_CENTRE[1],
                                             radius_m=3300.0, n_buildings=GENERATED_BUILDINGS, seed=5,
                                             with_ortho=False, with_dem=False))
    files = json.loads((sample / "sample_manifest.json").read_text(encoding="utf-8"))["files"]
    inputs = {"dem": str(folder / "dem.tif"), "ortho": str(folder / "ortho")}
    if (run / "tiles.json").is_file():
        return run, inputs
    print(f"writing the stand-in tiles in {run} (not timed)", flush=True)
    shutil.rmtree(run, ignore_errors=True)
    buildings = read_layer(str(sample / files["buildings"]))
    single = shapely.make_valid(transform(buildings.geoms, buildings.crs, pyproj.CRS(CRS)))
    single = np.array([max(shapely.get_parts(g), key=lambda p: p.area) for g in single], dtype=object)
    xmin, ymin, xmax, ymax = shapely.total_bounds(single)
    width, height = xmax - xmin + 50.0, ymax - ymin + 50.0
    half = GENERATED_COPIES // 2
    copies = [(i * width, j * height) for i in range(-half, GENERATED_COPIES - half)
              for j in range(-half, GENERATED_COPIES - half)]
    footprints = np.concatenate([shapely.transform(single, lambda xy, d=d: xy + d) for d in copies])
    floors = np.tile(np.array([int(v) if v else 0 for v in buildings.columns["GRO_FLO_CO"]]), len(copies))
    names = np.tile(np.array([v or "" for v in buildings.columns["BULD_NM"]], dtype=object), len(copies))
    area = shapely.box(*shapely.total_bounds(footprints))
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    # a DEM of smooth hills (30 m), and one orthoimage sheet per 1:5,000 sheet (a pattern of its own)
    ax0, ay0, ax1, ay1 = area.buffer(500).bounds
    cols, rows = int((ax1 - ax0) / 30) + 1, int((ay1 - ay0) / 30) + 1
    x = ax0 + 30 * np.arange(cols)
    y = ay1 - 30 * np.arange(rows)
    hills = 40 + 25 * np.sin(x[None, :] / 1700.0) * np.cos(y[:, None] / 2300.0)
    dem = gdal.GetDriverByName("GTiff").Create(inputs["dem"], cols, rows, 1, gdal.GDT_Float32)
    dem.SetGeoTransform((ax0, 30.0, 0.0, ay1, 0.0, -30.0))
    dem.SetProjection(srs.ExportToWkt())
    dem.GetRasterBand(1).WriteArray(hills.astype(np.float32))
    dem = None
    to_degrees = pyproj.Transformer.from_crs(CRS, "EPSG:4737", always_xy=True)
    lon, lat = to_degrees.transform([ax0, ax1, ax1, ax0], [ay0, ay0, ay1, ay1])
    ortho = Path(inputs["ortho"])
    ortho.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(1)
    for sheet in sheets_covering(min(lon), min(lat), max(lon), max(lat), 5000):
        base = rng.integers(60, 200, 3)
        pixels = np.clip(base[:, None, None] + rng.normal(0, 25, (3, 128, 128)), 0, 255).astype(np.uint8)
        pixels[:, ::16, :] = pixels[:, :, ::16] = 90  # a street grid
        image = gdal.GetDriverByName("GTiff").Create(str(ortho / f"(B060)정사영상_2022_{sheet.number}.tif"), 128, 128,
                                                    3, gdal.GDT_Byte)
        for band in range(3):
            image.GetRasterBand(band + 1).WriteArray(pixels[band])
        image = None
    tiles = plan_tiles(area, CRS, 1000)
    owner = np.array(owners(shapely.get_coordinates(shapely.point_on_surface(footprints)), CRS, 1000), dtype=object)
    georef = Georeference(CRS)
    centres = shapely.get_coordinates(shapely.centroid(footprints))
    base = 40 + 25 * np.sin(centres[:, 0] / 1700.0) * np.cos(centres[:, 1] / 2300.0)
    order = np.argsort(owner)
    starts = np.searchsorted(owner[order], [t.sheet for t in tiles], side="left")
    ends = np.searchsorted(owner[order], [t.sheet for t in tiles], side="right")
    for number, tile in enumerate(tiles):
        folder3d = run / "tiles" / tile.sheet / "3dtiles"
        (folder3d / "tiles").mkdir(parents=True)
        bx0, by0, bx1, by1 = tile.polygon.bounds
        corners = np.array([[bx0, by0], [bx1, by0], [bx1, by1], [bx0, by1]])
        xyz = np.column_stack([corners, 40 + 25 * np.sin(corners[:, 0] / 1700.0) * np.cos(corners[:, 1] / 2300.0)])
        frame = georef.frame((bx0 + bx1) / 2, (by0 + by1) / 2, float(xyz[:, 2].mean()))
        glb = GlbBuilder()
        glb.triangles(georef.local(frame, xyz[[0, 1, 2, 0, 2, 3]]).reshape(2, 3, 3),
                      glb.plain_material((150, 150, 140), lit=False, name="ground"))
        (folder3d / "tiles" / "0_0.glb").write_bytes(glb.to_bytes())
        root = {"boundingVolume": {"region": georef.region(xyz)}, "geometricError": 16.0, "refine": "REPLACE",
                "transform": column_major(frame), "content": {"uri": "tiles/0_0.glb"}}
        (folder3d / "tileset.json").write_text(json.dumps({"asset": {"version": "1.1"}, "geometricError": 32.0,
                                                           "root": root}), encoding="utf-8")
        mine = order[starts[number]:ends[number]]
        if not len(mine):
            continue
        ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(run / "tiles" / tile.sheet / "lod1.gpkg"))
        layer = ds.CreateLayer(step_layers.LOD1_LAYER, srs, ogr.wkbPolygon)
        for name, kind in ((step_layers.WIT_ID, ogr.OFTString), (step_layers.FACE_TYPE, ogr.OFTString),
                           (step_layers.FACE_NUMBER, ogr.OFTInteger), (step_layers.BASE_Z, ogr.OFTReal),
                           (step_layers.HEIGHT, ogr.OFTReal), (step_layers.STOREYS_ABOVE, ogr.OFTInteger),
                           ("BULD_NM", ogr.OFTString)):
            layer.CreateField(ogr.FieldDefn(name, kind))
        ds.StartTransaction()
        for i in mine.tolist():
            feature = ogr.Feature(layer.GetLayerDefn())
            feature.SetField(step_layers.WIT_ID, f"BLD_{i}")
            feature.SetField(step_layers.FACE_TYPE, "ground")
            feature.SetField(step_layers.FACE_NUMBER, 0)
            feature.SetField(step_layers.BASE_Z, float(base[i]))
            feature.SetField(step_layers.HEIGHT, 3.0 * floors[i] if floors[i] else 3.0)
            if floors[i]:
                feature.SetField(step_layers.STOREYS_ABOVE, int(floors[i]))
            if names[i]:
                feature.SetField("BULD_NM", names[i])
            feature.SetGeometry(ogr.CreateGeometryFromWkb(shapely.to_wkb(footprints[i])))
            layer.CreateFeature(feature)
        ds.CommitTransaction()
        ds = None
        if number % 200 == 0:
            print(f"  {number}/{len(tiles)} tiles", flush=True)
    (run / "tiles.json").write_text(json.dumps({t.sheet: shapely.to_wkt(t.polygon.intersection(area))
                                                for t in tiles}), encoding="utf-8")
    return run, inputs


def write(run: Path, areas: dict, dem: str, ortho: str) -> tuple[dict, float]:
    from wit_plugin.mosaic.georef import list_tifs
    from wit_plugin.tiles3d.combine import write_run_tileset

    start = time.perf_counter()
    written = write_run_tileset(run, {sheet: f"tiles/{sheet}" for sheet in areas}, areas, dem, list_tifs(ortho),
                                "EPSG:5186")
    return written, time.perf_counter() - start


def browse(run: Path, scratch: Path, view_range: float) -> dict:
    viewer = scratch / "viewer"
    subprocess.run([sys.executable, str(ROOT / "scripts" / "viewer.py"), "build", str(run), str(viewer)], check=True,
                   capture_output=True)
    server = subprocess.Popen([sys.executable, str(ROOT / "scripts" / "viewer.py"), "serve", str(viewer),
                               "--port", "0"], stdout=subprocess.PIPE, text=True)
    try:
        url = server.stdout.readline().strip() + f"?range={view_range}"
        result = subprocess.run(["node", str(ROOT / "viewer" / "browse.mjs"), url, str(scratch / "view.png"),
                                 "--timeout", "900"], capture_output=True, text=True)
    finally:
        server.terminate()
        server.wait(timeout=10)
    shutil.rmtree(viewer, ignore_errors=True)
    return json.loads(result.stdout)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    case = parser.add_mutually_exclusive_group(required=True)
    case.add_argument("--district", action="store_true")
    case.add_argument("--generated", action="store_true")
    parser.add_argument("--range", type=float, default=2.0, help="the first view's distance, in radii of the "
                        "run's bounding sphere (default 2: the whole run in view, from afar)")
    args = parser.parse_args()

    import shapely

    from wit_plugin.sheetrun.index import read_index
    from wit_plugin.sheetrun.layers import area_of_layer
    from wit_plugin.sheetrun.plan import tile_of
    from wit_plugin.tiles3d.check import check_tileset
    from wit_plugin.tiles3d.combine import tile_areas

    if args.district:
        name, run = "district", OUT / "tiles" / "district-run"
        sample = OUT / "tiles" / "district"
        if not (run / "tileset.json").is_file():
            sys.exit(f"{run} holds no tileset: run `benchmarks/bench_tiles.py --district --tiles3d` first.")
        files = json.loads((sample / "sample_manifest.json").read_text(encoding="utf-8"))["files"]
        dem, ortho = str(sample / files["dem"]), str(sample / "ortho")
        rows = read_index(run)  # the run's area is everything the buildings layer covers, as the runner takes it
        covered = area_of_layer(str(sample / files["buildings"]), "EPSG:5186")
        areas = tile_areas({s: tile_of(s, "EPSG:5186").polygon for s, r in rows.items()
                            if r.get("status") in ("done", "empty")}, covered)
    else:
        name = "generated"
        run, inputs = generated_run(OUT / "hierarchy")
        dem, ortho = inputs["dem"], inputs["ortho"]
        areas = {s: shapely.from_wkt(w) for s, w in json.loads((run / "tiles.json").read_text()).items()}
    written, seconds = write(run, areas, dem, ortho)
    check = check_tileset(run)
    scratch = OUT / "hierarchy" / f"view-{name}"
    scratch.mkdir(parents=True, exist_ok=True)
    view = browse(run, scratch, args.range)
    shot = OUT / f"hierarchy-{name}.png"
    if (scratch / "view.png").is_file():
        shutil.copy(scratch / "view.png", shot)
    errors = sorted(written.errors.values())
    result = {"case": name, "tiles": written.tiles, "groups": written.groups, "levels": written.levels,
              "seconds": round(seconds, 1), "root_bytes": written.root_bytes,
              "largest_tileset_file_bytes": written.largest_file_bytes,
              "tileset_files": len(check.tilesets), "tileset_files_bytes": sum(check.tilesets.values()),
              "group_bytes": written.group_bytes, "group_buildings": written.buildings,
              "groups_without_terrain": written.without_terrain,
              "group_errors_m": [errors[0], errors[len(errors) // 2], errors[-1]] if errors else [],
              "check_problems": check.problems[:10], "range": args.range,
              "viewer": {k: view.get(k) for k in ("loaded", "error", "navigationSeconds", "loadSeconds", "loadedTiles",
                                                  "firstViewBytes", "firstViewRequests", "consoleErrors",
                                                  "pageErrors", "httpErrors")},
              "screenshot": str(shot)}
    (OUT / f"hierarchy-{name}.json").write_text(json.dumps(result, indent=1), encoding="utf-8")
    print(json.dumps(result, indent=1))
    v = result["viewer"]
    print(f"\n| run | tiles | groups (levels) | write s | tileset.json | largest tileset file | group contents | "
          f"first view (range {args.range:g}): bytes, requests, s |\n|---|---:|---:|---:|---:|---:|---:|---|\n"
          f"| {name} | {written.tiles:,} | {written.groups} ({written.levels}) | {seconds:.1f} | "
          f"{written.root_bytes / 1e3:.1f} kB | {written.largest_file_bytes / 1e3:.1f} kB | "
          f"{written.group_bytes / 1e6:.1f} MB, {written.buildings:,} buildings | "
          f"{(v['firstViewBytes'] or 0) / 1e6:.2f} MB, {v['firstViewRequests']}, {v['navigationSeconds']} s |")
    print(f"checker: {len(check.problems)} problem(s); group errors {math.floor(errors[0]) if errors else '-'}–"
          f"{math.ceil(errors[-1]) if errors else '-'} m")
    return 0 if v["loaded"] and not check.problems else 1


if __name__ == "__main__":
    sys.exit(main())
