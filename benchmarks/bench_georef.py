"""Benchmark wit:georeferencemapsheets: 100 unreferenced 1:5,000-sheet TIFs → GeoTIFF and VRT.

Generates 100 plain (uncompressed, unreferenced) RGB uint8 TIFFs of 1000×1200 pixels, named like
NGII downloads (``(B060)정사영상_2022_<sheet>.tif``, the 100 sheets of 1:50,000 sheet 37709), then
georeferences them once per output format. Generation and each format run in their own child
process, started from a parent that imports nothing heavy: Linux carries ``ru_maxrss`` over fork
and exec, so this keeps each peak RSS (``resource.getrusage``) the run's own. The paper has no
figure for this step.

Run: ``.venv/bin/python benchmarks/bench_georef.py [--count N] [--width W] [--height H]``
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FORMATS = ("GTiff", "VRT")


def peak_rss_mb() -> float:
    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)


def make_inputs(folder: str, count: int, width: int, height: int) -> dict:
    """Write ``count`` ortho-like TIFs (smooth gradients + noise, so they compress like photos)."""
    import numpy as np
    from osgeo import gdal

    start = time.perf_counter()
    rng = np.random.default_rng(42)
    y, x = np.mgrid[0:height, 0:width]
    driver = gdal.GetDriverByName("GTiff")
    total = 0
    for n in range(1, count + 1):
        base = (x * (0.1 + n % 7 * 0.02) + y * 0.07 + n * 13) % 256
        pixels = np.stack([base, base[::-1], base[:, ::-1]]) + rng.normal(0, 6, (3, height, width))
        pixels = np.clip(pixels, 0, 255).astype(np.uint8)
        path = Path(folder) / f"(B060)정사영상_2022_37709{n:03d}.tif"
        ds = driver.Create(str(path), width, height, 3, gdal.GDT_Byte, ["PHOTOMETRIC=RGB"])
        ds.WriteRaster(0, 0, width, height, pixels.tobytes())
        ds = None
        total += path.stat().st_size
    return {"input_mb": round(total / 2**20, 1), "generate_s": round(time.perf_counter() - start, 2),
            "gdal": gdal.__version__}


def run_mode(input_dir: str, output_dir: str, fmt: str) -> dict:
    """Georeference everything in ``input_dir``; time, counts, sizes and this process's peak RSS."""
    sys.path.insert(0, str(ROOT))
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")
    from wit_plugin.mosaic import georef

    tifs = georef.list_tifs(input_dir)
    rss_before = peak_rss_mb()
    start = time.perf_counter()
    results = georef.georeference_sheets(tifs, output_dir, fmt=fmt)
    seconds = time.perf_counter() - start
    ok = [r for r in results if r.status == "ok"]
    return {
        "format": fmt,
        "files": len(tifs),
        "ok": len(ok),
        "seconds": round(seconds, 3),
        "files_per_s": round(len(ok) / seconds, 1),
        "output_mb": round(sum(Path(r.output).stat().st_size for r in ok) / 2**20, 1),
        "rss_after_imports_mb": rss_before,
        "peak_rss_mb": peak_rss_mb(),
    }


def child(*args: str) -> dict:
    """Run this script in a fresh interpreter with ``args``; its last stdout line is JSON."""
    out = subprocess.run([sys.executable, __file__, *args], check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=100)
    parser.add_argument("--width", type=int, default=1000)
    parser.add_argument("--height", type=int, default=1200)
    parser.add_argument("--generate", metavar="FOLDER", help=argparse.SUPPRESS)
    parser.add_argument("--run", nargs=3, metavar=("INPUT", "OUTPUT", "FORMAT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.generate:
        print(json.dumps(make_inputs(args.generate, args.count, args.width, args.height)))
        return
    if args.run:
        print(json.dumps(run_mode(*args.run)))
        return

    with tempfile.TemporaryDirectory(prefix="wit-bench-georef-") as tmp:
        inputs = Path(tmp) / "입력"
        inputs.mkdir()
        generated = child("--generate", str(inputs), "--count", str(args.count),
                          "--width", str(args.width), "--height", str(args.height))
        rows = [child("--run", str(inputs), str(Path(tmp) / f"out-{fmt}"), fmt) for fmt in FORMATS]

    report = {
        "benchmark": "georeferencemapsheets",
        "inputs": {"count": args.count, "width": args.width, "height": args.height, "bands": 3, "dtype": "uint8",
                   "input_mb": generated["input_mb"], "generate_s": generated["generate_s"]},
        "gdal": generated["gdal"],
        "cpus": os.cpu_count(),
        "paper": None,
        "runs": rows,
    }
    print(f"{args.count} unreferenced {args.width}×{args.height} RGB uint8 TIFs, "
          f"{report['inputs']['input_mb']} MB in total (paper: no figure for this step)")
    print(f"{'format':<8}{'files':>7}{'ok':>5}{'time s':>9}{'files/s':>9}{'out MB':>9}"
          f"{'RSS after imports MB':>22}{'peak RSS MB':>13}")
    for r in rows:
        print(f"{r['format']:<8}{r['files']:>7}{r['ok']:>5}{r['seconds']:>9.2f}{r['files_per_s']:>9.1f}"
              f"{r['output_mb']:>9.1f}{r['rss_after_imports_mb']:>22.1f}{r['peak_rss_mb']:>13.1f}")
    print(json.dumps(report, indent=2, ensure_ascii=False))


if __name__ == "__main__":
    main()
