"""What the generated facades cost: the texture step and the 3D Tiles export, and the CityGML and tileset sizes,
with wall textures ``none`` beside ``generated`` (``TextureConfig.facades``) on the same step outputs.

Data (not timed, cached): the 1 km / 5 m sample's chain outputs, as ``bench_3dtiles.py`` prepares them
(``wit:generatesample`` then ``wit:citymodel --KEEP_WORK=true`` through ``scripts/qgis-process``). Each
measured call runs in its own child process (wall and CPU seconds around the library call, peak RSS), the
two settings interleaved, ``--runs`` times each: the texture step (``texture_model``), then on its output the
CityGML writer (size of ``model.gml`` and its textures) and the 3D Tiles export (time and size of the
tileset). Goals (issue 27): texture + export time at most +25 %, CityGML and tileset at most +15 %.

``--district``: instead, the 40 km² district of ``bench_tiles.py --district`` (its sample, generated once and
shared) run in map-sheet tiles on 2 workers with 3D Tiles, once with facades none and once generated: the runs'
wall seconds and the CityGML (with textures) and 3D Tiles (tiles and groups) of all tiles.

Writes ``out/bench/facades.json`` and prints a Markdown table.
Usage: ``python benchmarks/bench_facades.py [--radius 1000] [--max-edge 5] [--runs 3] [--district]``
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))
OUT = ROOT / "out" / "bench" / "facades"
SETTINGS = ("none", "generated")


def _mb(path: Path) -> float:
    return round(sum(f.stat().st_size for f in Path(path).rglob("*") if f.is_file()) / 1e6, 2)


def child(kind: str, facades: str, model: Path) -> dict:
    """One measured call (in this child process): texture, citygml or 3dtiles for ``facades``."""
    from wit_plugin.citygml.writer import CityGMLInputs, write_citygml
    from wit_plugin.texture import TextureConfig, texture_model
    from wit_plugin.tiles3d import export_tileset

    work, out = model / "work", OUT / facades
    textures = out / "textures"
    cpu, wall = time.process_time(), time.perf_counter()
    if kind == "texture":
        texture_model(str(work / "ortho.tif"), str(model / "lod1.gpkg"), str(model / "tin.gpkg"), str(textures),
                      TextureConfig(facades=facades))
        size = _mb(textures)
    elif kind == "citygml":
        prepared = str(work / "prepared.gpkg")
        write_citygml(CityGMLInputs(str(model / "lod1.gpkg"), str(model / "tin.gpkg"), prepared, prepared,
                                    str(textures)), str(out / "gml" / "model.gml"))
        size = _mb(out / "gml")
    else:
        export_tileset(str(model / "lod1.gpkg"), str(model / "tin.gpkg"), str(textures), str(out / "3dtiles"))
        size = _mb(out / "3dtiles")
    return {"kind": kind, "facades": facades, "cpu_s": round(time.process_time() - cpu, 3),
            "wall_s": round(time.perf_counter() - wall, 3), "mb": size,
            "peak_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)}


def _run_child(kind: str, facades: str, model: Path) -> dict:
    import shutil

    target = {"texture": "textures", "citygml": "gml", "3dtiles": "3dtiles"}[kind]
    shutil.rmtree(OUT / facades / target, ignore_errors=True)
    (OUT / facades).mkdir(parents=True, exist_ok=True)
    result = subprocess.run([sys.executable, __file__, "--child", kind, facades, str(model)], capture_output=True,
                            text=True, env={**os.environ, "PYTHONPATH": f"{ROOT}:{os.environ.get('PYTHONPATH', '')}"})
    if result.returncode:
        sys.exit(f"{kind} {facades} failed:\n{result.stderr[-3000:]}")
    return json.loads(result.stdout.strip().splitlines()[-1])


def measure(model: Path, runs: int) -> dict:
    rows: dict[tuple[str, str], list[dict]] = {}
    for _ in range(runs):
        for facades in SETTINGS:  # interleaved: the same load for both
            for kind in ("texture", "citygml", "3dtiles"):
                rows.setdefault((kind, facades), []).append(_run_child(kind, facades, model))
    table = {}
    for (kind, facades), found in rows.items():
        table[f"{kind}/{facades}"] = {key: statistics.median(r[key] for r in found)
                                      for key in ("cpu_s", "wall_s", "mb", "peak_mb")}
    return table


def district(workers: int = 2) -> dict:
    """The district run with each setting (a fresh output folder each): wall seconds and sizes."""
    import shutil

    from bench_tiles import OUT as TILES_OUT

    from wit_plugin.chain import ChainInputs, ChainOptions
    from wit_plugin.sample import SampleConfig, generate_sample
    from wit_plugin.sheetrun.runner import run_tiles

    folder = TILES_OUT / "district"  # bench_tiles.py --district's sample: the same data
    if not (folder / "sample_manifest.json").is_file():
        shutil.rmtree(folder, ignore_errors=True)
        generate_sample(folder, SampleConfig(radius_m=3162.0, seed=7, ortho_pixel_size=1.0))
    files = json.loads((folder / "sample_manifest.json").read_text(encoding="utf-8"))["files"]
    inputs = ChainInputs([str(folder / "ortho")], str(folder / files["dem"]), str(folder / files["buildings"]),
                         str(folder / files["roads"]), str(folder / files["districts"]))
    result = {}
    for facades in SETTINGS:
        out = OUT / f"district-{facades}"
        shutil.rmtree(out, ignore_errors=True)
        start = time.perf_counter()
        report = run_tiles(inputs, ChainOptions(area=None, metrics=False, tiles3d=True, facades=facades), out, None,
                           scale=1000, workers=workers)
        tiles = [t for t in (out / "tiles").iterdir() if t.is_dir()]
        result[facades] = {"seconds": round(time.perf_counter() - start, 1), "tiles": len(report.rows),
                           "buildings": report.buildings,
                           "citygml_mb": round(sum(_mb(t) - _mb(t / "3dtiles") for t in tiles), 1),
                           "tiles3d_mb": round(sum(_mb(t / "3dtiles") for t in tiles)
                                               + _mb(out / "3dtiles-groups"), 1)}
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radius", type=float, default=1000.0)
    parser.add_argument("--max-edge", type=float, default=5.0)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--district", action="store_true", help="the 40 km² district in tiles, both settings")
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(args.child[0], args.child[1], Path(args.child[2]))))
        return 0
    if args.district:
        result = district()
        result["load_average"] = os.getloadavg()
        lines = ["| 40 km² district, 2 workers | none | generated | cost |", "|---|---:|---:|---:|"]
        for key, label in (("seconds", "run, wall s"), ("citygml_mb", "CityGML MB"), ("tiles3d_mb", "3D Tiles MB")):
            a, b = result["none"][key], result["generated"][key]
            lines.append(f"| {label} | {a} | {b} | {100 * (b / a - 1):+.1f} % |")
    else:
        from bench_3dtiles import prepare

        model = prepare(args.radius, args.max_edge)
        result = measure(model, args.runs)
        result["load_average"] = os.getloadavg()
        lines = ["| 1 km / 5 m sample (median of runs) | none | generated | cost |", "|---|---:|---:|---:|"]
        for kind, key, unit in (("texture", "cpu_s", "CPU s"), ("3dtiles", "cpu_s", "CPU s"),
                                ("texture", "wall_s", "wall s"), ("3dtiles", "wall_s", "wall s"),
                                ("citygml", "mb", "MB"), ("3dtiles", "mb", "MB"), ("texture", "mb", "MB")):
            a, b = result[f"{kind}/none"][key], result[f"{kind}/generated"][key]
            lines.append(f"| {kind} {unit} | {a} | {b} | {100 * (b / a - 1):+.1f} % |")
        both = {s: sum(result[f"{k}/{s}"]["cpu_s"] for k in ("texture", "3dtiles")) for s in SETTINGS}
        lines.append(f"| texture + export CPU s | {both['none']:.2f} | {both['generated']:.2f} | "
                     f"{100 * (both['generated'] / both['none'] - 1):+.1f} % |")
    OUT.mkdir(parents=True, exist_ok=True)
    name = "facades-district.json" if args.district else "facades.json"
    (OUT.parent / name).write_text(json.dumps(result, indent=1), encoding="utf-8")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
