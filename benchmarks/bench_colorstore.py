"""Benchmark the colour store against raster reads, like the paper's Tables 14–16 (Kang et al. 2025, §4.1).

Data: the project's sample generator (radius 300 m, 0.5 m ortho: two 1:5,000 sheets), the tiles
georeferenced and merged (wit:georeference, wit:mergerasters), then a centred ``--size`` px square
cut out as a tiled (512 px) DEFLATE GeoTIFF; ``--size 2048`` (default) is 12.6 MB of RGB, the
size of the paper's image (Table 14: 12 MB). Cached under out/bench/colorstore_data.

Methods, each timed and measured in its own child process (three runs with different random
points; mean ± std over the runs):

* (a) ``raster-full``: the paper's raster baseline, per query ``gdal.Open`` + ``ReadAsArray`` of
  the whole image, then indexing (nearest pixel / slice);
* (b) ``raster-window``: the tiled GeoTIFF kept open, per query a windowed ``ReadAsArray`` of just
  the pixels needed (GDAL's block cache at its default);
* (c) ``store-gpkg`` and ``store-postgis``: ``ColorStore`` (opened once) ``query_point`` /
  ``query_patch``.

Point queries: ``--points`` random points (p50 / p95 ms); (a) does ``--full-queries`` of them.
Patch queries: 64 × 64 m at 0.5 m (128 × 128 texels) at random places. Peak memory is each child's
peak RSS as GNU time reports it, minus that of a child that only does the same imports. Not
``getrusage`` here: ``RUSAGE_CHILDREN`` is the maximum over all children so far, and Linux charges
a child (even its ``RUSAGE_SELF``) the RSS of this process at fork/exec time, hundreds of MB after
the builds; GNU time forks the child from its own small process.

Usage: ``python benchmarks/bench_colorstore.py [out.json] [--size 2048] [--tolerance 12]
[--metric rms] [--dsn postgresql://…]`` (default DSN: scripts/postgis.sh's output).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "out" / "bench" / "colorstore_data"
PATCH_M, PATCH_RES = 64.0, 0.5
RUNS = 3
PAPER = {"raster_query_s": "2.73 ± 0.51", "vector_query_s": "0.22 ± 0.01",
         "raster_memory": "1.53 ± 0.25 GB", "vector_memory": "44.3 ± 6.0 MB",
         "raster_file_mb": 12, "vector_store_mb": 52}


def _imports() -> None:
    """What every child imports, so that the baseline child measures the same interpreter state."""
    global np, gdal, colorstore
    sys.path.insert(0, str(ROOT))
    import numpy as np
    import psycopg2  # noqa: F401
    from osgeo import gdal

    from wit_plugin import colorstore
    gdal.UseExceptions()


def make_ortho(size: int) -> Path:
    """The cropped bench ortho (cached): sample → georeference → merge → centred square."""
    from osgeo import gdal

    sys.path.insert(0, str(ROOT))
    from wit_plugin.mosaic import merge_rasters
    from wit_plugin.mosaic.georef import georeference_sheets
    from wit_plugin.sample import SampleConfig, generate_sample

    merged = DATA / "ortho.tif"
    if not merged.exists():
        sample = generate_sample(DATA / "sample", SampleConfig(radius_m=300, ortho_pixel_size=0.5, with_dem=False))
        sheets = georeference_sheets([str(p) for p in sample.ortho_tiles], DATA / "georef")
        merge_rasters([r.output for r in sheets], str(merged))
    crop = DATA / f"ortho_{size}.tif"
    if not crop.exists():
        ds = gdal.Open(str(merged))
        w, h = ds.RasterXSize, ds.RasterYSize
        if size > min(w, h):
            raise SystemExit(f"--size {size} exceeds the merged ortho ({w} × {h})")
        gdal.Translate(str(crop), ds, srcWin=[(w - size) // 2, (h - size) // 2, size, size],
                       creationOptions=["TILED=YES", "BLOCKXSIZE=512", "BLOCKYSIZE=512", "COMPRESS=DEFLATE",
                                        "PREDICTOR=2", "PHOTOMETRIC=RGB"])
    return crop


def _queries(ortho: str, kind: str, n: int, seed: int) -> list[tuple[float, ...]]:
    """Random point (x, y) or patch-box (xmin, ymin, xmax, ymax) queries inside the ortho."""
    ds = gdal.Open(ortho)
    x0, px, _, y0, _, py = ds.GetGeoTransform()
    w, h = ds.RasterXSize * px, ds.RasterYSize * -py
    rng = np.random.default_rng(seed)
    if kind == "point":
        return [(x0 + a, y0 - b) for a, b in zip(rng.uniform(0, w, n), rng.uniform(0, h, n))]
    corner = np.floor(np.column_stack([rng.uniform(0, w - PATCH_M, n), rng.uniform(PATCH_M, h, n)]))
    return [(x0 + a, y0 - b, x0 + a + PATCH_M, y0 - b + PATCH_M) for a, b in corner]


def _child(method: str, ortho: str, store: str, table: str, kind: str, n: int, seed: int) -> None:
    """Child-process entry: run ``n`` queries of one method; print the timings."""
    _imports()
    queries = _queries(ortho, kind, n, seed) if method != "baseline" else []
    start = time.perf_counter()
    if method == "raster-window":
        ds = gdal.Open(ortho)
        x0, px, _, y0, _, py = ds.GetGeoTransform()
    elif method.startswith("store"):
        handle = colorstore.ColorStore.open(store, table)
    open_s = time.perf_counter() - start
    times = []
    for q in queries:
        t = time.perf_counter()
        if method == "raster-full":
            full = gdal.Open(ortho)
            x0, px, _, y0, _, py = full.GetGeoTransform()
            pixels = full.ReadAsArray()
            c, r = int((q[0] - x0) / px), int((q[-1] - y0) / py)
            if kind == "point":
                result = pixels[:, r, c]
            else:
                size = round(PATCH_M / px)
                result = pixels[:, r:r + size, c:c + size]
            del full
        elif method == "raster-window":
            c, r = int((q[0] - x0) / px), int((q[-1] - y0) / py)
            size = 1 if kind == "point" else round(PATCH_M / px)
            out = 1 if kind == "point" else round(PATCH_M / PATCH_RES)
            result = ds.ReadAsArray(c, r, size, size, buf_xsize=out, buf_ysize=out)
        elif kind == "point":
            result = handle.query_point(*q)
        else:
            result = handle.query_patch(q, PATCH_RES)
        times.append(time.perf_counter() - t)
        assert result is not None
    print(json.dumps({"open_s": open_s, "times": times}))


def _run_child(*args: object) -> dict:
    """Run one child under GNU time; its timings plus its peak RSS in MB."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as rss:
        out = subprocess.run(["/usr/bin/time", "-f", "%M", "-o", rss.name, sys.executable, __file__, "--child",
                              *map(str, args)], check=True, capture_output=True, text=True).stdout
        result = json.loads(out.strip().splitlines()[-1])
        result["rss_mb"] = int(rss.read().split()[-1]) / 1024
    return result


def _stats(values: list[float]) -> dict:
    return {"mean": statistics.mean(values), "std": statistics.stdev(values) if len(values) > 1 else 0.0,
            "runs": values}


def _pct(times: list[float], q: float) -> float:
    import numpy as np

    return float(np.percentile(np.array(times) * 1e3, q))


def _fmt(s: dict, digits: int = 2) -> str:
    return f"{s['mean']:.{digits}f} ± {s['std']:.{digits}f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="?", default=str(ROOT / "out" / "bench" / "colorstore.json"))
    parser.add_argument("--size", type=int, default=2048, help="side of the bench ortho in pixels")
    parser.add_argument("--tolerance", type=float, default=12.0)
    parser.add_argument("--metric", default="rms", choices=("rms", "max"))
    parser.add_argument("--points", type=int, default=1000, help="point queries per run (b, c)")
    parser.add_argument("--patches", type=int, default=200, help="patch queries per run (b, c)")
    parser.add_argument("--full-queries", type=int, default=20, help="queries per run for (a)")
    parser.add_argument("--dsn", help="PostGIS DSN (default: start the local one with scripts/postgis.sh)")
    args = parser.parse_args()
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")
    _imports()
    ortho = make_ortho(args.size)
    dsn = args.dsn or subprocess.run(["bash", str(ROOT / "scripts" / "postgis.sh")], check=True,
                                     capture_output=True, text=True).stdout.strip()
    tag = f"{args.size}_{args.metric}{args.tolerance:g}"
    gpkg = DATA / f"store_{tag}.gpkg"
    table = f"wit_bench.cells_{tag.replace('.', '_')}"
    builds = {}
    if not gpkg.exists():
        t = time.perf_counter()
        colorstore.build_color_store(ortho, gpkg, args.tolerance, metric=args.metric)
        builds["gpkg_s"] = time.perf_counter() - t
    with colorstore.ColorStore.open(gpkg) as s:
        meta = s.meta
    import psycopg2

    with psycopg2.connect(dsn) as conn, conn.cursor() as cur:
        cur.execute("CREATE SCHEMA IF NOT EXISTS wit_bench")
    t = time.perf_counter()
    pg_report = colorstore.build_color_store(ortho, None, args.tolerance, metric=args.metric,
                                             postgis_dsn=dsn, table=table)
    builds["postgis_s"] = time.perf_counter() - t
    src = gdal.Open(str(ortho))
    sizes = {"image_raw_bytes": src.RasterXSize * src.RasterYSize * 3, "image_file_bytes": ortho.stat().st_size,
             "gpkg_bytes": gpkg.stat().st_size, "postgis_bytes": pg_report.store_bytes, "cells": meta["cells"],
             "levels": meta["levels"], "max_error": meta["max_error"], "mean_error": meta["mean_error"]}
    print(f"ortho {ortho.name}: {src.RasterXSize} × {src.RasterYSize} px; {meta['cells']} cells "
          f"({args.metric} ≤ {args.tolerance:g}, mean error {meta['mean_error']:.2f}); builds {builds}", flush=True)

    base = statistics.mean(_run_child("baseline", ortho, "", "", "point", 0, 0)["rss_mb"] for _ in range(RUNS))
    methods = {"raster-full": ("", "", args.full_queries, args.full_queries),
               "raster-window": ("", "", args.points, args.patches),
               "store-gpkg": (gpkg, colorstore.DEFAULT_TABLE, args.points, args.patches),
               "store-postgis": (dsn, table, args.points, args.patches)}
    results = []
    for name, (store, tbl, n_points, n_patches) in methods.items():
        row = {"method": name}
        for kind, n in (("point", n_points), ("patch", n_patches)):
            runs = [_run_child(name, ortho, store, tbl, kind, n, 1000 * run + 1) for run in range(RUNS)]
            row[kind] = {"queries": n, "p50_ms": _stats([_pct(r["times"], 50) for r in runs]),
                         "p95_ms": _stats([_pct(r["times"], 95) for r in runs]),
                         "open_ms": _stats([r["open_s"] * 1e3 for r in runs]),
                         "peak_mb": _stats([r["rss_mb"] - base for r in runs])}
        results.append(row)
        print(f"{name}: point p50 {_fmt(row['point']['p50_ms'], 3)} ms, patch p50 {_fmt(row['patch']['p50_ms'])} ms, "
              f"peak {_fmt(row['point']['peak_mb'], 1)} / {_fmt(row['patch']['peak_mb'], 1)} MB", flush=True)

    with psycopg2.connect(dsn) as conn, conn.cursor() as cur:  # rebuilt by every run: do not keep it
        cur.execute(f"DROP TABLE {table}; DROP TABLE {table}_meta")
    print("\n| method | point p50 ms | point p95 ms | patch p50 ms | patch p95 ms | peak MB (points) "
          "| peak MB (patches) |")
    print("|---|---|---|---|---|---|---|")
    for row in results:
        p, q = row["point"], row["patch"]
        print(f"| {row['method']} | {_fmt(p['p50_ms'], 3)} | {_fmt(p['p95_ms'], 3)} | {_fmt(q['p50_ms'])} | "
              f"{_fmt(q['p95_ms'])} | {_fmt(p['peak_mb'], 1)} | {_fmt(q['peak_mb'], 1)} |")
    print(f"| paper raster (Tables 15, 16) | {PAPER['raster_query_s']} s | | | | {PAPER['raster_memory']} | |")
    print(f"| paper vector (Tables 15, 16) | {PAPER['vector_query_s']} s | | | | {PAPER['vector_memory']} | |")
    mb = 1e6
    print(f"\nTable 14 (sizes): image {sizes['image_raw_bytes'] / mb:.1f} MB raw RGB, "
          f"{sizes['image_file_bytes'] / mb:.1f} MB as DEFLATE GeoTIFF; store {sizes['gpkg_bytes'] / mb:.1f} MB "
          f"GeoPackage, {sizes['postgis_bytes'] / mb:.1f} MB PostGIS. Paper: {PAPER['raster_file_mb']} MB image "
          f"vs {PAPER['vector_store_mb']} MB store. Peak memory is above a {base:.0f} MB import baseline.")
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"ortho": str(ortho), "size_px": args.size, "tolerance": args.tolerance,
                               "metric": args.metric, "baseline_rss_mb": base, "builds_s": builds,
                               "sizes": sizes, "results": results, "paper": PAPER, "cpus": os.cpu_count(),
                               "gdal": gdal.__version__, "load_average": os.getloadavg()}, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        method, ortho, store, table, kind, n, seed = sys.argv[2:]
        _child(method, ortho, store, table, kind, int(n), int(seed))
    else:
        main()
