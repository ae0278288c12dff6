"""``make bench``: the paper's Tables 15, 16, 19 and 20 reproduced on the sample data, ours beside the paper's.

Sizes (``--sizes``): ``default`` = the default sample (1 km around Suseo station), ``4x`` = radius
2 km (4× the area), ``quick`` = radius 300 m; a bare number is a radius in metres. For each size:

1. **Data** (not timed): ``wit_plugin.sample.generate_sample`` once, cached under
   ``out/bench/data/<size>-<hash of the SampleConfig>/`` so reruns reuse it.
2. **Table 20, the whole chain**, ``--runs`` times (default once): georeference → merge (feather + gain) →
   prepare vectors → terrain TIN → extrude LoD1 → texture → write CityGML → validate. Every step of
   every run is its own child process (``python run_all.py --step …``) started from this parent,
   which imports nothing heavy; the step's time is measured inside the child around the library
   call (interpreter start-up and imports excluded; the wall time of the child is kept too) and its
   peak memory is the child's ``VmHWM`` from ``/proc/self/status`` (reset at exec, so it is the
   step's own, not the parent's RSS at fork as ``ru_maxrss`` would carry). The terrain step is
   split like ``bench_geometry.py``: mesh (constraint cleaning + Triangle), DEM mapping (DEM read,
   bilinear Z, vertical error) and writing the TIN. Table 20's "total" row is what the paper's is,
   the sum of its three stages (15 s = 0.5 loading + 6.5 mesh + 8 DEM mapping): our loading
   (wit:preparevectors) + mesh + DEM mapping; beside it, all 3D objects on disk (loading, the whole
   terrain step with the TIN written, LoD1 extrusion) and the whole chain (the eight steps). A step
   running longer than ``--step-timeout`` (default 300 s) is killed, and one that fails is
   recorded with its error; either is reported as "≥ its time" and ends that run, so ``make bench``
   stays bounded and always writes its tables.
3. **Table 19**: ``wit_plugin.metrics.texture_metrics`` on run 1's texture folder (the model's
   textures, inside their texture-coordinate rings) and on run 1's mosaic (over the buildings' box
   and inside the footprints), in a child process.
4. **Tables 15 and 16**: ``bench_colorstore.py``'s children (raster whole-load per query, windowed
   read, colour store ``query_point`` / ``query_patch``), three runs with different random
   queries, on a centred crop of run 1's mosaic (2048 px = 1 km square for ``default``, 4096 px for
   ``4x``; cached with its GeoPackage colour store under the size's data folder). ``--postgis``
   adds the PostGIS store (scripts/postgis.sh's server; the table is rebuilt each time).

Writes ``out/bench/results.json`` and ``out/bench/results.md`` and prints the Markdown.

Usage: ``python benchmarks/run_all.py [--quick] [--sizes default,4x] [--runs 1] [--step-timeout 300]
[--postgis [DSN]] [--skip-colorstore] [--skip-metrics]``
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out" / "bench"
SCHEMAS = ROOT.parent / "shared" / "schemas"
CENTER = (127.1020, 37.4876)  # Suseo station, EPSG:4737
SIZES = {"quick": 300.0, "default": 1000.0, "4x": 2000.0}
STEPS = ("georeference", "merge", "prepare", "terrain", "extrude", "texture", "citygml", "validate")
GOAL_TOTAL_S = 5.0

PAPER_T15 = {"raster": [2.2, 2.8, 3.2], "raster_avg": "2.73 ± 0.51", "vector": [0.23, 0.21, 0.22],
             "vector_avg": "0.22 ± 0.01"}
PAPER_T16 = {"raster": ["1.3 GB", "1.5 GB", "1.8 GB"], "raster_avg": "1.53 ± 0.25 GB",
             "vector": ["38 MB", "45 MB", "50 MB"], "vector_avg": "44.3 ± 6.0 MB"}
PAPER_T19 = {"laplacian_variance": {"Bing Maps": 898.63, "V-World": 1471.99, "WIT": 3008.24},
             "contrast": {"Bing Maps": 71.32, "V-World": 75.35, "WIT": 78.87}}
PAPER_T20 = [  # (stage, method A, method B, proposed)
    ("Vector data loading", "0.5", "0.5", 0.5),
    ("Mesh generation", "X", "X", 6.5),
    ("DEM mapping", "X", "X", 8.0),
    ("Total processing time", "45", "30", 15.0),
]


# --- child processes ---------------------------------------------------------------------------------

def _vm_hwm_mb(pid: int | str = "self") -> float | None:
    """Peak resident set (VmHWM) of a process (default: this one), in MB, from /proc."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return round(int(line.split()[1]) / 1024, 1)
    except OSError:
        pass
    if pid != "self":
        return None
    import resource

    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)


def _setup_child() -> None:
    sys.path.insert(0, str(ROOT))
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")


def sample_config(radius: float) -> dict:
    return {"center_lon": CENTER[0], "center_lat": CENTER[1], "radius_m": radius, "seed": 42,
            "ortho_pixel_size": 0.5, "dem_cell_size": 5.0, "with_ortho": True, "with_dem": True}


def child_prepare_data(folder: str, config: dict) -> dict:
    """Generate the sample (not timed as part of the chain); reuse it when already there."""
    _setup_child()
    from wit_plugin.sample import SampleConfig, generate_sample

    sample = Path(folder) / "sample"
    start = time.perf_counter()
    generated = False
    if not (sample / "sample_manifest.json").exists():
        generate_sample(sample, SampleConfig(**config))
        generated = True
    manifest = json.loads((sample / "sample_manifest.json").read_text(encoding="utf-8"))
    return {"generated": generated, "seconds": round(time.perf_counter() - start, 2),
            "tiles": len(list((sample / "ortho").glob("*.tif"))), "counts": manifest.get("counts"),
            "radius_m": manifest.get("radius_m"),
            "bytes": sum(p.stat().st_size for p in sample.rglob("*") if p.is_file())}


def _paths(sample: str, run: str) -> dict:
    s, r = Path(sample), Path(run)
    return {"tiles": str(s / "ortho"), "dem": str(s / "dem_5186.tif"), "buildings": str(s / "TL_SPBD_BULD.shp"),
            "roads": str(s / "TL_SPRD_MANAGE.shp"), "districts": str(s / "TL_SCCO_EMD.shp"),
            "georef": str(r / "georef"), "sheets": str(r / "sheets.gpkg"), "mosaic": str(r / "ortho.tif"),
            "prepared": str(r / "prepared.gpkg"), "tin": str(r / "tin.gpkg"), "lod1": str(r / "lod1.gpkg"),
            "textures": str(r / "textures"), "gml": str(r / "model" / "model.gml")}


def child_step(step: str, sample: str, run: str, radius: float) -> dict:
    """One chain step in this (child) process: its in-call seconds, peak memory and what it made."""
    _setup_child()
    p = _paths(sample, run)
    info: dict = {}
    if step == "georeference":
        from wit_plugin.mosaic import georef

        tiles = georef.list_tifs(p["tiles"])
        start = time.perf_counter()
        results = georef.georeference_sheets(tiles, p["georef"])
        georef.write_footprint_index(results, p["sheets"])
        seconds = time.perf_counter() - start
        info = {"sheets": sum(r.status == "ok" for r in results)}
    elif step == "merge":
        from wit_plugin.mosaic import merge_rasters

        sheets = sorted(str(t) for t in Path(p["georef"]).glob("*.tif"))
        start = time.perf_counter()
        report = merge_rasters(sheets, p["mosaic"], mode="feather", gain=True)
        seconds = time.perf_counter() - start
        info = {"width": report.width, "height": report.height, "blended_pixels": report.blended_pixels}
    elif step == "prepare":
        from wit_plugin.prepare.area import StudyArea
        from wit_plugin.prepare.vectors import PrepareConfig, prepare_vectors

        start = time.perf_counter()
        report = prepare_vectors(p["buildings"], p["roads"], p["districts"],
                                 StudyArea.circle(*CENTER, radius, "EPSG:4737"), p["prepared"], PrepareConfig())
        seconds = time.perf_counter() - start
        info = {s.layer: s.features_out for s in report.stats}
    elif step == "terrain":

        from benchmarks.bench_geometry import terrain_clock
        from wit_plugin.infra import step_layers
        from wit_plugin.terrain import build

        clock = terrain_clock()
        start = time.perf_counter()
        stats = build.triangulate_terrain(p["dem"], p["prepared"], p["prepared"], p["tin"],
                                            f"{p['prepared']}|layername={step_layers.STUDY_AREA}",
                                            build.TerrainConfig(spatial_index=False))  # as wit:citymodel
        seconds = time.perf_counter() - start
        split = {k: round(v, 3) for k, v in clock.seconds.items()}
        split["other"] = round(seconds - sum(clock.seconds.values()), 3)  # reading the layers, bookkeeping
        info = {"split_s": split, "triangles": stats.triangles, "vertices": stats.vertices,
                "max_vertical_error": stats.max_vertical_error, "max_edge": stats.max_edge}
    elif step == "extrude":
        from wit_plugin.buildings import extrude

        start = time.perf_counter()
        stats = extrude.extrude_buildings(p["prepared"], p["dem"], p["lod1"], spatial_index=False)
        seconds = time.perf_counter() - start
        info = stats.as_dict()
    elif step == "texture":
        from wit_plugin.texture import TextureConfig, texture_model

        start = time.perf_counter()
        report = texture_model(p["mosaic"], p["lod1"], p["tin"], p["textures"], TextureConfig())
        seconds = time.perf_counter() - start
        info = {"images": len(report.images), "atlases": report.atlases, "ground_images": report.ground_images,
                "surfaces": report.surfaces, "mb_written": round(report.bytes_written / 1e6, 1)}
    elif step == "citygml":
        from wit_plugin.citygml import writer as citygml

        start = time.perf_counter()
        report = citygml.write_citygml(citygml.CityGMLInputs(
            lod1=p["lod1"], tin=p["tin"], roads=p["prepared"], districts=p["prepared"], textures=p["textures"]),
            p["gml"])
        seconds = time.perf_counter() - start
        info = {"buildings": report.buildings, "faces": report.faces, "roads": report.roads,
                "triangles": report.triangles, "textures": report.textures, "groups": report.groups,
                "gml_mb": round(Path(p["gml"]).stat().st_size / 1e6, 1)}
    elif step == "validate":
        from wit_plugin.citygml.validate import validate_files

        start = time.perf_counter()
        report = validate_files([p["gml"]], SCHEMAS)[0]
        seconds = time.perf_counter() - start
        info = {"valid": report.valid, "errors": sum(i.severity == "error" for i in report.issues),
                "warnings": sum(i.severity == "warning" for i in report.issues), "details": report.details}
    else:
        raise SystemExit(f"unknown step {step}")
    import resource

    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # any helper processes
    return {"seconds": round(seconds, 3), "peak_rss_mb": max(_vm_hwm_mb(), round(children, 1)), "info": info}


def child_metrics(sample: str, run: str) -> dict:
    """Table 19 on run 1's outputs: the model's textures and the mosaic they were cut from."""
    _setup_child()
    from benchmarks.bench_metrics import _footprints
    from wit_plugin import metrics

    p = _paths(sample, run)
    start = time.perf_counter()
    model = metrics.texture_metrics(p["textures"])
    footprints = _footprints(p)
    ortho = metrics.texture_metrics(None, p["mosaic"], footprints.bounds, footprints)
    seconds = time.perf_counter() - start
    def q(r):
        return {"laplacian_variance": r.laplacian_variance, "contrast": r.contrast, "pixels": r.pixels}

    return {"model_textures": {"laplacian_variance": model.laplacian_variance, "contrast": model.contrast,
                               "pixels": model.pixels, "images": len(model.images), "masked": model.masked},
            "mosaic_buildings_box": q(ortho.ortho), "mosaic_in_footprints": q(ortho.ortho_inside),
            "seconds": round(seconds, 2), "peak_rss_mb": _vm_hwm_mb()}


def child_colorstore_data(mosaic: str, folder: str, size: int) -> dict:
    """Crop run 1's mosaic to a centred ``size`` px square and build its GeoPackage colour store (cached)."""
    _setup_child()
    from osgeo import gdal

    from wit_plugin import colorstore

    gdal.UseExceptions()
    folder_p = Path(folder)
    folder_p.mkdir(parents=True, exist_ok=True)
    crop, store = folder_p / f"ortho_{size}.tif", folder_p / f"store_{size}_rms12.gpkg"
    build_s = None
    if not crop.exists():
        ds = gdal.Open(mosaic)
        w, h = ds.RasterXSize, ds.RasterYSize
        size = min(size, w, h)
        tmp = folder_p / f".ortho_{size}.tif"
        gdal.Translate(str(tmp), ds, srcWin=[(w - size) // 2, (h - size) // 2, size, size],
                       creationOptions=["TILED=YES", "BLOCKXSIZE=512", "BLOCKYSIZE=512", "COMPRESS=DEFLATE",
                                        "PREDICTOR=2", "PHOTOMETRIC=RGB"])
        os.replace(tmp, crop)
    if not store.exists():
        start = time.perf_counter()
        colorstore.build_color_store(str(crop), str(store), 12.0, metric="rms")
        build_s = round(time.perf_counter() - start, 1)
    with colorstore.ColorStore.open(store) as s:
        meta = s.meta
    ds = gdal.Open(str(crop))
    return {"ortho": str(crop), "store": str(store), "px": ds.RasterXSize, "build_s": build_s,
            "cells": meta["cells"], "image_raw_mb": round(ds.RasterXSize * ds.RasterYSize * 3 / 1e6, 1),
            "image_file_mb": round(crop.stat().st_size / 1e6, 1), "store_mb": round(store.stat().st_size / 1e6, 1),
            "table": colorstore.DEFAULT_TABLE}


# --- parent ------------------------------------------------------------------------------------------

def child(*args: str, timeout: float | None = None, allow_failure: bool = False) -> tuple[dict, float]:
    """Run this script in a fresh interpreter; its last stdout line is JSON. Returns it and the wall time.

    With ``timeout`` (s), a child still running then is killed: ``{"timed_out": True, "peak_rss_mb": …}``.
    With ``allow_failure``, a child that fails gives ``{"failed": True, "error": its last stderr line}``.
    """
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, __file__, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        wall = time.perf_counter() - start
        peak = _vm_hwm_mb(proc.pid)  # its peak so far, read before it is killed
        proc.kill()
        proc.communicate()
        return {"timed_out": True, "peak_rss_mb": peak}, wall
    wall = time.perf_counter() - start
    if proc.returncode and allow_failure:
        lines = stderr.strip().splitlines() or [f"exit code {proc.returncode}"]
        return {"failed": True, "error": lines[-1][:300], "peak_rss_mb": None}, wall
    if proc.returncode:
        sys.stderr.write(stderr[-5000:])
        raise SystemExit(f"child {' '.join(args[:2])} failed with exit code {proc.returncode}")
    return json.loads(stdout.strip().splitlines()[-1]), wall


def stats(values: list[float]) -> dict:
    return {"mean": statistics.mean(values), "std": statistics.stdev(values) if len(values) > 1 else 0.0,
            "runs": values}


def fmt(s: dict | None, digits: int = 2) -> str:
    """mean ± std (or the single value); "≥" when a run was cut off by the step time-out."""
    if not s:
        return "–"
    ge = "failed after " if s.get("failed") else "≥ " if s.get("lower_bound") else ""
    return ge + (f"{s['mean']:.{digits}f} ± {s['std']:.{digits}f}" if len(s["runs"]) > 1 else f"{s['mean']:.{digits}f}")


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def run_chain(name: str, sample: str, radius: float, runs: int, timeout: float | None) -> dict:
    """The eight steps, ``runs`` times; a step over ``timeout`` s is killed and counts as ≥ ``timeout``."""
    per_run = []
    for k in range(1, runs + 1):
        run_dir = OUT / "runs" / name / f"run{k}"
        shutil.rmtree(run_dir, ignore_errors=True)
        run_dir.mkdir(parents=True)
        steps = {}
        for step in STEPS:
            result, wall = child("--step", step, sample, str(run_dir), str(radius), timeout=timeout,
                                 allow_failure=True)
            cut = result.get("timed_out") or result.get("failed")
            if cut:  # killed or failed: its time is a lower bound, later steps have no input
                result.update(seconds=round(wall, 3), info={})
            result["wall_s"] = round(wall, 3)
            steps[step] = result
            log(f"  [{name} run {k}] {step:12s} {'≥' if cut else ' '}{result['seconds']:8.2f} s"
                f"  (wall {wall:7.2f} s)  peak {result['peak_rss_mb'] or 0:7.1f} MB"
                + ("  TIMED OUT (killed)" if result.get("timed_out") else "")
                + (f"  FAILED: {result['error']}" if result.get("failed") else ""))
            if cut:
                break
        total = sum(s["seconds"] for s in steps.values())
        split_s = steps.get("terrain", {}).get("info", {}).get("split_s", {})
        table20 = sum(steps[s]["seconds"] for s in ("prepare",) if s in steps) + split_s.get("mesh", 0.0) + \
            split_s.get("dem_mapping", 0.0)
        objects = sum(steps[s]["seconds"] for s in ("prepare", "terrain", "extrude") if s in steps)
        total_wall = sum(s["wall_s"] for s in steps.values())
        complete = len(steps) == len(STEPS) and not any(s.get("timed_out") or s.get("failed")
                                                         for s in steps.values())
        log(f"  [{name} run {k}] total {'' if complete else '≥ '}{total:.2f} s in the calls, "
            f"{total_wall:.2f} s with start-ups")
        per_run.append({"run": k, "steps": steps, "complete": complete, "total_s": round(total, 3),
                        "total_wall_s": round(total_wall, 3), "table20_total_s": round(table20, 3),
                        "objects_s": round(objects, 3)})

    def over(step: str, key: str) -> dict | None:
        values = [r["steps"][step][key] for r in per_run if step in r["steps"]]
        if not values or None in values:
            return None
        s = stats(values)
        cut = [r["steps"][step] for r in per_run if step in r["steps"]]
        s["lower_bound"] = any(c.get("timed_out") or c.get("failed") for c in cut)
        s["failed"] = any(c.get("failed") for c in cut)
        return s

    summary = {step: {"seconds": over(step, "seconds"), "wall_s": over(step, "wall_s"),
                      "peak_rss_mb": over(step, "peak_rss_mb")} for step in STEPS}
    split = {part: stats([r["steps"].get("terrain", {}).get("info", {}).get("split_s", {}).get(part, 0.0)
                          for r in per_run])
             for part in ("mesh", "dem_mapping", "write", "other")}
    complete = all(r["complete"] for r in per_run)
    total, total_wall = stats([r["total_s"] for r in per_run]), stats([r["total_wall_s"] for r in per_run])
    total["lower_bound"] = total_wall["lower_bound"] = not complete
    table20, objects = stats([r["table20_total_s"] for r in per_run]), stats([r["objects_s"] for r in per_run])
    objects["lower_bound"] = table20["lower_bound"] = not all("extrude" in r["steps"] for r in per_run)
    peaks = [s["peak_rss_mb"]["mean"] for s in summary.values() if s["peak_rss_mb"]]
    return {"runs": per_run, "steps": summary, "terrain_split": split, "complete": complete,
            "step_timeout_s": timeout, "total_s": total, "total_wall_s": total_wall, "table20_total_s": table20,
            "objects_s": objects, "peak_rss_mb": max(peaks)}


def run_colorstore(name: str, data: Path, mosaic: str, radius: float, quick: bool, dsn: str | None) -> dict:
    sys.path.insert(0, str(ROOT))
    from benchmarks import bench_colorstore as bc

    size = max(256, round(2048 * radius / 1000.0 / 256) * 256)
    built, wall = child("--colorstore-data", mosaic, str(data / "colorstore"), str(size))
    log(f"  [{name}] colour store data: {built['px']} px crop, {built['cells']} cells, "
        f"build {built['build_s']} s (None = cached), {wall:.1f} s")
    n_points, n_patches, n_full = (200, 50, 5) if quick else (1000, 200, 20)
    runs = bc.RUNS
    base_runs = [bc._run_child("baseline", built["ortho"], "", "", "point", 0, 0)["rss_mb"] for _ in range(runs)]
    base = statistics.mean(base_runs)
    methods = {"raster-full": ("", "", n_full, n_full), "raster-window": ("", "", n_points, n_patches),
               "store-gpkg": (built["store"], built["table"], n_points, n_patches)}
    table = None
    if dsn:
        import psycopg2

        table = f"wit_bench.cells_runall_{name}".replace("-", "_")
        with psycopg2.connect(dsn) as conn, conn.cursor() as cur:
            cur.execute("CREATE SCHEMA IF NOT EXISTS wit_bench")
        code = (f"import sys; sys.path.insert(0, {str(ROOT)!r}); from wit_plugin import colorstore; "
                f"colorstore.build_color_store({built['ortho']!r}, None, 12.0, metric='rms', "
                f"postgis_dsn={dsn!r}, table={table!r})")
        subprocess.run([sys.executable, "-c", code], check=True)
        methods["store-postgis"] = (dsn, table, n_points, n_patches)
    rows = {}
    for method, (store, tbl, n_pt, n_pa) in methods.items():
        row = {}
        for kind, n in (("point", n_pt), ("patch", n_pa)):
            res = [bc._run_child(method, built["ortho"], store, tbl, kind, n, 1000 * run + 1) for run in range(runs)]
            row[kind] = {"queries": n,
                         "mean_s": stats([statistics.mean(r["times"]) for r in res]),
                         "p50_ms": stats([bc._pct(r["times"], 50) for r in res]),
                         "open_s": stats([r["open_s"] for r in res]),
                         "peak_mb": stats([r["rss_mb"] - base for r in res])}
        rows[method] = row
        log(f"  [{name}] {method:14s} patch mean {fmt(row['patch']['mean_s'], 4)} s, point mean "
            f"{fmt(row['point']['mean_s'], 5)} s, peak {fmt(row['patch']['peak_mb'], 1)} MB above imports")
    if dsn and table:
        import psycopg2

        with psycopg2.connect(dsn) as conn, conn.cursor() as cur:
            cur.execute(f"DROP TABLE IF EXISTS {table}; DROP TABLE IF EXISTS {table}_meta")
    return {"data": built, "baseline_rss_mb": base, "methods": rows,
            "queries": {"point": n_points, "patch": n_patches, "raster_full": n_full,
                        "patch_m": bc.PATCH_M, "patch_res_m": bc.PATCH_RES}}


# --- Markdown ----------------------------------------------------------------------------------------

def _md_header(report: dict, names: list[str]) -> list[str]:
    """The title, the machine and, per size, its sample."""
    sizes = report["sizes"]
    md = ["# WIT City Model benchmarks vs the paper (Kang 2025)", "",
          (f"{report['machine']['cpus']} CPUs, {report['machine']['platform']}, Python {report['machine']['python']}; "
          f"runs per size: {report['runs']}; started {report['started']}; "
          f"took {report['elapsed_s'] / 60:.1f} min."), ""]
    for name in names:
        s = sizes[name]
        d = s["data"]
        c = d.get("counts") or {}
        tin = s["chain"]["runs"][0]["steps"].get("terrain", {}).get("info", {}) if "chain" in s else {}
        md.append(f"* **{name}**: radius {s['radius_m']:g} m around Suseo station; sample {d['tiles']} ortho sheets "
                  f"(0.5 m), {c.get('buildings', '?')} buildings generated; TIN {tin.get('triangles', 0):,} triangles.")
    md.append("")
    return md


def _md_table20(sizes: dict, names: list[str]) -> list[str]:
    """Table 20, the 3D object generation time, and the goal on the default sample."""
    md = ["## Table 20 — 3D object generation time (s)", "",
          ("Paper: Method A / B / proposed, as printed; its total (15 s) is the sum of its three stages. Ours: "
          "seconds inside the library calls, mean ± std over the runs; vector data loading = "
          "wit:preparevectors (read, clean, write); mesh generation and DEM mapping = the split of "
          "wit:triangulateterrain; total = the same three stages. The two rows below it are not in the "
          "paper: every 3D object on disk, and the whole chain (8 steps, the next table)."), ""]
    head = "| No. | Processing stage | Method A | Method B | Proposed (paper) | " + " | ".join(
        f"ours, {n}" for n in names) + " |"
    md += [head, "|" + "---|" * (5 + len(names))]
    for k, (stage, a, b, paper) in enumerate(PAPER_T20, 1):
        ours = []
        for n in names:
            ch = sizes[n].get("chain")
            if not ch:
                ours.append("–")
            elif k == 1:
                ours.append(fmt(ch["steps"]["prepare"]["seconds"]))
            elif k == 2:
                ours.append(fmt(ch["terrain_split"]["mesh"]))
            elif k == 3:
                ours.append(fmt(ch["terrain_split"]["dem_mapping"]))
            else:
                ours.append(f"**{fmt(ch['table20_total_s'])}**")
        md.append(f"| {k} | {stage} | {a} | {b} | {paper:g} | " + " | ".join(ours) + " |")
    for label, key in (("+ TIN read/written, LoD1 extruded and written (all 3D objects on disk)", "objects_s"),
                       ("whole chain: imagery, texture, CityGML, validation too", "total_s")):
        cells = [fmt(sizes[n]["chain"][key]) if sizes[n].get("chain") else "–" for n in names]
        md.append(f"| – | {label} | – | – | – | " + " | ".join(cells) + " |")
    md.append("")
    for n in names:
        ch = sizes[n].get("chain")
        if not ch:
            continue
        total = ch["table20_total_s"]["mean"]
        goal = ""
        if n == "default":
            goal = (f" Goal Table 20 total ≤ {GOAL_TOTAL_S:g} s on the default sample: "
                    f"**{'met' if total <= GOAL_TOTAL_S else 'NOT met'}** ({total:.2f} s; paper 15 s).")
        md.append(f"*{n}*: Table 20 total {fmt(ch['table20_total_s'])} s; whole chain {fmt(ch['total_s'])} s "
                  f"in the calls, {fmt(ch['total_wall_s'])} s wall (one Python start-up + imports per step).{goal}")
    md.append("")
    return md


def _md_steps(sizes: dict, names: list[str]) -> list[str]:
    """The chain per step (time, wall time, peak memory) and what run 1 made."""
    md = ["### Per step (time s, peak RSS MB of the step's process)", ""]
    md += ["| step | " + " | ".join(f"{n} s | {n} wall s | {n} peak MB" for n in names) + " |",
           "|---|" + "---|---|---|" * len(names)]
    for step in STEPS + ("terrain: mesh", "terrain: DEM mapping", "terrain: write TIN", "terrain: read/other",
                         "whole chain"):
        cells = []
        for n in names:
            ch = sizes[n].get("chain")
            if not ch:
                cells += ["–"] * 3
            elif step == "whole chain":
                cells += [f"**{fmt(ch['total_s'])}**", fmt(ch["total_wall_s"]), f"{ch['peak_rss_mb']:.0f} (max)"]
            elif step.startswith("terrain:"):
                part = {"mesh": "mesh", "DEM mapping": "dem_mapping", "write TIN": "write",
                        "read/other": "other"}[step.split(": ")[1]]
                cells += [fmt(ch["terrain_split"][part]), "", ""]
            else:
                st = ch["steps"][step]
                cells += [fmt(st["seconds"]), fmt(st["wall_s"]), fmt(st["peak_rss_mb"], 0)]
        md.append(f"| {step} | " + " | ".join(cells) + " |")
    md.append("")
    for n in names:
        ch = sizes[n].get("chain")
        if ch:
            i = {s: ch["runs"][0]["steps"].get(s, {}).get("info", {}) for s in STEPS}

            def g(step: str, key: str, default: object = "?", i: dict = i) -> object:
                return i[step].get(key, default)

            v = ch["runs"][0]["steps"].get("validate", {})
            valid = (f"{g('validate', 'valid')} ({g('validate', 'details')})" if i["validate"] else
                     f"not known (the validator failed: {v['error']})" if v.get("failed") else
                     "not known (validation cut off by the step time-out)")
            md.append(f"*{n}* (run 1): mosaic {g('merge', 'width')} × {g('merge', 'height')} px; "
                      f"{g('prepare', 'buildings')} buildings prepared; TIN {g('terrain', 'triangles', 0):,} "
                      f"triangles; {g('extrude', 'solids')} solids; {g('texture', 'images')} texture images "
                      f"({g('texture', 'mb_written')} MB); CityGML {g('citygml', 'gml_mb')} MB; valid: {valid}.")
    md.append("")
    return md


def _md_colorstore(sizes: dict, names: list[str]) -> list[str]:
    """Tables 15 and 16, the colour store beside the raster: query time and memory."""
    cs_names = [n for n in names if sizes[n].get("colorstore")]
    if not cs_names:
        return []
    md = ["## Table 15 — query response time", "",
          ("Paper: three experiments of growing complexity (1st, 2nd, 3rd), seconds per query incl. loading. "
          "Ours: three runs with different random queries (run 1, 2, 3), mean seconds per query; raster "
          "whole-load = per query gdal.Open + ReadAsArray of the whole image (the paper's raster way); "
          "windowed = the tiled GeoTIFF kept open, read only the window; store = ColorStore (GeoPackage), "
          "opened once. Patch = 64 m × 64 m at 0.5 m (128 × 128 texels); point = one colour."), ""]
    md += ["| approach | query | 1st / run 1 | 2nd / run 2 | 3rd / run 3 | average ± std |",
           "|---|---|---|---|---|---|"]
    md.append(f"| paper: raster-based | – | {' | '.join(f'{v} s' for v in PAPER_T15['raster'])} | "
              f"{PAPER_T15['raster_avg']} s |")
    md.append(f"| paper: vector-based | – | {' | '.join(f'{v} s' for v in PAPER_T15['vector'])} | "
              f"{PAPER_T15['vector_avg']} s |")
    labels = {"raster-full": "raster whole-load", "raster-window": "raster windowed",
              "store-gpkg": "vector store (GeoPackage)", "store-postgis": "vector store (PostGIS)"}
    for n in cs_names:
        cs = sizes[n]["colorstore"]
        for method, row in cs["methods"].items():
            for kind in ("patch", "point"):
                s = row[kind]["mean_s"]
                runs = " | ".join(f"{v:.2e} s" for v in s["runs"])
                md.append(f"| ours {n}: {labels[method]} | {kind} | {runs} | {s['mean']:.2e} ± {s['std']:.1e} s |")
    md.append("")
    md += ["## Table 16 — memory consumption", "",
           ("Ours: peak RSS of the querying process (GNU time) minus that of a process that only does the "
           "same imports, MB, per run (patch queries)."), ""]
    md += ["| approach | 1st / run 1 | 2nd / run 2 | 3rd / run 3 | average ± std |", "|---|---|---|---|---|"]
    md.append(f"| paper: raster-based | {' | '.join(PAPER_T16['raster'])} | {PAPER_T16['raster_avg']} |")
    md.append(f"| paper: vector-based | {' | '.join(PAPER_T16['vector'])} | {PAPER_T16['vector_avg']} |")
    for n in cs_names:
        cs = sizes[n]["colorstore"]
        for method, row in cs["methods"].items():
            s = row["patch"]["peak_mb"]
            md.append(f"| ours {n}: {labels[method]} | " + " | ".join(f"{v:.1f} MB" for v in s["runs"])
                      + f" | {fmt(s, 1)} MB |")
    md.append("")
    for n in cs_names:
        d = sizes[n]["colorstore"]["data"]
        md.append(f"*{n}*: image {d['px']} × {d['px']} px ({d['image_raw_mb']} MB raw RGB, {d['image_file_mb']} MB "
                  f"DEFLATE GeoTIFF), colour store {d['cells']:,} cells, {d['store_mb']} MB GeoPackage "
                  f"(paper Table 14: 12 MB image, 52 MB store); import baseline "
                  f"{sizes[n]['colorstore']['baseline_rss_mb']:.0f} MB.")
    md.append("")
    return md


def _md_table19(sizes: dict, names: list[str]) -> list[str]:
    """Table 19, the objective texture quality."""
    m_names = [n for n in names if sizes[n].get("metrics")]
    if not m_names:
        return []
    md = ["## Table 19 — objective texture quality", "",
          ("Paper: screenshots of Bing Maps, V-World and WIT at ten places. Ours (run 1): the model's texture "
          "images inside their texture-coordinate rings (what the CityGML shows: roofs, terrain, roads), and "
          "the merged orthoimage they were cut from (over the buildings' box; inside the footprints). The "
          "paper's images are not ours: its figures are context, not targets."), ""]
    cols = []
    for n in m_names:
        cols += [f"ours {n}: model textures", f"ours {n}: mosaic (box)", f"ours {n}: mosaic in footprints"]
    md += ["| No. | metric | Bing Maps | V-World | WIT (paper) | " + " | ".join(cols) + " |",
           "|" + "---|" * (5 + len(cols))]
    for k, (key, label) in enumerate((("laplacian_variance", "Edge sharpness (Laplacian variance)"),
                                      ("contrast", "Contrast (pixel intensity STD)")), 1):
        p = PAPER_T19[key]
        cells = []
        for n in m_names:
            m = sizes[n]["metrics"]
            cells += [f"{m['model_textures'][key]:.2f}", f"{m['mosaic_buildings_box'][key]:.2f}",
                      f"{m['mosaic_in_footprints'][key]:.2f}"]
        md.append(f"| {k} | {label} | {p['Bing Maps']} | {p['V-World']} | {p['WIT']} | " + " | ".join(cells) + " |")
    md.append("")
    return md


def markdown(report: dict) -> str:
    """The report as Markdown: the paper's tables beside ours, size by size."""
    sizes = report["sizes"]
    names = list(sizes)
    md = _md_header(report, names) + _md_table20(sizes, names) + _md_steps(sizes, names)
    md += _md_colorstore(sizes, names) + _md_table19(sizes, names)
    return "\n".join(md)

def run_script(script: str, extra: list[str]) -> str:
    """Run another benchmark of this folder, its output shown as it comes; its printed summary (the
    lines from its table on)."""
    log(f"== {script} {' '.join(extra)}")
    lines = []
    with subprocess.Popen([sys.executable, str(Path(__file__).with_name(script)), *extra], stdout=subprocess.PIPE,
                          text=True) as proc:
        for line in proc.stdout:
            print(line, end="", flush=True)
            lines.append(line.rstrip("\n"))
    if proc.returncode:
        return f"{script} failed (exit {proc.returncode}): " + " | ".join(lines[-3:])
    start = next((k for k, line in enumerate(lines) if line.startswith("|")), len(lines))
    return "\n".join(lines[start:])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="radius 300 m, one run (smoke test)")
    parser.add_argument("--sizes", help="comma-separated: default, 4x, quick or a radius in metres "
                                        "(default: default,4x; with --quick: quick)")
    parser.add_argument("--runs", type=int, default=1,
                        help="chain runs per size (default 1: the default-size chain takes minutes; Tables 15 "
                             "and 16 always make three query runs)")
    parser.add_argument("--step-timeout", type=float, default=300.0,
                        help="kill a chain step after this many seconds and report ≥ that (0: no limit)")
    parser.add_argument("--postgis", nargs="?", const="auto", metavar="DSN",
                        help="also query a PostGIS colour store (default DSN: start scripts/postgis.sh)")
    parser.add_argument("--skip-colorstore", action="store_true", help="leave out Tables 15 and 16")
    parser.add_argument("--skip-metrics", action="store_true", help="leave out Table 19")
    parser.add_argument("--skip-chain", action="store_true",
                        help="leave out the whole wit:citymodel through qgis_process beside xmllint (bench_chain.py)")
    parser.add_argument("--skip-tiles", action="store_true", help="leave out the tiled runs on Dask (bench_tiles.py)")
    parser.add_argument("--skip-triangulators", action="store_true",
                        help="leave out Triangle beside CDT on 1 km and 16 tiles (bench_triangulators.py)")
    args = parser.parse_args()
    sizes = (args.sizes or ("quick" if args.quick else "default,4x")).split(",")
    runs = max(1, args.runs)
    timeout = args.step_timeout or None
    started = time.strftime("%Y-%m-%d %H:%M:%S")
    t0 = time.perf_counter()
    dsn = None
    if args.postgis:
        dsn = args.postgis if args.postgis != "auto" else subprocess.run(
            ["bash", str(ROOT / "scripts" / "postgis.sh")], check=True, capture_output=True, text=True).stdout.strip()
    OUT.mkdir(parents=True, exist_ok=True)
    report: dict = {"started": started, "runs": runs, "quick": args.quick, "center_lon_lat": CENTER,
                    "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                                "python": platform.python_version(), "load_average_start": os.getloadavg()},
                    "paper": {"table15_s": PAPER_T15, "table16": PAPER_T16, "table19": PAPER_T19,
                              "table20_s": PAPER_T20},
                    "goal_total_s_default": GOAL_TOTAL_S, "step_timeout_s": timeout, "sizes": {}}
    for name in sizes:
        name = name.strip()
        radius = SIZES.get(name) or float(name)
        config = sample_config(radius)
        key = hashlib.sha1(json.dumps(config, sort_keys=True).encode()).hexdigest()[:8]
        data = OUT / "data" / f"{name}-{key}"
        log(f"== {name}: radius {radius:g} m, data {data}")
        prepared, wall = child("--prepare-data", str(data), json.dumps(config))
        log(f"  [{name}] sample {'generated' if prepared['generated'] else 'cached'} ({wall:.1f} s): "
            f"{prepared['tiles']} ortho sheets, {prepared['counts']}")
        entry: dict = {"radius_m": radius, "data_folder": str(data), "sample_config": config, "data": prepared}
        sample = str(data / "sample")
        entry["chain"] = run_chain(name, sample, radius, runs, timeout)
        run1 = str(OUT / "runs" / name / "run1")
        done = entry["chain"]["runs"][0]["steps"]
        if not args.skip_metrics and "timed_out" not in done.get("texture", {"timed_out": True}):
            entry["metrics"], wall = child("--metrics", sample, run1)
            log(f"  [{name}] texture metrics ({wall:.1f} s): model {entry['metrics']['model_textures']}")
        if not args.skip_colorstore and Path(_paths(sample, run1)["mosaic"]).exists():
            entry["colorstore"] = run_colorstore(name, data, _paths(sample, run1)["mosaic"], radius, args.quick, dsn)
        report["sizes"][name] = entry
        # write what we have after each size, so an interrupted run still leaves results
        report["elapsed_s"] = round(time.perf_counter() - t0, 1)
        (OUT / "results.json").write_text(json.dumps(report, indent=1, ensure_ascii=False), encoding="utf-8")
    report["elapsed_s"] = round(time.perf_counter() - t0, 1)
    report["machine"]["load_average_end"] = os.getloadavg()
    (OUT / "results.json").write_text(json.dumps(report, indent=1, ensure_ascii=False), encoding="utf-8")
    md = markdown(report)
    quick = args.quick
    for skip, title, script, extra in (
            (args.skip_chain, "The whole chain as users run it (qgis_process) beside xmllint --stream",
             "bench_chain.py", ["--radius", "300", "--no-core"] if quick else []),
            (args.skip_tiles, "Tiled runs on Dask (1:1,000 sheets)", "bench_tiles.py",
             ["--tiles", "1", "4"] if quick else []),
            (args.skip_triangulators, "Terrain triangulators: Triangle beside CDT", "bench_triangulators.py",
             ["--tiles", "4"] if quick else [])):
        if not skip:
            md += f"\n\n## {title} (benchmarks/{script})\n\n" + run_script(script, extra)
    (OUT / "results.md").write_text(md + "\n", encoding="utf-8")
    print(md)
    log(f"wrote {OUT / 'results.json'} and {OUT / 'results.md'} in {report['elapsed_s'] / 60:.1f} min")
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--step":
        print(json.dumps(child_step(sys.argv[2], sys.argv[3], sys.argv[4], float(sys.argv[5]))))
    elif len(sys.argv) > 1 and sys.argv[1] == "--prepare-data":
        print(json.dumps(child_prepare_data(sys.argv[2], json.loads(sys.argv[3]))))
    elif len(sys.argv) > 1 and sys.argv[1] == "--metrics":
        print(json.dumps(child_metrics(sys.argv[2], sys.argv[3])))
    elif len(sys.argv) > 1 and sys.argv[1] == "--colorstore-data":
        print(json.dumps(child_colorstore_data(sys.argv[2], sys.argv[3], int(sys.argv[4]))))
    else:
        sys.exit(main())
