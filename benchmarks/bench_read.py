"""Benchmark reading a real-shaped NGII building layer: the Arrow fast path against the
feature API that layers with non-UTF-8 field names take (``bulk_read.arrow_ready``).

The layer: ``--buildings`` (default 100,000) NGII-shaped buildings (``N3A_B0010000``: Korean field
names, CP949 text, EPSG:5187, no ``.cpg``), generated once under ``out/bench/read_data``. Cases,
each in its own child process (peak RSS its own), under QGIS's ``SHAPE_ENCODING=""``:

* ``arrow``: ``vector_io.read_layer`` as the core reads it (explicit encoding: UTF-8 names, Arrow);
* ``features``: the same read forced through the feature API (what a CSV with CP949 names takes).

Run: ``.venv/bin/python benchmarks/bench_read.py [--buildings N]``
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out" / "bench"


def make_layer(path: Path, count: int) -> None:
    sys.path.insert(0, str(ROOT / "tests"))
    import ngii

    side = int(count ** 0.5) + 1
    rows, wkts = [], []
    for k in range(count):
        x, y = 200000.0 + 25 * (k % side), 350000.0 + 25 * (k // side)
        rows.append({"명칭": ngii.NAMES[k % 12] or None, "구분": "건물", "종류": ngii.KINDS[k % 12],
                     "용도": ngii.USES[k % 12], "층수": ngii.FLOORS[k % 12], "측량방법": "사진측량",
                     "UFID": f"B001{k:030d}"})
        wkts.append(ngii.building_wkt(x, y))
    ngii.write_shapefile(path, ngii.ogr.wkbPolygon, ngii.BUILDING_FIELDS, rows, wkts, cpg=None)


def run_case(case: str, path: str) -> dict:
    sys.path.insert(0, str(ROOT))
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")
    from osgeo import gdal

    gdal.SetConfigOption("SHAPE_ENCODING", "")
    from wit_plugin.infra.io import bulk_read, vector_io

    if case == "features":
        bulk_read.arrow_ready = lambda layer: False  # the fallback, as for non-UTF-8 names
    start, cpu = time.perf_counter(), time.process_time()
    layer = vector_io.read_layer(path)
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    assert layer.columns["층수"][:3] == [1, 2, 3] and layer.encoding == "CP949"
    return {"case": case, "features": len(layer), "seconds": round(seconds, 2), "cpu_seconds": round(cpu, 2),
            "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--buildings", type=int, default=100_000)
    parser.add_argument("--case", help=argparse.SUPPRESS)
    parser.add_argument("--path", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:
        print(json.dumps(run_case(args.case, args.path)))
        return
    path = OUT / "read_data" / f"{args.buildings}" / "N3A_B0010000.shp"
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        make_layer(path, args.buildings)
    results = []
    for case in ("arrow", "features"):
        out = subprocess.run([sys.executable, __file__, "--case", case, "--path", str(path)], check=True,
                             capture_output=True, text=True).stdout
        results.append(json.loads(out.strip().splitlines()[-1]))
    print(f"{'case':<10}{'features':>10}{'seconds':>10}{'CPU s':>10}{'peak MB':>10}")
    for r in results:
        print(f"{r['case']:<10}{r['features']:>10}{r['seconds']:>10}{r['cpu_seconds']:>10}{r['peak_rss_mb']:>10}")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "read.json").write_text(json.dumps(results, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
