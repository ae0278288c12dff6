"""make demo: the whole chain on the default sample, through qgis_process like a batch user.

Generates the default sample (1 km around Suseo station), then runs every step as its own
`scripts/qgis-process run wit:…` call, each output feeding the next, and prints a summary:
counts, validity, time per step and where the files are. Results go to out/demo/: the model, a
preview picture, the 3D Tiles tileset (3dtiles/) and the offline web viewer (viewer/, `make view`).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = Path(os.environ.get("WIT_DEMO_OUT", ROOT / "out" / "demo"))
QGIS_PROCESS = str(ROOT / "scripts" / "qgis-process")
WIT_DEMO_MAX_EDGE = float(os.environ.get("WIT_DEMO_MAX_EDGE", "15"))


def run(algorithm: str, **parameters) -> tuple[dict, float]:
    """One qgis_process call; exits with its message if the algorithm fails."""
    args = [QGIS_PROCESS, "--json", "run", algorithm]
    for name, value in parameters.items():
        for item in value if isinstance(value, list) else [value]:
            args.append(f"--{name}={item}")
    start = time.perf_counter()
    result = subprocess.run(args, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if result.returncode != 0:
        sys.exit(f"{algorithm} failed:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}")
    return json.loads(result.stdout[result.stdout.index("{"):])["results"], seconds


def main() -> int:
    if OUT.exists():
        shutil.rmtree(OUT)
    OUT.mkdir(parents=True)
    times: dict[str, float] = {}

    def step(label: str, algorithm: str, **parameters) -> dict:
        print(f"== {label} ({algorithm})", flush=True)
        results, times[algorithm] = run(algorithm, **parameters)
        print(f"   {times[algorithm]:.1f} s", flush=True)
        return results

    sample = step("sample data: 1 km around Suseo station", "wit:generatesample",
                  RADIUS=1000, SEED=42, OUTPUT=OUT / "sample")
    chain = {"ORTHO_INPUT": sample["ORTHO_FOLDER"], "DEM": sample["DEM"], "BUILDINGS": sample["BUILDINGS"],
             "ROADS": sample["ROADS"], "DISTRICTS": sample["DISTRICTS"], "RADIUS": 1000, "KEEP_WORK": "true",
             # the paper's 5 m max edge (the algorithm's default) makes ~650k terrain triangles here and a
             # 390 MB CityGML file that takes minutes to validate; 15 m (refined to 0.5 m vertically) keeps
             # the demo to about a minute
             "MAX_EDGE": WIT_DEMO_MAX_EDGE, "CITYJSON": "true",  # model.city.json beside model.gml
             "OUTPUT": OUT / "model"}
    model = step("the whole chain: NGII sheets → CityGML 3.0", "wit:citymodel", **chain)
    work = OUT / "model" / "work"
    print("== preview picture", flush=True)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "wit_plugin.preview", str(OUT / "model" / "lod1.gpkg"),
                    str(OUT / "model" / "tin.gpkg"),
                    str(work / "textures"), str(OUT / "preview.png")], check=True, cwd=ROOT)
    times["preview"] = time.perf_counter() - start
    (OUT / "3dtiles").symlink_to(Path("model") / "3dtiles")  # the chain's tileset, where the viewer expects it
    print("== web viewer (CesiumJS, offline)", flush=True)
    viewer = subprocess.run([sys.executable, str(ROOT / "scripts" / "viewer.py"), "build", str(OUT / "3dtiles"),
                             str(OUT / "viewer")], capture_output=True, text=True, cwd=ROOT)
    if viewer.returncode != 0:
        print(f"   WARNING: no web viewer: {(viewer.stderr or viewer.stdout).strip()}", flush=True)

    print("\nSummary")
    print(f"  buildings generated {sample['BUILDINGS_WRITTEN']}, written to CityGML {model['BUILDINGS_WRITTEN']}")
    print(f"  CityGML 3.0: {model['GML']}")
    print(f"  CityJSON 2.0: {model['CITYJSON_FILE']}")
    print(f"  valid: {model['VALID']} ({model['ERROR_COUNT']} errors) — report {model['VALIDATION_REPORT']}")
    print(f"  metrics: {model['METRICS']}")
    print(f"  preview: {OUT / 'preview.png'}")
    tileset_mb = sum(p.stat().st_size for p in (OUT / "model" / "3dtiles").rglob("*") if p.is_file()) / 1e6
    print(f"  3D Tiles: {model['TILESET']} ({tileset_mb:.1f} MB)")
    if viewer.returncode == 0:
        print(f"  web viewer: {OUT / 'viewer' / 'index.html'} — `make view` serves it on 127.0.0.1")
    print("  seconds per step of the chain (inside wit:citymodel):")
    for name, seconds in json.loads(model["STEP_TIMES"]).items():
        print(f"    {name:14s} {seconds:7.2f}")
    for name, seconds in times.items():
        print(f"  {name:28s} {seconds:6.1f} s wall (qgis_process start-up included)")
    print(f"  results in {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
