"""The whole chain as users run it: ``scripts/qgis-process run wit:citymodel`` on the default sample
(1 km around Suseo, the paper's 5 m edge), beside the same chain in plain Python (the core's
``run_city_model``) and beside ``xmllint --stream --noout --schema citygml3-all.xsd`` on the same
output file, measured in the same run so the machine's load cancels out of the ratios.

    .venv/bin/python benchmarks/bench_chain.py [--radius 1000] [--max-edge 5] [--runs 1] [--no-core]

Prints the seconds per step (steps.json), the whole chain (as the chain times itself, and the wall time of the
qgis_process command), the xmllint time and the ratios (the project's goals: the chain ≤ 20 s wall through
qgis_process; validation ≤ 1.5 × xmllint; chain ≤ 3 × xmllint); writes out/bench/chain.json.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out" / "bench" / "chain"
XSD = ROOT / "wit_plugin" / "citygml" / "xsd" / "citygml3-all.xsd"
sys.path.insert(0, str(ROOT))


def sample(radius: float) -> dict:
    folder = OUT / f"sample-r{radius:g}"
    if not (folder / "sample_manifest.json").is_file():
        from wit_plugin.sample import SampleConfig, generate_sample

        print(f"generating the sample in {folder} (not timed)", flush=True)
        shutil.rmtree(folder, ignore_errors=True)
        generate_sample(folder, SampleConfig(radius_m=radius, seed=42))
    files = json.loads((folder / "sample_manifest.json").read_text(encoding="utf-8"))["files"]
    return {"ORTHO_INPUT": str(folder / "ortho"), "DEM": str(folder / files["dem"]),
            "BUILDINGS": str(folder / files["buildings"]), "ROADS": str(folder / files["roads"]),
            "DISTRICTS": str(folder / files["districts"])}


def xmllint_seconds(gml: str) -> float:
    start = time.perf_counter()
    result = subprocess.run(["xmllint", "--stream", "--noout", "--schema", str(XSD), gml], capture_output=True,
                            text=True)
    seconds = time.perf_counter() - start
    if result.returncode != 0:
        raise SystemExit(f"xmllint rejects {gml}: {result.stderr[-1000:]}")
    return seconds


def through_qgis_process(inputs: dict, radius: float, max_edge: float, output: Path) -> dict:
    """``qgis_process run wit:citymodel`` as users run it: the checkout's set-up (``scripts/setup.sh``, which
    ``scripts/qgis-process`` runs first) is run before the clock starts."""
    subprocess.run(["bash", str(ROOT / "scripts" / "setup.sh")], check=True, capture_output=True)
    env = dict(os.environ, WIT_SKIP_SETUP="1")
    args = [str(ROOT / "scripts" / "qgis-process"), "--json", "run", "wit:citymodel"]
    for name, value in {**inputs, "RADIUS": radius, "MAX_EDGE": max_edge, "OUTPUT": output}.items():
        args.append(f"--{name}={value}")
    shutil.rmtree(output, ignore_errors=True)
    start = time.perf_counter()
    result = subprocess.run(args, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - start
    if result.returncode != 0:
        raise SystemExit(f"wit:citymodel failed:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}")
    recorded = json.loads((output / "steps.json").read_text(encoding="utf-8"))
    return {"wall": round(wall, 2), "steps": recorded["seconds"], "chain": recorded["wall"],
            "gml": str(output / "model.gml")}


def in_python(inputs: dict, radius: float, max_edge: float, output: Path) -> dict:
    from wit_plugin.chain import ChainInputs, ChainOptions, run_city_model
    from wit_plugin.prepare.area import StudyArea

    shutil.rmtree(output, ignore_errors=True)
    start = time.perf_counter()
    report = run_city_model(ChainInputs([inputs["ORTHO_INPUT"]], inputs["DEM"], inputs["BUILDINGS"], inputs["ROADS"],
                                        inputs["DISTRICTS"]),
                            ChainOptions(area=StudyArea.circle(127.1020, 37.4876, radius), max_edge=max_edge), output)
    return {"wall": round(time.perf_counter() - start, 2), "steps": report.seconds, "chain": report.wall_seconds,
            "gml": report.gml}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radius", type=float, default=1000.0)
    parser.add_argument("--max-edge", type=float, default=5.0)
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--no-core", action="store_true", help="only the qgis_process path")
    args = parser.parse_args()
    inputs = sample(args.radius)
    runs = []
    for _ in range(args.runs):
        user = through_qgis_process(inputs, args.radius, args.max_edge, OUT / "qgis")
        user["xmllint"] = round(xmllint_seconds(user["gml"]), 2)
        core = None if args.no_core else in_python(inputs, args.radius, args.max_edge, OUT / "core")
        if core:
            core["xmllint"] = round(xmllint_seconds(core["gml"]), 2)
        runs.append({"qgis_process": user, "core": core, "model_mb": round(Path(user["gml"]).stat().st_size / 1e6, 1)})
        print(json.dumps(runs[-1]), flush=True)
    last = runs[-1]
    user, core = last["qgis_process"], last["core"]
    print(f"\nwit:citymodel, {args.radius:g} m, max edge {args.max_edge:g} m, model {last['model_mb']} MB")
    print("| step | qgis_process (s) | plain Python (s) |\n|---|---:|---:|")
    for step, seconds in user["steps"].items():
        print(f"| {step} | {seconds:.2f} | {core['steps'].get(step, float('nan')) if core else float('nan'):.2f} |")
    print(f"| **whole chain** | **{user['chain']:.1f}** (wall {user['wall']:.1f} with start-up) | "
          f"{core['chain'] if core else float('nan'):.1f} |")
    print(f"| xmllint --stream on the same file | {user['xmllint']:.2f} | "
          f"{core['xmllint'] if core else float('nan'):.2f} |")
    print(f"| validation / xmllint | {user['steps']['validate'] / user['xmllint']:.2f} (goal ≤ 1.5) | |")
    print(f"| whole chain / xmllint | {user['chain'] / user['xmllint']:.1f} (goal ≤ 3) | |")
    print(f"| qgis_process wall ≤ 20 s | {'met' if user['wall'] <= 20 else 'not met'} ({user['wall']:.1f} s) | |")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT.parent / "chain.json").write_text(json.dumps(runs, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
