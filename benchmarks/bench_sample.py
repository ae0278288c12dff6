"""Benchmark wit:generatesample drawing from given layers, beside the synthetic city over the same area.

Given layers: the real Gangnam road centre lines (``../shared``, TL_SPRD_MANAGE 2019) and, as the
building layer, the synthetic city's footprints (there is no open building layer for Gangnam):
4,789 footprints around Suseo station, and 1,300 around the centre of 역삼동 for the legal-dong case.
Cases: a 500 m and a 1 km circle around Suseo (2 sheets each), and the whole of 역삼동 (3.4 km²);
the reference is the synthetic mode (its own vectors, DEM and tiles) for a square of the same
half-side. All at 0.5 m pixels with the DEM. Every case runs in its own child process (its own
peak RSS); the layers are made first, not timed.

Run: ``.venv/bin/python benchmarks/bench_sample.py [--pixel 0.5] [--runs 1]``
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
JUSO = ROOT.parent / "shared" / "data" / "juso_gangnam_11680_2019"
SUSEO = (127.1020, 37.4876)


def peak_rss_mb() -> float:
    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)


def _core():
    sys.path.insert(0, str(ROOT))
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")


def make_layers(folder: str) -> dict:
    """Synthetic footprints around Suseo (1 km) and 1,300 around the centre of 역삼동 (not timed)."""
    _core()
    import shapely
    from pyproj import Transformer

    from wit_plugin.infra.io.vector_io import read_layer
    from wit_plugin.sample import SampleConfig, generate_sample

    districts = read_layer(JUSO / "TL_SCCO_EMD.shp")
    dong = districts.geoms[districts.columns["EMD_KOR_NM"].index("역삼동")]
    lon, lat = Transformer.from_crs(districts.crs, "EPSG:4737", always_xy=True).transform(
        *shapely.get_coordinates(shapely.point_on_surface(dong))[0])
    suseo = generate_sample(Path(folder) / "suseo", SampleConfig(radius_m=1000.0, with_ortho=False, with_dem=False))
    yeoksam = generate_sample(Path(folder) / "yeoksam", SampleConfig(center_lon=lon, center_lat=lat, n_buildings=1300,
                                                                     with_ortho=False, with_dem=False))
    return {"suseo": [str(suseo.buildings), suseo.counts["buildings"]],
            "yeoksam": [str(yeoksam.buildings), yeoksam.counts["buildings"]], "dong_km2": round(dong.area / 1e6, 2)}


def run_case(case: str, out: str, pixel: float, layers: dict) -> dict:
    """One case in this process: seconds, tiles, buildings and roads drawn, peak RSS."""
    _core()
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.sample import GivenLayers, SampleConfig, draw_from_layers, generate_sample

    kind, size = case.split("-")
    config = SampleConfig(ortho_pixel_size=pixel)
    rss_before = peak_rss_mb()
    start = time.perf_counter()
    if kind == "synthetic":
        result = generate_sample(out, SampleConfig(radius_m=float(size), ortho_pixel_size=pixel))
        counts = {"buildings": result.counts["buildings"], "roads": result.counts["roads"],
                  "tiles": len(result.ortho_tiles)}
    else:
        if size == "yeoksam":
            given = GivenLayers(buildings=layers["yeoksam"][0], roads=str(JUSO / "TL_SPRD_MANAGE.shp"),
                                districts=str(JUSO / "TL_SCCO_EMD.shp"), area=StudyArea.from_district_code("역삼동"))
        else:
            given = GivenLayers(buildings=layers["suseo"][0], roads=str(JUSO / "TL_SPRD_MANAGE.shp"),
                                area=StudyArea.circle(*SUSEO, float(size)))
        result = draw_from_layers(out, given, config)
        counts = result.counts
    seconds = time.perf_counter() - start
    megapixels = sum(os.path.getsize(t) for t in result.ortho_tiles) / 3 / 1e6
    return {"case": case, "seconds": round(seconds, 2), **counts, "megapixels": round(megapixels, 1),
            "rss_after_imports_mb": rss_before, "peak_rss_mb": peak_rss_mb()}


def child(*args: str) -> dict:
    """Run this script in a fresh interpreter with ``args``; its last stdout line is JSON."""
    out = subprocess.run([sys.executable, __file__, *args], check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


CASES = ("synthetic-500", "drawn-500", "synthetic-1000", "drawn-1000", "drawn-yeoksam")
#: the printed table: (key, title, alignment, width, format)
COLUMNS = (("case", "case", "<", 16, ""), ("seconds", "time s", ">", 8, ".1f"), ("tiles", "tiles", ">", 7, ""),
           ("megapixels", "Mpx", ">", 7, ".0f"), ("buildings", "buildings", ">", 11, ""),
           ("roads", "roads", ">", 7, ""), ("peak_rss_mb", "peak RSS MB", ">", 13, ".0f"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pixel", type=float, default=0.5)
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--layers", metavar="FOLDER", help=argparse.SUPPRESS)
    parser.add_argument("--run", nargs=3, metavar=("CASE", "OUTPUT", "LAYERS_JSON"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.layers:
        print(json.dumps(make_layers(args.layers)))
        return
    if args.run:
        print(json.dumps(run_case(args.run[0], args.run[1], args.pixel, json.loads(args.run[2]))))
        return

    with tempfile.TemporaryDirectory(prefix="wit-bench-sample-") as tmp:
        layers = child("--layers", str(Path(tmp) / "layers"))
        rows = [child("--run", case, str(Path(tmp) / f"{case}-{k}"), json.dumps(layers), "--pixel", str(args.pixel))
                for k in range(args.runs) for case in CASES]
    report = {"benchmark": "generatesample from given layers", "pixel_m": args.pixel, "layers": layers,
              "cpus": os.cpu_count(), "load_average": os.getloadavg(), "paper": None, "runs": rows}
    print(f"pixel {args.pixel} m; building layers: {layers['suseo'][1]} footprints around Suseo, "
          f"{layers['yeoksam'][1]} in 역삼동 ({layers['dong_km2']} km²); roads: real TL_SPRD_MANAGE (paper: no figure)")
    print("".join(f"{title:{align}{width}}" for _, title, align, width, _ in COLUMNS))
    for r in rows:
        print("".join(f"{r[key]:{align}{width}{spec}}" for key, _, align, width, spec in COLUMNS))
    print(json.dumps(report, indent=2, ensure_ascii=False))


if __name__ == "__main__":
    main()
