"""Benchmark CityJSON beside CityGML on the same model: size, write time, validation time (and val3dity's verdict).

The model: a kept chain run (``wit:citymodel --KEEP_WORK=true``: its LoD1 and TIN GeoPackages and ``work/``
with the prepared roads and dongs and the textures) — ``--work`` names its output folder; else the default
sample (1 km around Suseo station, the paper's 5 m edge) is generated and run once, cached under
``out/bench/data/cityjson-1km/``. In one process, interleaved (``--runs`` rounds of CityGML writer, CityJSON
writer, CityJSONSeq writer), each write's CPU and wall seconds; then the file sizes (the texture images are
the same files for all, not counted) and both validators on the files written. ``--val3dity PATH`` runs
TU Delft's val3dity (built by hand beside the project, not part of it) on the CityJSON file at its defaults.

Usage: ``python benchmarks/bench_cityjson.py [out.json] [--work DIR] [--runs 2] [--val3dity PATH]``.
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def model_folder(work: str | None) -> Path:
    """A kept chain run: ``work`` or the default sample's, made once."""
    if work:
        return Path(work)
    from wit_plugin.chain import ChainInputs, ChainOptions, run_city_model
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.sample import SampleConfig, generate_sample

    folder = ROOT / "out" / "bench" / "data" / "cityjson-1km"
    model = folder / "model"
    if not (model / "work" / "prepared.gpkg").is_file():
        sample = generate_sample(folder / "sample", SampleConfig())
        area = StudyArea.circle(SampleConfig().center_lon, SampleConfig().center_lat, 1000.0)
        run_city_model(ChainInputs([str(sample.ortho_tiles[0].parent)], str(sample.dem), str(sample.buildings),
                                   str(sample.roads), str(sample.districts)),
                       ChainOptions(area=area, keep_work=True, metrics=False, tiles3d=False), model)
    return model


def timed(function, *args, **kwargs) -> tuple[float, float]:
    cpu, wall = time.process_time(), time.perf_counter()
    function(*args, **kwargs)
    return time.process_time() - cpu, time.perf_counter() - wall


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", nargs="?", default=str(ROOT / "out" / "bench" / "cityjson.json"))
    parser.add_argument("--work", help="output folder of a wit:citymodel run with KEEP_WORK")
    parser.add_argument("--runs", type=int, default=2)
    parser.add_argument("--val3dity", help="the val3dity executable")
    args = parser.parse_args(argv)

    from wit_plugin.citygml.inputs import CityGMLInputs
    from wit_plugin.citygml.schemas import find_schema_dir
    from wit_plugin.citygml.validate import validate_files
    from wit_plugin.citygml.writer import write_citygml
    from wit_plugin.cityjson.validate import validate_cityjson_files
    from wit_plugin.cityjson.writer import write_cityjson

    model = model_folder(args.work)
    prepared = str(model / "work" / "prepared.gpkg")
    inputs = CityGMLInputs(lod1=str(model / "lod1.gpkg"), tin=str(model / "tin.gpkg"), roads=prepared,
                           districts=prepared, textures=str(model / "work" / "textures"))
    scratch = Path(tempfile.mkdtemp(prefix="bench-cityjson-"))
    files = {"CityGML": scratch / "model.gml", "CityJSON": scratch / "model.city.json",
             "CityJSONSeq": scratch / "model.city.jsonl"}
    writers = {"CityGML": write_citygml, "CityJSON": write_cityjson, "CityJSONSeq": write_cityjson}
    seconds: dict[str, list] = {name: [] for name in files}
    try:
        for _ in range(args.runs):
            for name, path in files.items():
                seconds[name].append(timed(writers[name], inputs, str(path)))
        schema_dir, _ = find_schema_dir(None, str(scratch / "cache"), allow_download=False)
        validation = {"CityGML": timed(validate_files, [str(files["CityGML"])], schema_dir),
                      "CityJSON": timed(validate_cityjson_files, [str(files["CityJSON"])]),
                      "CityJSONSeq": timed(validate_cityjson_files, [str(files["CityJSONSeq"])])}
        verdicts = {"CityGML": validate_files([str(files["CityGML"])], schema_dir)[0].valid,
                    "CityJSON": validate_cityjson_files([str(files["CityJSON"])])[0].valid,
                    "CityJSONSeq": validate_cityjson_files([str(files["CityJSONSeq"])])[0].valid}
        result = {"model": str(model), "runs": args.runs, "files": {}}
        for name, path in files.items():
            cpu = [c for c, _ in seconds[name]]
            wall = [w for _, w in seconds[name]]
            result["files"][name] = {"bytes": path.stat().st_size, "write_cpu_s": cpu, "write_wall_s": wall,
                                     "validate_cpu_s": validation[name][0], "validate_wall_s": validation[name][1],
                                     "valid": verdicts[name]}
        if args.val3dity:
            start = time.perf_counter()
            done = subprocess.run([args.val3dity, str(files["CityJSON"])], capture_output=True, text=True)
            summary = re.findall(r"# (valid|invalid):\s+(\d+)", done.stdout)
            result["val3dity"] = {"seconds": round(time.perf_counter() - start, 2), "summary": summary,
                                  "errors": re.findall(r"^\s+(\d{3} -- \w+)", done.stdout, re.M)}
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    Path(args.output).parent.mkdir(parents=True, exist_ok=True)
    Path(args.output).write_text(json.dumps(result, indent=1), encoding="utf-8")
    gml = result["files"]["CityGML"]
    print("| file | MB | of the CityGML | write, CPU s (each run) | write / CityGML's | validate, CPU s | valid |")
    print("|---|---:|---:|---|---:|---:|---|")
    for name, row in result["files"].items():
        print(f"| {name} | {row['bytes'] / 1e6:.1f} | {row['bytes'] / gml['bytes']:.3f} | "
              f"{', '.join(f'{s:.2f}' for s in row['write_cpu_s'])} | "
              f"{min(row['write_cpu_s']) / min(gml['write_cpu_s']):.2f} | {row['validate_cpu_s']:.2f} | "
              f"{row['valid']} |")
    if "val3dity" in result:
        print(f"val3dity: {result['val3dity']}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
