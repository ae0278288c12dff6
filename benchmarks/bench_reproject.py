"""Benchmark a DEM in another CRS than the layers': the cost of reprojecting it on the fly,
and how far the reprojected surface departs from bilinear sampling of the source DEM.

Data: the generated 1 km sample around Suseo station (5 m DEM in EPSG:5186 with undeclared -9999
holes), its vectors prepared once in EPSG:5186 and once in EPSG:5187 (the East Belt), cached under
``out/bench/reproject_data``. Each case runs in its own child process (its peak RSS is its own):

* ``open``: ``Dem.open`` of the study area's window: the plain read (layers in 5186) against the
  reprojection (layers in 5187: a 5 m grid warped in memory);
* ``terrain``: ``build.triangulate_terrain`` (5 m edge, 0.5 m tolerance, without spatial index) in both CRSs;
* ``extrude``: ``extrude.extrude_buildings`` in both CRSs;
* ``coverage``: ``chain.coverage.require_dem`` in both CRSs.

Accuracy (in the parent): at 200,000 random points of the area, the reprojected surface against the
source DEM's bilinear height at the transformed point (max, 99th percentile, RMS), on the sample's
DEM and, when ``../shared`` is there, on the real 90 m DEM of Seoul (a 2 km square around Suseo).

Run: ``.venv/bin/python benchmarks/bench_reproject.py``; writes ``out/bench/reproject.json``.
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
DATA = OUT / "reproject_data"
CENTER = (127.1020, 37.4876)  # Suseo station, EPSG:4737
RADIUS = 1000.0
CRSS = {"plain": "EPSG:5186", "reprojected": "EPSG:5187"}  # the DEM is in EPSG:5186
SEOUL_DEM = ROOT.parent / "shared" / "data" / "dem_seoul_90m_5186" / "seoul_dem.tif"


def _setup() -> None:
    sys.path.insert(0, str(ROOT))
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")


def peak_rss_mb() -> float:
    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)


def cpu_seconds() -> float:
    """User + system CPU of this process: what to compare when other sessions load the machine."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def prepare_data() -> dict:
    """The sample, and its vectors prepared in both CRSs (once; later runs reuse them)."""
    _setup()
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.prepare.vectors import PrepareConfig, prepare_vectors
    from wit_plugin.sample import SampleConfig, generate_sample

    sample = DATA / "sample"
    if not (sample / "sample_manifest.json").exists():
        generate_sample(sample, SampleConfig(center_lon=CENTER[0], center_lat=CENTER[1], radius_m=RADIUS,
                                             with_ortho=False, with_dem=True))
    paths = {"dem": str(sample / "dem_5186.tif")}
    for kind, crs in CRSS.items():
        prepared = DATA / f"prepared_{crs.replace(':', '')}.gpkg"
        if not prepared.exists():
            prepare_vectors(sample / "TL_SPBD_BULD.shp", sample / "TL_SPRD_MANAGE.shp", sample / "TL_SCCO_EMD.shp",
                            StudyArea.circle(*CENTER, RADIUS, "EPSG:4737"), prepared, PrepareConfig(target_crs=crs))
        paths[kind] = str(prepared)
    return paths


def _area(prepared: str):
    from wit_plugin.infra import step_layers
    from wit_plugin.infra.io.vector_io import read_prepared

    return read_prepared(f"{prepared}|layername={step_layers.STUDY_AREA}", step_layers.STUDY_AREA).geoms[0]


def run_case(case: str, kind: str, paths: dict) -> dict:
    _setup()
    from wit_plugin.buildings import extrude
    from wit_plugin.chain.coverage import require_dem
    from wit_plugin.infra import step_layers
    from wit_plugin.infra.dem import Dem
    from wit_plugin.terrain import build

    prepared, crs = paths[kind], CRSS[kind]
    area = _area(prepared)
    start, cpu = time.perf_counter(), cpu_seconds()
    if case == "open":
        dem = Dem.open(paths["dem"], area.bounds, crs=crs)
        result = {"cells": int(dem.values.size), "cell_m": dem.geotransform[1]}
    elif case == "terrain":
        stats = build.triangulate_terrain(paths["dem"], f"{prepared}|layername={step_layers.PREPARED_BUILDINGS}",
                                            f"{prepared}|layername={step_layers.PREPARED_ROADS}",
                                            DATA / f"tin_{kind}.gpkg", area, build.TerrainConfig(spatial_index=False))
        result = {"triangles": stats.triangles, "max_vertical_error": stats.max_vertical_error}
    elif case == "extrude":
        stats = extrude.extrude_buildings(f"{prepared}|layername={step_layers.PREPARED_BUILDINGS}", paths["dem"],
                                          DATA / f"lod1_{kind}.gpkg", spatial_index=False)
        result = {"solids": stats.solids}
    else:
        require_dem(paths["dem"], area, crs)
        result = {}
    return {"seconds": round(time.perf_counter() - start, 3), "cpu_s": round(cpu_seconds() - cpu, 3),
            "peak_rss_mb": peak_rss_mb(), **result}


def accuracy(dem_path: str, bounds: tuple[float, float, float, float], points: int = 200_000) -> dict:
    """The reprojected surface (EPSG:5187) against the source's bilinear height at the transformed point."""
    _setup()
    import numpy as np
    import pyproj

    from wit_plugin.infra.dem import Dem

    source = Dem.open(dem_path)
    warped = Dem.open(dem_path, bounds, crs="EPSG:5187")
    rng = np.random.default_rng(1)
    x, y = rng.uniform(bounds[0], bounds[2], points), rng.uniform(bounds[1], bounds[3], points)
    sx, sy = pyproj.Transformer.from_crs("EPSG:5187", "EPSG:5186", always_xy=True).transform(x, y)
    error = np.abs(warped.sample(x, y) - source.sample(sx, sy))
    return {"cell_m": warped.geotransform[1], "max_m": round(float(error.max()), 4),
            "p99_m": round(float(np.percentile(error, 99)), 4), "rms_m": round(float(np.sqrt((error ** 2).mean())), 4),
            "mean_m": round(float(error.mean()), 4)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--case")
    parser.add_argument("--kind")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    paths = prepare_data()
    if args.case:
        print(json.dumps(run_case(args.case, args.kind, paths)))
        return
    import pyproj

    results: dict = {"cases": {}, "load_average": os.getloadavg()}
    for case in ("coverage", "open", "terrain", "extrude"):
        for kind in CRSS:
            runs = [json.loads(subprocess.run([sys.executable, __file__, "--case", case, "--kind", kind],
                                              capture_output=True, text=True, check=True).stdout)
                    for _ in range(args.runs)]
            best = min(runs, key=lambda r: r["cpu_s"])
            results["cases"][f"{case}/{kind}"] = {**best, "all_cpu_s": [r["cpu_s"] for r in runs]}
    area = _area(paths["reprojected"])
    results["accuracy_sample"] = accuracy(paths["dem"], area.bounds)
    if SEOUL_DEM.is_file():
        x, y = pyproj.Transformer.from_crs("EPSG:4737", "EPSG:5187", always_xy=True).transform(*CENTER)
        results["accuracy_seoul_90m"] = accuracy(str(SEOUL_DEM), (x - 1000, y - 1000, x + 1000, y + 1000))
    print(f"{'case (best of runs)':<22}{'plain CPU s':>12}{'reproj. CPU s':>14}{'plain wall s':>13}"
          f"{'reproj. wall s':>15}{'plain MB':>10}{'reproj. MB':>12}")
    for case in ("coverage", "open", "terrain", "extrude"):
        plain, warped = results["cases"][f"{case}/plain"], results["cases"][f"{case}/reprojected"]
        print(f"{case:<22}{plain['cpu_s']:>12.3f}{warped['cpu_s']:>14.3f}{plain['seconds']:>13.3f}"
              f"{warped['seconds']:>15.3f}{plain['peak_rss_mb']:>10.0f}{warped['peak_rss_mb']:>12.0f}")
    for name in ("accuracy_sample", "accuracy_seoul_90m"):
        if name in results:
            print(name, results[name])
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "reproject.json").write_text(json.dumps(results, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
