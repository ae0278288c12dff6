"""Benchmark wit:preparevectors on generated road-name-address data (CP949 shapefiles, EPSG:5179).

Cases: the demo's study area (1 km around Suseo station, about 5,000 buildings) and a large one
(``--large`` buildings, default 100,000). Each sample is generated once (cached under
``out/bench/vectors_data``), then each case runs in its own child process started from a parent
that imports nothing heavy, so its peak RSS (``resource.getrusage``) is its own. Prints a table
and writes ``out/bench/vectors.json``. The paper gives no figure for this step alone; its whole
1 km chain takes 15 s (Table 20).

Run: ``.venv/bin/python benchmarks/bench_vectors.py [--large N] [--skip-large]``
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
PAPER_CHAIN_1KM_S = 15.0


def peak_rss_mb() -> float:
    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)


def run_case(name: str, n_buildings: int | None) -> dict:
    """Generate (or reuse) the sample, then time prepare_vectors on it; this process's peak RSS."""
    sys.path.insert(0, str(ROOT))
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.prepare.vectors import PrepareConfig, prepare_vectors
    from wit_plugin.sample import SampleConfig, generate_sample

    config = SampleConfig(n_buildings=n_buildings, with_ortho=False, with_dem=False)
    folder = OUT / "vectors_data" / name
    manifest = folder / "sample_manifest.json"
    start = time.perf_counter()
    if not manifest.exists():
        generate_sample(folder, config)
    half = json.loads(manifest.read_text())["radius_m"]
    buildings, roads, districts = (folder / f"{n}.shp" for n in ("TL_SPBD_BULD", "TL_SPRD_MANAGE", "TL_SCCO_EMD"))
    generate_s = time.perf_counter() - start
    radius = 1000.0 if n_buildings is None else half * 1.5  # the large case: everything generated
    rss_before = peak_rss_mb()
    start = time.perf_counter()
    area = StudyArea.circle(config.center_lon, config.center_lat, radius, "EPSG:4737")
    report = prepare_vectors(buildings, roads, districts, area, OUT / f"vectors_{name}.gpkg", PrepareConfig())
    seconds = time.perf_counter() - start
    stats = {s.layer: s for s in report.stats}
    bld = stats["buildings"]
    return {
        "case": name,
        "radius_m": round(radius, 1),
        "buildings_in": bld.features_in,
        "buildings_out": bld.features_out,
        "building_vertices": [bld.vertices_in, bld.vertices_out],
        "arcs_kept": bld.arcs_kept,
        "roads_out": stats["roads"].features_out,
        "districts_out": stats["districts"].features_out,
        "seconds": round(seconds, 2),
        "buildings_per_s": round(bld.features_in / seconds),
        "generate_s": round(generate_s, 1),
        "rss_after_imports_mb": rss_before,
        "peak_rss_mb": peak_rss_mb(),
    }


def child(*args: str) -> dict:
    """Run this script in a fresh interpreter with ``args``; its last stdout line is JSON."""
    done = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"child {args} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--large", type=int, default=100_000, help="buildings in the large case")
    parser.add_argument("--skip-large", action="store_true")
    parser.add_argument("--case", nargs=2, help=argparse.SUPPRESS)  # internal: name, n_buildings|none
    args = parser.parse_args()
    if args.case:
        name, n = args.case
        print(json.dumps(run_case(name, None if n == "none" else int(n))))
        return
    rows = [child("--case", "suseo_1km", "none")]
    if not args.skip_large:
        rows.append(child("--case", f"n{args.large}", str(args.large)))
    header = (f"{'case':<12}{'buildings':>10}{'out':>8}{'vertices in→out':>20}{'arcs kept':>10}"
              f"{'time s':>9}{'bld/s':>8}{'peak MB':>9}")
    print(header)
    for r in rows:
        v = f"{r['building_vertices'][0]}→{r['building_vertices'][1]}"
        print(f"{r['case']:<12}{r['buildings_in']:>10}{r['buildings_out']:>8}{v:>20}{r['arcs_kept']:>10}"
              f"{r['seconds']:>9}{r['buildings_per_s']:>8}{r['peak_rss_mb']:>9}")
    print(f"paper: whole 1 km chain {PAPER_CHAIN_1KM_S} s (Table 20); no figure for vector preparation alone")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "vectors.json").write_text(json.dumps({"cases": rows, "paper_chain_1km_s": PAPER_CHAIN_1KM_S}, indent=2))


if __name__ == "__main__":
    main()
