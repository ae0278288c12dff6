"""The two terrain triangulators side by side: Triangle (TRIANGULATOR 0, non-commercial licence)
and CDT (TRIANGULATOR 1, MPL-2.0, with our Steiner points), on the same inputs.

* ``area``: ``mesh.triangulate`` + the snap to the millimetre grid on the 1 km / 5 m sample (the data of
  ``bench_geometry.py``: ~5,000 buildings, roads, 5 m DEM; max edge 5 m, tolerance 0.5 m), each backend in
  its own child process: wall and CPU seconds (CPU is the fairer figure on a shared machine), triangles,
  peak RSS, longest edge, measured maximum vertical error;
* ``tiles``: ``run_tiles`` over a block of 16 whole 1:1,000 sheets (``bench_tiles.py``'s sample) on 2 Dask
  workers per backend: wall seconds, the tiles' terrain steps added up, triangles, peak MB per worker.

Goal: CDT within 1.5 × Triangle's time and its triangle count within 10 % of Triangle's (fewer is no
fault: the same guarantees are checked on both). Prints a Markdown table; writes
``out/bench/triangulators.json``.

Run: ``.venv/bin/python benchmarks/bench_triangulators.py [--tiles 16] [--skip-tiles] [--runs 1]``
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out" / "bench"
sys.path.insert(0, str(ROOT))
GOAL_TIME_RATIO, GOAL_COUNT_RATIO = 1.5, 1.10


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def child_area(key: int) -> dict:
    """One backend on the 1 km sample, in this (child) process."""
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")
    from benchmarks import bench_geometry
    from wit_plugin.infra.dem import Dem
    from wit_plugin.terrain import mesh, output, triangulators

    paths = bench_geometry.prepare_data()
    _, footprints, roads = bench_geometry._inputs(paths)
    area = bench_geometry._study_area()
    dem = Dem.open(paths["dem"], area.bounds)
    wall, cpu = time.perf_counter(), _cpu()
    tin, stats = mesh.triangulate(area, footprints, roads, dem, triangulator=key)
    tin = output.snap_to_grid(tin, dem)
    wall, cpu = time.perf_counter() - wall, _cpu() - cpu
    return {"backend": triangulators.BACKENDS[key].label, "seconds": round(wall, 2), "cpu_seconds": round(cpu, 2),
            "triangles": len(tin.triangles), "peak_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
                                                               / 1024, 0),
            "max_edge": round(stats.max_edge, 3), "max_vertical_error": round(stats.max_vertical_error, 3),
            "refinement_passes": stats.refinement_iterations}


def run_tiles_case(key: int, tiles: int) -> dict:
    import shapely

    from benchmarks.bench_tiles import OUT as TILES_OUT
    from benchmarks.bench_tiles import blocks
    from wit_plugin.chain import ChainInputs, ChainOptions
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.sample import SampleConfig, generate_sample
    from wit_plugin.sheetrun.plan import tile_of
    from wit_plugin.sheetrun.runner import run_tiles
    from wit_plugin.terrain import triangulators

    folder = TILES_OUT / "sample"
    if not (folder / "sample_manifest.json").is_file():  # the same sample as bench_tiles.py
        shutil.rmtree(folder, ignore_errors=True)
        generate_sample(folder, SampleConfig(radius_m=1400.0, seed=42, ortho_pixel_size=0.5))
    files = json.loads((folder / "sample_manifest.json").read_text(encoding="utf-8"))["files"]
    inputs = ChainInputs([str(folder / "ortho")], str(folder / files["dem"]), str(folder / files["buildings"]),
                         str(folder / files["roads"]), str(folder / files["districts"]))
    area = shapely.union_all([tile_of(s, "EPSG:5186").polygon for s in blocks(tiles)]).buffer(-0.01)
    out = OUT / "triangulators" / f"tiles{tiles}-{key}"
    shutil.rmtree(out, ignore_errors=True)
    options = ChainOptions(area=None, max_edge=5.0, metrics=False, tiles3d=False, triangulator=key)
    start = time.perf_counter()
    report = run_tiles(inputs, options, out, StudyArea.polygon(area, "EPSG:5186"), scale=1000, workers=2)
    seconds = time.perf_counter() - start
    done = [r for r in report.rows if r["status"] in ("done", "empty")]
    terrain_seconds = sum(json.loads((out / Path(r["gml"]).parent / "steps.json").read_text())["seconds"]["terrain"]
                          for r in done)
    return {"backend": triangulators.BACKENDS[key].label, "seconds": round(seconds, 1),
            "terrain_seconds": round(terrain_seconds, 1), "tiles": len(report.rows), "done": len(done),
            "failed": report.count("failed"), "triangles": sum(r["triangles"] for r in done),
            "peak_mb": max((r["peak_mb"] for r in done), default=0)}


def _child(*args: str) -> dict:
    proc = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True, check=False,
                          cwd=ROOT)
    if proc.returncode:
        raise RuntimeError(f"{args} failed: {proc.stderr[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tiles", type=int, default=16)
    parser.add_argument("--skip-tiles", action="store_true")
    parser.add_argument("--runs", type=int, default=1, help="area runs per backend (the best is kept)")
    args = parser.parse_args()
    results: dict = {"load_average_start": os.getloadavg(), "area": [], "tiles": []}
    for key in (0, 1):
        runs = [_child("--area", str(key)) for _ in range(max(1, args.runs))]
        results["area"].append(min(runs, key=lambda r: r["cpu_seconds"]))
        print(json.dumps(results["area"][-1]), flush=True)
    if not args.skip_tiles:
        for key in (0, 1):
            results["tiles"].append(_child("--tiles", str(key), str(args.tiles)))
            print(json.dumps(results["tiles"][-1]), flush=True)
    results["load_average_end"] = os.getloadavg()
    (OUT / "triangulators.json").write_text(json.dumps(results, indent=1), encoding="utf-8")

    lines = ["| case | triangulator | wall s | CPU s | triangles | peak MB | longest edge m | max DEM error m |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in results["area"]:
        lines.append(f"| 1 km, 5 m edges | {r['backend']} | {r['seconds']} | {r['cpu_seconds']} | "
                     f"{r['triangles']:,} | {r['peak_mb']:.0f} | {r['max_edge']} | {r['max_vertical_error']} |")
    for r in results["tiles"]:
        lines.append(f"| {r['tiles']} tiles (1:1,000), 2 workers | {r['backend']} | {r['seconds']} | "
                     f"terrain steps {r['terrain_seconds']} | {r['triangles']:,} | {r['peak_mb']:.0f} per worker | "
                     f"| |")
    triangle, cdt = results["area"]
    lines.append("")
    lines.append(f"CDT / Triangle on 1 km: CPU time {cdt['cpu_seconds'] / triangle['cpu_seconds']:.2f}× (goal ≤ "
                 f"{GOAL_TIME_RATIO}), wall {cdt['seconds'] / triangle['seconds']:.2f}×, triangles "
                 f"{cdt['triangles'] / triangle['triangles']:.2f}× (goal ≤ {GOAL_COUNT_RATIO:.2f}).")
    if results["tiles"]:
        t, c = results["tiles"]
        lines.append(f"CDT / Triangle on {t['tiles']} tiles: wall {c['seconds'] / t['seconds']:.2f}×, terrain steps "
                     f"{c['terrain_seconds'] / t['terrain_seconds']:.2f}×, triangles "
                     f"{c['triangles'] / t['triangles']:.2f}×.")
    lines.append(f"(load average {results['load_average_start'][0]:.1f} at the start, "
                 f"{results['load_average_end'][0]:.1f} at the end, on {os.cpu_count()} cores)")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--area":
        print(json.dumps(child_area(int(sys.argv[2]))))
    elif len(sys.argv) > 3 and sys.argv[1] == "--tiles":
        print(json.dumps(run_tiles_case(int(sys.argv[2]), int(sys.argv[3]))))
    else:
        sys.exit(main())
