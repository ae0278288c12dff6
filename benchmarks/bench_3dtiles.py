"""3D Tiles export and the offline viewer beside the paper's rendering optimisation (Table 18).

The paper reports file size 796 → 216 MB, loading 4.74 → 1.74 s and 48.9 → 55.6 frames per second.
On the sample (default: 1 km around Suseo station, the chain's default 5 m maximum TIN edge):

1. **Data** (not timed, cached under ``out/bench/3dtiles/r<radius>-e<edge>/``): ``wit:generatesample``
   then ``wit:citymodel --KEEP_WORK=true`` through ``scripts/qgis-process``, as a batch user runs them.
2. **Sizes**: the CityGML model (``model.gml`` + its texture folder) and the tileset (everything in it).
3. **Export time and peak memory**, ``--runs`` times, each in its own child process (time around the
   library call, peak RSS = the child's ``VmHWM``); the reference measured beside it in the same run
   is the CityGML writer on the same step outputs (also a child, same inputs, textures copied).
4. **Viewer**: the viewer folder served on 127.0.0.1, headless Chromium (``viewer/browse.mjs``): seconds
   from opening the page until the tileset is loaded for the first view (CesiumJS start-up
   included) and from the tileset request alone, then frames per second over ``--fps-seconds`` with
   the scene redrawn continuously. No GPU here: WebGL runs on SwiftShader (software, 2 shared
   cores), so the frame rate says little about a desktop with a graphics card.

Writes ``out/bench/3dtiles-r<radius>.json`` and prints a Markdown table.
Usage: ``python benchmarks/bench_3dtiles.py [--radius 1000] [--max-edge 5] [--runs 3] [--fps-seconds 5]``
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out" / "bench"
QGIS_PROCESS = str(ROOT / "scripts" / "qgis-process")
PAPER = {"size_mb": (796, 216), "load_s": (4.74, 1.74), "fps": (48.9, 55.6)}


def _vm_hwm_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return round(int(line.split()[1]) / 1024, 1)
    return float("nan")


def _folder_mb(path: Path) -> float:
    return round(sum(f.stat().st_size for f in path.rglob("*") if f.is_file()) / 1e6, 1)


def _qgis_process(algorithm: str, **parameters) -> dict:
    args = [QGIS_PROCESS, "--json", "run", algorithm] + [f"--{k}={v}" for k, v in parameters.items()]
    result = subprocess.run(args, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"{algorithm} failed:\n{result.stdout[-2000:]}\n{result.stderr[-2000:]}")
    return json.loads(result.stdout[result.stdout.index("{"):])["results"]


def prepare(radius: float, max_edge: float) -> Path:
    """The chain's outputs for the sample (cached): returns the model folder (model.gml, work/)."""
    data = OUT / "3dtiles" / f"r{radius:g}-e{max_edge:g}"
    model = data / "model"
    if not (model / "lod1.gpkg").is_file() or not (model / "model.gml").is_file():
        print(f"preparing the data in {data} (not timed)", flush=True)
        sample = _qgis_process("wit:generatesample", RADIUS=radius, SEED=42, OUTPUT=data / "sample")
        _qgis_process("wit:citymodel", ORTHO_INPUT=sample["ORTHO_FOLDER"], DEM=sample["DEM"],
                      BUILDINGS=sample["BUILDINGS"], ROADS=sample["ROADS"], DISTRICTS=sample["DISTRICTS"],
                      RADIUS=radius, MAX_EDGE=max_edge, KEEP_WORK="true", OUTPUT=model)
    return model


def child(kind: str, model: Path, output: Path) -> None:
    """One measured case in this process: prints {"seconds", "peak_mb"} as JSON."""
    sys.path.insert(0, str(ROOT))
    work = model / "work"
    if kind == "3dtiles":
        from wit_plugin.tiles3d import export_tileset

        start = time.perf_counter()
        export_tileset(str(model / "lod1.gpkg"), str(model / "tin.gpkg"), str(work / "textures"), str(output))
    else:
        from wit_plugin.citygml.writer import CityGMLInputs, write_citygml

        start = time.perf_counter()
        write_citygml(CityGMLInputs(lod1=str(model / "lod1.gpkg"), tin=str(model / "tin.gpkg"),
                                    roads=str(work / "prepared.gpkg"), districts=str(work / "prepared.gpkg"),
                                    textures=str(work / "textures")), str(output))
    print(json.dumps({"seconds": round(time.perf_counter() - start, 3), "peak_mb": _vm_hwm_mb()}))


def _run_child(kind: str, model: Path, output: Path) -> dict:
    result = subprocess.run([sys.executable, __file__, "--child", kind, str(model), str(output)],
                            capture_output=True, text=True, cwd=ROOT)
    if result.returncode != 0:
        sys.exit(f"{kind} failed:\n{result.stderr[-3000:]}")
    return json.loads(result.stdout.strip().splitlines()[-1])


def browse(viewer: Path, fps_seconds: float) -> dict:
    server = subprocess.Popen([sys.executable, str(ROOT / "scripts" / "viewer.py"), "serve", str(viewer), "--port", "0"],
                              stdout=subprocess.PIPE, text=True)
    try:
        url = server.stdout.readline().strip()
        result = subprocess.run(["node", str(ROOT / "viewer" / "browse.mjs"), url, str(OUT / "3dtiles-view.png"),
                                 "--fps", str(fps_seconds), "--timeout", "600"], capture_output=True, text=True)
    finally:
        server.terminate()
        server.wait(timeout=10)
    report = json.loads(result.stdout)
    if not report.get("loaded"):
        sys.exit(f"the viewer did not load the tileset: {json.dumps(report)[:2000]}")
    return report


def _mean(values: list[float]) -> str:
    if len(values) == 1:
        return f"{values[0]:.2f}"
    return f"{statistics.mean(values):.2f} ± {statistics.stdev(values):.2f}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radius", type=float, default=1000.0)
    parser.add_argument("--max-edge", type=float, default=5.0)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--fps-seconds", type=float, default=5.0)
    parser.add_argument("--child", nargs=3, metavar=("KIND", "MODEL", "OUTPUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], Path(args.child[1]), Path(args.child[2]))
        return 0
    model = prepare(args.radius, args.max_edge)
    scratch = OUT / "3dtiles" / "scratch"
    scratch.mkdir(parents=True, exist_ok=True)
    runs = {"3dtiles": [], "citygml": []}
    for _ in range(args.runs):  # interleaved, so both see the same load on the shared machine
        runs["3dtiles"].append(_run_child("3dtiles", model, scratch / "3dtiles"))
        runs["citygml"].append(_run_child("citygml", model, scratch / "gml" / "model.gml"))
    viewer = scratch / "viewer"
    subprocess.run([sys.executable, str(ROOT / "scripts" / "viewer.py"), "build", str(scratch / "3dtiles"),
                    str(viewer)], check=True, capture_output=True)
    views = [browse(viewer, args.fps_seconds) for _ in range(args.runs)]
    gml_mb = round((model / "model.gml").stat().st_size / 1e6 + _folder_mb(model / "model_textures"), 1)
    tiles_mb = _folder_mb(scratch / "3dtiles")
    document = json.loads((scratch / "3dtiles" / "tileset.json").read_text(encoding="utf-8"))
    results = {
        "radius_m": args.radius, "max_edge_m": args.max_edge, "runs": args.runs, "load_average": os.getloadavg(),
        "citygml_mb": gml_mb, "tileset_mb": tiles_mb, "tiles": len(list((scratch / "3dtiles").rglob("*.glb"))),
        "root_geometric_error": document["root"]["geometricError"],
        "export": runs["3dtiles"], "citygml_writer": runs["citygml"],
        "viewer": [{k: v[k] for k in ("navigationSeconds", "loadSeconds", "loadedTiles", "fps", "webgl")} for v in views],
    }
    (OUT / f"3dtiles-r{args.radius:g}.json").write_text(json.dumps(results, indent=1), encoding="utf-8")
    export_s = [r["seconds"] for r in runs["3dtiles"]]
    writer_s = [r["seconds"] for r in runs["citygml"]]
    print(f"\n3D Tiles on the sample of radius {args.radius:g} m (max TIN edge {args.max_edge:g} m), "
          f"{args.runs} run(s), load average {results['load_average'][0]:.1f}\n")
    print("| measure | paper (before → after) | ours |\n|---|---|---|")
    print(f"| file size | {PAPER['size_mb'][0]} → {PAPER['size_mb'][1]} MB | CityGML {gml_mb} MB (with textures) "
          f"→ 3D Tiles {tiles_mb} MB ({results['tiles']} tiles) |")
    print(f"| loading | {PAPER['load_s'][0]} → {PAPER['load_s'][1]} s | page open → first view loaded "
          f"{_mean([v['navigationSeconds'] for v in views])} s; tileset alone "
          f"{_mean([v['loadSeconds'] for v in views])} s |")
    print(f"| frames per second | {PAPER['fps'][0]} → {PAPER['fps'][1]} | {_mean([v['fps'] for v in views])} "
          f"(software WebGL, SwiftShader, no GPU) |")
    print(f"| export time (reference: CityGML writer, same inputs) | – | {_mean(export_s)} s vs {_mean(writer_s)} s "
          f"(ratio {statistics.mean(export_s) / statistics.mean(writer_s):.2f}) |")
    print(f"| export peak memory (CityGML writer) | – | {max(r['peak_mb'] for r in runs['3dtiles'])} MB "
          f"({max(r['peak_mb'] for r in runs['citygml'])} MB) |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
