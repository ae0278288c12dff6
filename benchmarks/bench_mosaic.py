"""Benchmark ``wit:mergerasters`` against GDAL's own mosaicking tools.

Generates four 1:5,000-sheet-like RGB tiles (0.25 m, about 9000 × 11000 px each, 2 × 2 layout
overlapping by 400 px = 100 m like NGII's 50 m margins, each tile with its own brightness), then
times each method in its own process and reads that process's peak RSS:

* ``merge_rasters`` overwrite, feather + gain (our output: tiled DEFLATE GeoTIFF + overviews);
* ``gdal_merge.py`` with the same creation options (no overviews);
* ``gdalbuildvrt`` + ``gdal_translate`` to GTiff with the same creation options (no overviews);
* ``gdalbuildvrt`` + ``gdal_translate -of COG`` (DEFLATE + overviews: the same product as ours).

Usage: ``python benchmarks/bench_mosaic.py [out.json] [--scale 0.25] [--keep]``. Tiles are cached
under /tmp and reused; outputs are deleted after each run.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FULL_W, FULL_H, FULL_OVERLAP = 9000, 11000, 400
PIXEL = 0.25
BRIGHTNESS = (1.0, 1.12, 0.9, 1.2)
CREATION = ["TILED=YES", "BLOCKXSIZE=512", "BLOCKYSIZE=512", "COMPRESS=DEFLATE", "PREDICTOR=2",
            "BIGTIFF=IF_SAFER", "NUM_THREADS=ALL_CPUS"]


def _scene(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A deterministic RGB 'orthophoto' in global pixel coordinates: smooth shapes plus texture."""
    xx, yy = np.meshgrid(x.astype(np.float32), y.astype(np.float32))
    hx, hy = np.meshgrid(x.astype(np.uint32), y.astype(np.uint32))
    noise = (((hx * np.uint32(73856093)) ^ (hy * np.uint32(19349663))) >> np.uint32(20)) % np.uint32(24)
    base = 110 + 50 * np.sin(xx / 400.0) * np.cos(yy / 650.0) + 20 * np.sin((xx + yy) / 90.0)
    rgb = np.stack([base + noise, base * 0.9 + 10 + noise, base * 0.8 + 20 + noise])
    return rgb


def make_tiles(folder: Path, scale: float) -> list[str]:
    """Write (or reuse) the four tiles; return their paths in mosaic order NW, NE, SW, SE."""
    from osgeo import gdal, osr

    w, h, ov = int(FULL_W * scale), int(FULL_H * scale), int(FULL_OVERLAP * scale)
    folder.mkdir(parents=True, exist_ok=True)
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    paths = []
    x_origin, y_origin = 206619.31, 497391.01  # sheet 37713074 with its 50 m margin
    for k, (col, row) in enumerate([(0, 0), (1, 0), (0, 1), (1, 1)]):
        path = folder / f"tile_{k + 1}.tif"
        paths.append(str(path))
        if path.exists():
            continue
        x0, y0 = col * (w - ov), row * (h - ov)
        tmp = folder / f".tile_{k + 1}.tif"
        ds = gdal.GetDriverByName("GTiff").Create(str(tmp), w, h, 3, gdal.GDT_Byte,
                                                  ["TILED=YES", "BLOCKXSIZE=512", "BLOCKYSIZE=512", "PHOTOMETRIC=RGB"])
        ds.SetGeoTransform((x_origin + x0 * PIXEL, PIXEL, 0, y_origin - y0 * PIXEL, 0, -PIXEL))
        ds.SetProjection(srs.ExportToWkt())
        for r in range(0, h, 512):
            n = min(512, h - r)
            rgb = _scene(np.arange(x0, x0 + w), np.arange(y0 + r, y0 + r + n)) * BRIGHTNESS[k]
            ds.WriteRaster(0, r, w, n, np.clip(rgb, 1, 255).astype(np.uint8).tobytes())
        ds = None
        os.replace(tmp, path)
    return paths


def _run(cmd: list[str]) -> tuple[float, float, int]:
    """Wall seconds, CPU seconds (user + system) and peak RSS (MB) of one command, by GNU time.

    Not ``getrusage`` in this process: Linux charges a child the parent's RSS at fork time.
    CPU seconds are reported because wall time suffers when other jobs share the machine.
    """
    with tempfile.NamedTemporaryFile("r", suffix=".time") as out:
        start = time.perf_counter()
        subprocess.run(["/usr/bin/time", "-f", "%U %S %M", "-o", out.name, *cmd], check=True,
                       stdout=subprocess.DEVNULL)
        elapsed = time.perf_counter() - start
        user, system, rss = out.read().split()[-3:]
        return elapsed, float(user) + float(system), int(rss) // 1024


def _merge_child(args: list[str]) -> None:
    """Child-process entry: run merge_rasters once."""
    sys.path.insert(0, str(ROOT))
    from wit_plugin.mosaic import merge_rasters

    mode, output, *inputs = args
    merge_rasters(inputs, output, mode=mode)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="?", default=str(ROOT / "out" / "bench" / "mosaic.json"))
    parser.add_argument("--scale", type=float, default=1.0, help="tile size factor (0.25 for a quick run)")
    parser.add_argument("--only", nargs="*", help="run only these method names")
    args = parser.parse_args()
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")
    tiles = make_tiles(Path(tempfile.gettempdir()) / f"wit_bench_mosaic_{args.scale:g}", args.scale)
    work = Path(tempfile.mkdtemp(prefix="wit_bench_mosaic_out_"))
    py = sys.executable
    co = [x for c in CREATION for x in ("-co", c)]
    vrt = str(work / "mosaic.vrt")
    methods = {
        "merge_rasters overwrite": [[py, __file__, "--child", "overwrite", str(work / "o.tif"), *tiles]],
        "merge_rasters feather+gain": [[py, __file__, "--child", "feather", str(work / "f.tif"), *tiles]],
        "gdal_merge.py": [[py, "/usr/bin/gdal_merge.py", "-q", *co, "-o", str(work / "m.tif"), *tiles]],
        "gdalbuildvrt + gdal_translate GTiff": [
            ["gdalbuildvrt", "-q", vrt, *tiles],
            ["gdal_translate", "-q", *co, vrt, str(work / "t.tif")]],
        "gdalbuildvrt + gdal_translate COG": [
            ["gdalbuildvrt", "-q", vrt, *tiles],
            ["gdal_translate", "-q", "-of", "COG", "-co", "COMPRESS=DEFLATE", "-co", "PREDICTOR=YES",
             "-co", "BIGTIFF=IF_SAFER", "-co", "NUM_THREADS=ALL_CPUS", "-co", "OVERVIEW_RESAMPLING=AVERAGE",
             vrt, str(work / "c.tif")]],
    }
    results = []
    print(f"{'method':38s} {'wall s':>7s} {'CPU s':>7s} {'RSS MB':>8s} {'out MB':>9s}")
    for name, cmds in methods.items():
        if args.only and name not in args.only:
            continue
        seconds, cpu, rss = 0.0, 0.0, 0
        for cmd in cmds:
            t, c, r = _run(cmd)
            seconds, cpu, rss = seconds + t, cpu + c, max(rss, r)
        size = sum(p.stat().st_size for p in work.glob("*.tif")) / 1e6
        results.append({"method": name, "wall_s": round(seconds, 1), "cpu_s": round(cpu, 1),
                        "peak_rss_mb": rss, "output_mb": round(size, 1)})
        for p in work.iterdir():
            p.unlink()
        print(f"{name:38s} {seconds:7.1f} {cpu:7.1f} {rss:8d} {size:9.1f}", flush=True)
    work.rmdir()
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    from osgeo import gdal

    ds = gdal.Open(tiles[0])
    info = {"tiles": len(tiles), "tile_size": [ds.RasterXSize, ds.RasterYSize],
            "overlap_px": int(FULL_OVERLAP * args.scale), "scale": args.scale, "cpus": os.cpu_count(),
            "gdal": gdal.__version__, "load_average": os.getloadavg(), "results": results}
    out.write_text(json.dumps(info, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        _merge_child(sys.argv[2:])
    else:
        main()
