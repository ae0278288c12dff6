"""Tiled runs (wit:citymodeltiles' core) on generated data of 1, 4 and 16 tiles of the 1:1,000 sheet grid,
with 1 and 2 Dask workers: wall time, buildings per second, peak memory per worker, and the
single-process chain on the same 1-tile area beside it (the reference measured in the same run).

    .venv/bin/python benchmarks/bench_tiles.py [--tiles 1 4 16] [--workers 1 2] [--max-edge 5] [--tiles3d]
    .venv/bin/python benchmarks/bench_tiles.py --district     # one run over a generated 40 km² district
    .venv/bin/python benchmarks/bench_tiles.py --district --update [--footprints]   # then update that run

``--update`` (after a ``--district`` run with the same ``--tiles3d``): the run updated in place — first back to
the original inputs (not timed: an earlier ``--update`` edited it), then the same run again (nothing changed:
every tile kept), then with the buildings of one 1:5,000 sheet edited (every one whose point on surface lies
in the district's fullest 1:5,000 sheet gets one more storey; ``--footprints``: and a footprint 10 cm
smaller), then those of one 1:1,000 sheet: wall time, the fingerprints' seconds, tiles kept and rebuilt,
beside the full run's time.

Data: the generated sample around Suseo (cached in out/bench/tiles/sample); the areas are blocks of
whole 1:1,000 sheets (1×1, 2×2, 4×4) so every tile is full. Results: a table, and
out/bench/tiles/results.json. Goals: 16 tiles ≤ 17 × one tile; 2 workers ≥ 1.8 × faster
than 1; peak memory per worker flat (≤ 1.5 GB) whatever the area.
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out" / "bench" / "tiles"
sys.path.insert(0, str(ROOT))


def blocks(n: int) -> list[str]:
    """n sheets forming a square block (n = 1, 4, 16) of 1:1,000 sheets around Suseo station."""
    import pyproj

    from wit_plugin.infra.mapsheet import sheet_at

    side = int(round(n ** 0.5))
    west, south = 127.0975, 37.4775  # south-west of the station: the 4 × 4 block lies inside the sample's DEM
    cell = 0.005
    to_4737 = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:4737", always_xy=True)  # (the datums agree here)
    numbers = []
    for row in range(side):
        for col in range(side):
            lon, lat = to_4737.transform(west + (col + 0.5) * cell, south + (row + 0.5) * cell)
            numbers.append(sheet_at(lon, lat, 1000).number)
    return numbers


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tiles", type=int, nargs="+", default=[1, 4, 16])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--max-edge", type=float, default=5.0)
    parser.add_argument("--district", action="store_true", help="instead: one run over a generated district "
                        "of Gangnam-gu's size (40 km², all its buildings) on the largest --workers")
    parser.add_argument("--tiles3d", action="store_true", help="each tile also writes its 3D Tiles (as the "
                        "algorithm does by default); off: the CityGML chain alone")
    parser.add_argument("--update", action="store_true", help="with --district: then update the run (nothing "
                        "changed; one 1:5,000 sheet's buildings edited; one 1:1,000 sheet's)")
    parser.add_argument("--footprints", action="store_true", help="with --update: the edited buildings' footprints "
                        "change too (not only their storeys)")
    args = parser.parse_args()

    import shapely

    from wit_plugin.chain import ChainInputs, ChainOptions, run_city_model
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.sample import SampleConfig, generate_sample
    from wit_plugin.sheetrun.plan import tile_of
    from wit_plugin.sheetrun.runner import run_tiles
    from wit_plugin.sheetrun.worker import peak_mb

    def sample(name: str, config: SampleConfig) -> ChainInputs:
        folder = OUT / name
        if not (folder / "sample_manifest.json").is_file():
            print(f"generating the sample {folder} (not timed)", flush=True)
            shutil.rmtree(folder, ignore_errors=True)
            generate_sample(folder, config)
        files = json.loads((folder / "sample_manifest.json").read_text(encoding="utf-8"))["files"]
        return ChainInputs([str(folder / "ortho")], str(folder / files["dem"]), str(folder / files["buildings"]),
                           str(folder / files["roads"]), str(folder / files["districts"]))

    options = ChainOptions(area=None, max_edge=args.max_edge, metrics=False, tiles3d=args.tiles3d)
    if args.district:  # a square of 6.32 km a side: Gangnam-gu's 40 km², at the generator's building density
        inputs = sample("district", SampleConfig(radius_m=3162.0, seed=7, ortho_pixel_size=1.0))
        workers = max(args.workers)
        if args.update:
            result = json.loads((OUT / "district.json").read_text(encoding="utf-8"))
            if result.get("tiles3d") != args.tiles3d:
                sys.exit("Run --district first with the same --tiles3d: --update updates that run.")
            result["updates"] = updates(inputs, options, OUT / "district-run", workers, args.footprints,
                                        result["seconds"])
            (OUT / "district.json").write_text(json.dumps(result, indent=1), encoding="utf-8")
            return 0
        shutil.rmtree(OUT / "district-run", ignore_errors=True)  # a fresh run, not a resumed one
        start = time.perf_counter()
        report = run_tiles(inputs, options, OUT / "district-run", None, scale=1000, workers=workers)
        seconds = time.perf_counter() - start
        done = [r for r in report.rows if r["status"] in ("done", "empty")]
        result = {"workers": workers, "tiles3d": args.tiles3d, "seconds": round(seconds, 1), "tiles": len(report.rows),
                  "modelled": len(done),
                  "failed": report.count("failed"), "buildings": report.buildings,
                  "triangles": sum(r["triangles"] for r in done),
                  "peak_mb_per_worker": max((r["peak_mb"] for r in done), default=0)}
        print(json.dumps(result), flush=True)
        print("\n| district (40 km²) | workers | wall | tiles (failed) | buildings | TIN triangles | "
              "peak MB/worker |\n"
              f"|---|---:|---:|---:|---:|---:|---:|\n| generated, 1:1,000 sheets | {workers} | "
              f"{seconds / 60:.1f} min | {result['tiles']} ({result['failed']}) | {result['buildings']:,} | "
              f"{result['triangles']:,} | {result['peak_mb_per_worker']:.0f} |\n(goal: a Gangnam-size area in "
              "≤ 10 minutes)")
        (OUT / "district.json").write_text(json.dumps(result, indent=1), encoding="utf-8")
        return 0
    inputs = sample("sample", SampleConfig(radius_m=1400.0, seed=42, ortho_pixel_size=0.5))
    rows = []
    one_tile = shapely.union_all([tile_of(s, "EPSG:5186").polygon for s in blocks(1)])
    start = time.perf_counter()
    single = run_city_model(inputs, ChainOptions(area=StudyArea.polygon(one_tile, "EPSG:5186"),
                                                 max_edge=args.max_edge, metrics=False, tiles3d=args.tiles3d),
                            OUT / "single", )
    reference = {"seconds": round(time.perf_counter() - start, 2), "buildings": single.buildings,
                 "peak_mb": round(peak_mb(), 0)}
    print(f"reference: the chain in this process on the 1-tile area: {reference}", flush=True)
    for n in args.tiles:
        area = shapely.union_all([tile_of(s, "EPSG:5186").polygon for s in blocks(n)]).buffer(-0.01)
        for workers in args.workers:
            out = OUT / f"t{n}-w{workers}"
            shutil.rmtree(out, ignore_errors=True)
            start = time.perf_counter()
            report = run_tiles(inputs, options, out, StudyArea.polygon(area, "EPSG:5186"), scale=1000, workers=workers)
            seconds = time.perf_counter() - start
            done = [r for r in report.rows if r["status"] == "done"]
            row = {"tiles": n, "workers": workers, "seconds": round(seconds, 1), "done": len(done),
                   "km2": round(area.area / 1e6, 3),
                   "buildings": report.buildings, "buildings_per_s": round(report.buildings / seconds, 1),
                   "triangles": sum(r["triangles"] for r in done),
                   "tile_seconds_mean": round(sum(r["seconds"] for r in done) / max(len(done), 1), 1),
                   "peak_mb_per_worker": max((r["peak_mb"] for r in done), default=0)}
            rows.append(row)
            print(json.dumps(row), flush=True)
    by = {(r["tiles"], r["workers"]): r for r in rows}
    print("\n| tiles | workers | wall s | buildings | buildings/s | triangles | s per tile (mean) | peak MB/worker |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['tiles']} | {r['workers']} | {r['seconds']} | {r['buildings']} | {r['buildings_per_s']} | "
              f"{r['triangles']:,} | {r['tile_seconds_mean']} | {r['peak_mb_per_worker']:.0f} |")
    print(f"\nreference (one process, 1-tile area): {reference['seconds']} s, {reference['buildings']} buildings")
    if (1, 1) in by and (16, 1) in by:
        print(f"16 tiles / 1 tile (1 worker): {by[(16, 1)]['seconds'] / by[(1, 1)]['seconds']:.1f} (goal ≤ 17)")
    for n in args.tiles:
        if (n, 1) in by and (n, 2) in by:
            print(f"{n} tiles: 2 workers {by[(n, 1)]['seconds'] / by[(n, 2)]['seconds']:.2f}× faster than 1 "
                  "(goal ≥ 1.8)")
    largest = max(args.tiles)
    for workers in args.workers:
        if (largest, workers) in by:
            run = by[(largest, workers)]
            per_km2, per_building = run["seconds"] / run["km2"], run["seconds"] / max(run["buildings"], 1)
            print(f"extrapolated from {largest} tiles on {workers} worker(s) ({per_km2:.0f} s/km², "
                  f"{1000 * per_building:.0f} ms/building): Gangnam-gu (40 km², ~24k buildings) "
                  f"{40 * per_km2 / 60:.0f}–{24_000 * per_building / 60:.0f} min; Seoul (605 km², ~600k buildings) "
                  f"{605 * per_km2 / 3600:.1f}–{600_000 * per_building / 3600:.1f} h, "
                  f"÷ N/{workers} on N workers")
    (OUT / "results.json").write_text(json.dumps({"reference": reference, "runs": rows}, indent=1), encoding="utf-8")
    return 0


def edit_sheet(buildings: str, scale: int, folder: Path, footprints: bool, skip: set[str]) -> tuple[str, str, int]:
    """A copy of ``buildings`` in ``folder`` where every building whose point on surface lies in the fullest
    sheet of ``scale`` inside the layer's extent (and not in ``skip``) has one more storey (and, with
    ``footprints``, a footprint 10 cm smaller): (the copy, the sheet, buildings edited)."""
    import pyproj
    import shapely
    from osgeo import gdal, ogr

    from wit_plugin.infra.io.vector_io import read_layer
    from wit_plugin.infra.polygons import repair_polygons, transform
    from wit_plugin.sheetrun.layers import area_of_layer
    from wit_plugin.sheetrun.plan import owners, plan_tiles

    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    source = Path(buildings)
    for part in source.parent.glob(source.stem + ".*"):
        shutil.copy(part, folder / part.name)
    copy = folder / source.name
    extent = area_of_layer(str(copy), "EPSG:5186")
    inside = {t.sheet for t in plan_tiles(extent, "EPSG:5186", scale) if extent.contains(t.polygon)} - skip
    buildings = read_layer(copy)  # the point on surface as a tile finds it: reprojected, then repaired
    here = repair_polygons(transform(buildings.geoms, buildings.crs, pyproj.CRS("EPSG:5186")),
                           buildings.unclosed_rings).geoms
    placed = ~shapely.is_missing(here)
    fids, geometries = buildings.fids[placed], buildings.geoms[placed]
    sheets = owners(shapely.get_coordinates(shapely.point_on_surface(here[placed])), "EPSG:5186", scale)
    sheet = max(inside, key=sheets.count)
    edited = 0
    ds = gdal.OpenEx(str(copy), gdal.OF_VECTOR | gdal.OF_UPDATE, open_options=["ENCODING="])
    layer = ds.GetLayer(0)
    ds.StartTransaction()
    for fid, geometry, owner in zip(fids.tolist(), geometries, sheets):
        if owner == sheet:
            feature = layer.GetFeature(fid)
            feature.SetField("GRO_FLO_CO", (feature.GetField("GRO_FLO_CO") or 0) + 1)
            if footprints:
                smaller = shapely.make_valid(geometry).buffer(-0.1, join_style="mitre")
                if smaller.area > 0:
                    feature.SetGeometry(ogr.CreateGeometryFromWkb(shapely.to_wkb(smaller)))
            layer.SetFeature(feature)
            edited += 1
    ds.CommitTransaction()
    ds = layer = None
    return str(copy), sheet, edited


def updates(inputs, options, output: Path, workers: int, footprints: bool, full: float) -> list[dict]:
    """The district's run updated: nothing changed, then one 1:5,000 sheet's buildings edited, then one 1:1,000
    sheet's (another one): wall time beside the full run's."""
    from dataclasses import replace

    from wit_plugin.infra.feedback import Feedback
    from wit_plugin.sheetrun.runner import run_tiles

    class Log(Feedback):
        """Keeps the run's messages with their time: the fingerprints' seconds are one of them, and the groups
        above the tiles are refreshed from the message that says so to the end."""

        def __init__(self):
            self.lines: list[tuple[float, str]] = []

        def info(self, message: str) -> None:
            self.lines.append((time.perf_counter(), message))

        def fingerprint_seconds(self) -> float:
            line = next(m for _, m in self.lines if m.startswith("Fingerprints of the "))
            return float(line.rsplit(": ", 1)[1].split(" ")[0])

        def groups_seconds(self) -> float:
            start = next(t for t, m in self.lines if m.startswith("3D Tiles: the groups above"))
            end = next(t for t, m in self.lines if m.startswith("Tiles: "))
            return round(end - start, 1)

    print("back to the original inputs (not timed)", flush=True)
    run_tiles(inputs, options, output, None, scale=1000, workers=workers)
    rows, edited = [], set()
    cases = [("nothing changed", None), ("one 1:5,000 sheet's buildings edited", 5000),
             ("one 1:1,000 sheet's buildings edited", 1000)]
    for label, scale in cases:
        row = {"case": label}
        if scale:
            buildings, row["sheet"], row["buildings_edited"] = edit_sheet(
                inputs.buildings, scale, OUT / f"district-edit-{scale}", footprints, edited)
            inputs = replace(inputs, buildings=buildings)
            edited.add(row["sheet"])
        log = Log()
        start = time.perf_counter()
        report = run_tiles(inputs, options, output, None, scale=1000, workers=workers, feedback=log)
        row.update(seconds=round(time.perf_counter() - start, 1), fingerprints_seconds=log.fingerprint_seconds(),
                   groups_seconds=log.groups_seconds() if options.tiles3d else 0.0,
                   share_of_full=round((time.perf_counter() - start) / full, 3), kept=len(report.update.kept),
                   rebuilt=len(report.update.rebuilt), reasons=report.reasons(), added=len(report.update.added),
                   removed=len(report.update.removed))
        rows.append(row)
        print(json.dumps(row), flush=True)
    print(f"\n| update of the district (full run {full / 60:.1f} min) | wall s | share of the full run | "
          "fingerprints s | groups s | tiles kept | rebuilt |\n|---|---:|---:|---:|---:|---:|---:|")
    for row in rows:
        print(f"| {row['case']}{' (' + str(row['buildings_edited']) + ' buildings)' if 'sheet' in row else ''} | "
              f"{row['seconds']} | {row['share_of_full']:.1%} | {row['fingerprints_seconds']} | "
              f"{row['groups_seconds']} | {row['kept']} | {row['rebuilt']} |")
    return rows


if __name__ == "__main__":
    sys.exit(main())
