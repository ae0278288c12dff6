"""3D Tiles export and the offline viewer beside the paper's rendering optimisation (Table 18), in the
default profile and the web profile (``TilesetConfig.web``: quantized, meshopt-compressed geometry).

The paper reports file size 796 → 216 MB, loading 4.74 → 1.74 s and 48.9 → 55.6 frames per second.
On the sample (default: 1 km around Suseo station, the chain's default 5 m maximum TIN edge):

1. **Data** (not timed, cached under ``out/bench/3dtiles/r<radius>-e<edge>/``): ``wit:generatesample``
   then ``wit:citymodel --KEEP_WORK=true`` through ``scripts/qgis-process``, as a batch user runs them.
2. **Sizes**: the CityGML model (``model.gml`` + its texture folder) and the tileset (everything in it).
3. **Export time and peak memory**, ``--runs`` times, each in its own child process (wall and CPU time
   around the library call, peak RSS = the child's ``VmHWM``), both profiles; the reference measured
   beside it in the same run is the CityGML writer on the same step outputs (also a child, same
   inputs, textures copied). ``--profile``: one more export with CPU-time counters around its
   sub-stages (cProfile first showed where the time goes; its overhead inflates per-row Python work).
4. **Viewer**: each profile's viewer folder served on 127.0.0.1, headless Chromium
   (``viewer/browse.mjs``), the two interleaved: seconds from opening the page until the tileset is
   loaded for the first view (CesiumJS start-up included) and from the tileset request alone, the
   tileset's bytes fetched until then, then frames per second over ``--fps-seconds`` with the scene
   redrawn continuously. No GPU here: WebGL runs on SwiftShader (software, 2 shared cores), so the
   frame rate says little about a desktop with a graphics card.

``--tileset DIR`` measures an existing tileset instead (e.g. a tiled run's output folder, such as the
40 km² district of ``bench_tiles.py --district --tiles3d``): its web profile is made by the same pass
the export runs (``web.compress_tiles``, timed) on a copy, then both are viewed.

Writes ``out/bench/3dtiles-r<radius>.json`` (or ``3dtiles-<name>.json``) and prints a Markdown table.
Usage: ``python benchmarks/bench_3dtiles.py [--radius 1000] [--max-edge 5] [--runs 3] [--fps-seconds 5]
[--profile] [--tileset DIR]``
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
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


#: sub-stages of the export for ``--profile``: (label, module, class or None, function)
STAGES = (("staging: texture table", "store", "Store", "add_textures"),
          ("staging: buildings", "store", "Store", "add_buildings"),
          ("staging: TIN", "store", "Store", "add_triangles"),
          ("leaves: reading their triangles back", "store", "Store", "triangles"),
          ("coarse terrain of the leaves", "tileset", None, "leaf_patch"),
          ("decoding images and their mip chains", "textures", "TextureSet", "level"),
          ("buildings: roofs, walls, atlas copies and mip files", "tileset", "_Writer", "_buildings"),
          ("coordinates to ECEF", "geo", "Georeference", "local"),
          ("regions", "geo", "Georeference", "region"),
          ("glTF primitives", "glb", "GlbBuilder", "triangles"),
          (".glb bytes", "glb", "GlbBuilder", "to_bytes"),
          ("web profile pass", "tileset", None, "compress_tiles"))


def _count_stages() -> dict[str, float]:
    """Wrap the sub-stages' functions with CPU-time counters (a few hundred calls: no measurable
    overhead, unlike a profiler, which inflates per-row Python work); returns the live totals."""
    import functools
    import importlib

    totals: dict[str, float] = {}
    for label, module, owner, name in STAGES:
        target = importlib.import_module(f"wit_plugin.tiles3d.{module}")
        target = getattr(target, owner) if owner else target
        function = getattr(target, name)

        @functools.wraps(function)
        def counted(*args, _function=function, _label=label, **kwargs):
            start = time.process_time()
            try:
                return _function(*args, **kwargs)
            finally:
                totals[_label] = totals.get(_label, 0.0) + time.process_time() - start

        setattr(target, name, counted)
    return totals


def child(kind: str, model: Path, output: Path, profile: bool = False) -> None:
    """One measured case in this process: prints {"seconds", "cpu_seconds", "peak_mb"} (and with
    ``profile`` the CPU seconds per sub-stage) as JSON."""
    sys.path.insert(0, str(ROOT))
    work = model / "work"
    stages = _count_stages() if profile else None
    if kind.startswith("3dtiles"):
        from wit_plugin.tiles3d import TilesetConfig, export_tileset

        def run():
            export_tileset(str(model / "lod1.gpkg"), str(model / "tin.gpkg"), str(work / "textures"), str(output),
                           config=TilesetConfig(web=kind == "3dtiles-web"))
    else:
        from wit_plugin.citygml.writer import CityGMLInputs, write_citygml

        def run():
            write_citygml(CityGMLInputs(lod1=str(model / "lod1.gpkg"), tin=str(model / "tin.gpkg"),
                                        roads=str(work / "prepared.gpkg"), districts=str(work / "prepared.gpkg"),
                                        textures=str(work / "textures")), str(output))
    start, cpu = time.perf_counter(), time.process_time()
    run()
    result = {"seconds": round(time.perf_counter() - start, 3), "cpu_seconds": round(time.process_time() - cpu, 3),
              "peak_mb": _vm_hwm_mb()}
    if stages is not None:
        result["stages"] = {label: round(stages.get(label, 0.0), 2) for label, *_ in STAGES}
    print(json.dumps(result))


def _run_child(kind: str, model: Path, output: Path, profile: bool = False) -> dict:
    result = subprocess.run([sys.executable, __file__, "--child", kind, str(model), str(output)]
                            + (["--profile"] if profile else []), capture_output=True, text=True, cwd=ROOT)
    if result.returncode != 0:
        sys.exit(f"{kind} failed:\n{result.stderr[-3000:]}")
    return json.loads(result.stdout.strip().splitlines()[-1])


def browse(viewer: Path, fps_seconds: float, shot: str = "3dtiles-view.png") -> dict:
    server = subprocess.Popen([sys.executable, str(ROOT / "scripts" / "viewer.py"), "serve", str(viewer),
                               "--port", "0"], stdout=subprocess.PIPE, text=True)
    try:
        url = server.stdout.readline().strip()
        result = subprocess.run(["node", str(ROOT / "viewer" / "browse.mjs"), url, str(OUT / shot),
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


def _viewers(default: Path, web: Path, runs: int, fps_seconds: float) -> dict[str, list[dict]]:
    """Each profile's viewer folder, opened ``runs`` times, the two interleaved (same load on the machine)."""
    views: dict[str, list[dict]] = {"default": [], "web": []}
    folders = {}
    for name, tileset in (("default", default), ("web", web)):
        folders[name] = tileset.parent / f"viewer-{name}"
        subprocess.run([sys.executable, str(ROOT / "scripts" / "viewer.py"), "build", str(tileset), str(folders[name])],
                       check=True, capture_output=True)
    for _ in range(runs):
        for name, rows in views.items():
            report = browse(folders[name], fps_seconds, f"3dtiles-view-{name}.png")
            rows.append({k: report.get(k) for k in ("navigationSeconds", "loadSeconds", "loadedTiles",
                                                           "firstViewBytes", "fps", "webgl")})
    return views


def _tiles_mb(folder: Path) -> float:
    """MB of the tiles' .glb files alone (the textures are the same files in both profiles)."""
    return round(sum(f.stat().st_size for f in folder.rglob("*.glb")) / 1e6, 1)


def _profile_rows(results: dict, views: dict) -> list[str]:
    rows = []
    for name in ("default", "web"):
        v = views[name]
        rows.append(f"| {name} | {results[name + '_mb']} MB ({results[name + '_glb_mb']} MB of .glb) | "
                    f"{_mean([x['firstViewBytes'] / 1e6 for x in v])} MB | "
                    f"{_mean([x['navigationSeconds'] for x in v])} s "
                    f"| {_mean([x['loadSeconds'] for x in v])} s | {v[0]['loadedTiles']} |")
    return rows


def measure_tileset(folder: Path, runs: int, fps_seconds: float) -> int:
    """``--tileset``: an existing tileset and its web profile (made on a copy), both viewed."""
    sys.path[:0] = [str(ROOT), str(ROOT / "scripts")]
    from viewer import NOT_3DTILES
    from wit_plugin.tiles3d.web import compress_tiles

    scratch = OUT / "3dtiles" / f"given-{folder.name}"
    shutil.rmtree(scratch, ignore_errors=True)
    scratch.mkdir(parents=True)
    default, web = scratch / "default", scratch / "web"
    for target in (default, web):  # hard links: the viewer's own copy rule (scripts/viewer.py)
        shutil.copytree(folder, target, copy_function=os.link, ignore=NOT_3DTILES)
    start, cpu = time.perf_counter(), time.process_time()
    for glb in web.rglob("*.glb"):  # unlink first: never write through a hard link into the source
        data = glb.read_bytes()
        glb.unlink()
        glb.write_bytes(data)
    files = compress_tiles(web)
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    views = _viewers(default, web, runs, fps_seconds)
    results = {"tileset": str(folder), "runs": runs, "load_average": os.getloadavg(), "files": files,
               "web_pass_seconds": round(seconds, 1), "web_pass_cpu_seconds": round(cpu, 1),
               "default_mb": _folder_mb(default), "web_mb": _folder_mb(web), "default_glb_mb": _tiles_mb(default),
               "web_glb_mb": _tiles_mb(web), "viewer": views}
    (OUT / f"3dtiles-{folder.name}.json").write_text(json.dumps(results, indent=1), encoding="utf-8")
    print(f"\n{folder}: {files} .glb files, web profile pass {seconds:.1f} s (CPU {cpu:.1f} s), {runs} run(s), "
          f"load average {results['load_average'][0]:.1f}\n")
    print("| profile | size | bytes to first view | page open → first view | tileset → first view | tiles |")
    print("|---|---|---|---|---|---|")
    print("\n".join(_profile_rows(results, views)))
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radius", type=float, default=1000.0)
    parser.add_argument("--max-edge", type=float, default=5.0)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--fps-seconds", type=float, default=5.0)
    parser.add_argument("--profile", action="store_true", help="also the export's CPU seconds per sub-stage")
    parser.add_argument("--tileset", type=Path, help="measure this tileset folder and its web profile instead")
    parser.add_argument("--child", nargs=3, metavar=("KIND", "MODEL", "OUTPUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], Path(args.child[1]), Path(args.child[2]), args.profile)
        return 0
    if args.tileset:
        return measure_tileset(args.tileset, args.runs, args.fps_seconds)
    model = prepare(args.radius, args.max_edge)
    scratch = OUT / "3dtiles" / "scratch"
    scratch.mkdir(parents=True, exist_ok=True)
    runs = {"3dtiles": [], "3dtiles-web": [], "citygml": []}
    outputs = {"3dtiles": scratch / "3dtiles", "3dtiles-web": scratch / "3dtiles-web",
               "citygml": scratch / "gml" / "model.gml"}
    for _ in range(args.runs):  # interleaved, so all see the same load on the shared machine
        for kind, rows in runs.items():
            rows.append(_run_child(kind, model, outputs[kind]))
    stages = _run_child("3dtiles-web", model, scratch / "3dtiles-profiled", profile=True)["stages"] if args.profile \
        else None
    views = _viewers(outputs["3dtiles"], outputs["3dtiles-web"], args.runs, args.fps_seconds)
    gml_mb = round((model / "model.gml").stat().st_size / 1e6 + _folder_mb(model / "model_textures"), 1)
    document = json.loads((outputs["3dtiles"] / "tileset.json").read_text(encoding="utf-8"))
    results = {
        "radius_m": args.radius, "max_edge_m": args.max_edge, "runs": args.runs, "load_average": os.getloadavg(),
        "citygml_mb": gml_mb, "default_mb": _folder_mb(outputs["3dtiles"]),
        "web_mb": _folder_mb(outputs["3dtiles-web"]),
        "default_glb_mb": _tiles_mb(outputs["3dtiles"]), "web_glb_mb": _tiles_mb(outputs["3dtiles-web"]),
        "tiles": len(list(outputs["3dtiles"].rglob("*.glb"))),
        "root_geometric_error": document["root"]["geometricError"],
        "export": runs["3dtiles"], "export_web": runs["3dtiles-web"], "citygml_writer": runs["citygml"],
        "stages": stages, "viewer": views,
    }
    (OUT / f"3dtiles-r{args.radius:g}.json").write_text(json.dumps(results, indent=1), encoding="utf-8")
    seconds = {kind: [r["seconds"] for r in rows] for kind, rows in runs.items()}
    cpu = {kind: [r["cpu_seconds"] for r in rows] for kind, rows in runs.items()}
    print(f"\n3D Tiles on the sample of radius {args.radius:g} m (max TIN edge {args.max_edge:g} m), "
          f"{args.runs} run(s), load average {results['load_average'][0]:.1f}\n")
    print("| measure | paper (before → after) | ours |\n|---|---|---|")
    print(f"| file size | {PAPER['size_mb'][0]} → {PAPER['size_mb'][1]} MB | CityGML {gml_mb} MB (with textures) "
          f"→ 3D Tiles {results['default_mb']} MB ({results['tiles']} tiles) → web profile {results['web_mb']} MB |")
    print(f"| loading | {PAPER['load_s'][0]} → {PAPER['load_s'][1]} s | page open → first view: default "
          f"{_mean([v['navigationSeconds'] for v in views['default']])} s, web "
          f"{_mean([v['navigationSeconds'] for v in views['web']])} s |")
    print(f"| frames per second | {PAPER['fps'][0]} → {PAPER['fps'][1]} | "
          f"{_mean([v['fps'] for v in views['default']])} (software WebGL, SwiftShader, no GPU) |")
    for kind, label in (("3dtiles", "export"), ("3dtiles-web", "export, web profile")):
        print(f"| {label} time (reference: CityGML writer, same inputs) | – | {_mean(seconds[kind])} s vs "
              f"{_mean(seconds['citygml'])} s "
              f"(ratio {statistics.mean(seconds[kind]) / statistics.mean(seconds['citygml']):.2f};"
              f" CPU {_mean(cpu[kind])} s vs {_mean(cpu['citygml'])} s) |")
    print(f"| export peak memory (CityGML writer) | – | {max(r['peak_mb'] for r in runs['3dtiles'])} MB "
          f"({max(r['peak_mb'] for r in runs['citygml'])} MB) |")
    print("\n| profile | size | bytes to first view | page open → first view | tileset → first view | tiles |")
    print("|---|---|---|---|---|---|")
    print("\n".join(_profile_rows(results, views)))
    if stages:
        print("\n| export sub-stage (CPU seconds; they overlap) | seconds |\n|---|---:|")
        print("\n".join(f"| {label} | {value:.2f} |" for label, value in stages.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
