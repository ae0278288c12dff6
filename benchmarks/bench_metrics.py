"""Benchmark wit:qualitymetrics on the 1 km sample chain, beside the paper's Tables 17 and 19.

Data (built once, cached under ``out/bench/metrics_data``): the generated sample around Suseo
station (``wit_plugin.sample``, 1 km radius, 0.5 m NGII-style ortho tiles, 5 m DEM) →
wit:georeferencemapsheets (+ footprint index) → wit:mergerasters twice (``overwrite``; ``feather``
with gain) → wit:preparevectors → wit:extrudebuildings → wit:wittexture (roofs, from the feather
mosaic, JPEG, S = 1) → wit:writecitygml (with textures). Each measurement then runs in its own
child process so that its peak RSS (``ru_maxrss``) is its own:

* ``geometry_gml`` / ``geometry_lod1``: ``geometry_metrics`` on the CityGML file / the LoD1 faces;
* ``texture_model``: ``texture_metrics`` on the roof atlases (pixels inside the roof islands);
* ``texture_ortho_footprints``: the feather mosaic inside the footprints (the pixels the atlases copy);
* ``texture_ortho_feather`` / ``texture_ortho_overwrite``: the mosaics over the buildings' box;
* ``seam_overwrite`` / ``seam_feather``: the colour step across the sheet borders;
* ``report``: ``quality_report`` doing all of it and writing CSV, GeoPackage and HTML.

The paper's figures are beside ours; its Table 19 images (Bing Maps, V-World, WIT screenshots of
ten places) are not ours, so those figures are context, not targets. Writes ``out/bench/metrics.json``.

Run: ``.venv/bin/python benchmarks/bench_metrics.py [--radius 1000]``
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
CENTER = (127.1020, 37.4876)  # Suseo station, EPSG:4737


def _setup() -> None:
    sys.path.insert(0, str(ROOT))
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")


def peak_rss_mb() -> float:
    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)


def prepare_data(data: Path, radius: float) -> dict:
    """Run the chain once; later runs reuse every file that exists. Returns the paths and step times."""
    _setup()
    from wit_plugin.buildings import extrude
    from wit_plugin.citygml import writer as citygml
    from wit_plugin.mosaic import georef, merge_rasters
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.prepare.vectors import prepare_vectors
    from wit_plugin.sample import SampleConfig, generate_sample
    from wit_plugin.texture import TextureConfig, texture_model

    data.mkdir(parents=True, exist_ok=True)
    p = {name: str(data / file) for name, file in (
        ("sample", "sample"), ("georef", "georef"), ("footprints", "georef/footprints.gpkg"),
        ("overwrite", "mosaic_overwrite.tif"), ("feather", "mosaic_feather.tif"), ("prepared", "prepared.gpkg"),
        ("lod1", "lod1.gpkg"), ("textures", "textures"), ("gml", "city.gml"))}
    times: dict[str, float] = {}

    def step(name: str, target: str, run) -> None:
        if not Path(target).exists():
            start = time.perf_counter()
            run()
            times[name] = round(time.perf_counter() - start, 2)

    sample = Path(p["sample"])
    step("generate_sample", str(sample / "sample_manifest.json"), lambda: generate_sample(
        sample, SampleConfig(center_lon=CENTER[0], center_lat=CENTER[1], radius_m=radius)))
    tiles = sorted(str(t) for t in (sample / "ortho").glob("*.tif"))

    def georeference() -> None:
        results = georef.georeference_sheets(tiles, p["georef"])
        georef.write_footprint_index(results, p["footprints"])

    step("georeference", p["footprints"], georeference)
    sheets = sorted(str(t) for t in Path(p["georef"]).glob("*.tif"))
    step("merge_overwrite", p["overwrite"], lambda: merge_rasters(sheets, p["overwrite"], mode="overwrite"))
    step("merge_feather", p["feather"], lambda: merge_rasters(sheets, p["feather"], mode="feather"))
    step("prepare_vectors", p["prepared"], lambda: prepare_vectors(
        sample / "TL_SPBD_BULD.shp", None, None, StudyArea.circle(*CENTER, radius, "EPSG:4737"), p["prepared"]))
    step("extrude", p["lod1"], lambda: extrude.extrude_buildings(p["prepared"], sample / "dem_5186.tif", p["lod1"]))
    step("texture", str(Path(p["textures"]) / "texcoords.gpkg"),
         lambda: texture_model(p["feather"], p["lod1"], None, p["textures"], TextureConfig()))
    step("citygml", p["gml"], lambda: citygml.write_citygml(
        citygml.CityGMLInputs(lod1=p["lod1"], textures=p["textures"]), p["gml"], copy_textures=False))
    p["tiles"] = len(sheets)
    return {"paths": p, "prepare_s": times}


def _footprints(paths: dict):
    """The prepared building footprints as one MultiPolygon (what the roof atlases copy)."""
    import numpy as np
    import shapely
    from osgeo import ogr

    from wit_plugin.infra import step_layers

    ds = ogr.Open(paths["prepared"])  # kept referenced: the layer dies with its data source
    wkbs = [bytes(f.GetGeometryRef().ExportToIsoWkb()) for f in ds.GetLayerByName(step_layers.PREPARED_BUILDINGS)]
    return shapely.multipolygons(shapely.get_parts(shapely.from_wkb(np.array(wkbs, dtype=object))))


def run_case(case: str, paths: dict) -> dict:
    """One measurement, in this (child) process."""
    _setup()
    from dataclasses import asdict

    from wit_plugin import metrics

    start = time.perf_counter()
    if case.startswith("geometry"):
        g = metrics.geometry_metrics(paths["gml" if case == "geometry_gml" else "lod1"], paths["prepared"])
        result = {k: v for k, v in asdict(g).items() if k not in ("buildings", "model_only", "source_only", "crs_wkt")}
        result.update(model_only=len(g.model_only), source_only=len(g.source_only))
    elif case == "texture_model":
        t = metrics.texture_metrics(paths["textures"])
        result = {"images": len(t.images), "pixels": t.pixels, "masked": t.masked,
                  "laplacian_variance": t.laplacian_variance, "contrast": t.contrast}
    elif case == "texture_ortho_footprints":
        footprints = _footprints(paths)
        t = metrics.texture_metrics(None, paths["feather"], footprints.bounds, footprints)
        result = {"pixels": t.ortho_inside.pixels, "laplacian_variance": t.ortho_inside.laplacian_variance,
                  "contrast": t.ortho_inside.contrast}
    elif case.startswith("texture_ortho"):
        t = metrics.texture_metrics(None, paths[case.rsplit("_", 1)[1]], _footprints(paths).bounds)
        result = {"pixels": t.ortho.pixels, "laplacian_variance": t.ortho.laplacian_variance,
                  "contrast": t.ortho.contrast}
    elif case.startswith("seam"):
        s = metrics.seam_metrics(paths[case.split("_", 1)[1]], paths["footprints"])
        result = {"step": s.step, "baseline": s.baseline, "excess": s.excess, "pairs": s.pairs, "edges": len(s.edges)}
    else:
        out = OUT / "metrics_report"
        r = metrics.quality_report(str(out / "metrics.csv"), paths["gml"], paths["prepared"], paths["textures"],
                                   paths["feather"], paths["feather"], paths["footprints"],
                                   str(out / "metrics.html"), str(out / "metrics.gpkg"))
        result = {"rows": len(r.rows), "outputs": r.outputs}
    result.update(seconds=round(time.perf_counter() - start, 3), peak_rss_mb=peak_rss_mb())
    return result


CASES = ("geometry_gml", "geometry_lod1", "texture_model", "texture_ortho_footprints", "texture_ortho_feather",
         "texture_ortho_overwrite", "seam_overwrite", "seam_feather", "report")


def _fmt(value) -> str:
    return "" if value is None else f"{value:,.4g}" if isinstance(value, float) else str(value)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radius", type=float, default=1000.0, help="study-area radius in metres")
    parser.add_argument("--case", choices=CASES, help=argparse.SUPPRESS)  # child process
    parser.add_argument("--paths", help=argparse.SUPPRESS)
    parser.add_argument("--prepare", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:
        print(json.dumps(run_case(args.case, json.loads(args.paths))))
        return 0
    if args.prepare:
        print(json.dumps(prepare_data(Path(args.prepare), args.radius)))
        return 0

    def child(*argv: str) -> dict:
        """Run in a fresh interpreter: Linux keeps ru_maxrss across fork + exec, so the parent stays small."""
        run = subprocess.run([sys.executable, __file__, "--radius", str(args.radius), *argv],
                             capture_output=True, text=True, check=False)
        if run.returncode:
            sys.stderr.write(run.stderr)
            raise SystemExit(f"{' '.join(argv[:2])} failed with exit code {run.returncode}")
        return json.loads(run.stdout.strip().splitlines()[-1])

    data = OUT / ("metrics_data" if args.radius == 1000.0 else f"metrics_data_{args.radius:g}")
    prepared = child("--prepare", str(data))
    paths = prepared["paths"]
    cases = {case: child("--case", case, "--paths", json.dumps(paths)) for case in CASES}

    _setup()
    from wit_plugin.metrics import PAPER_TABLE17, PAPER_TABLE19

    g, lap, con = cases["geometry_gml"], PAPER_TABLE19["laplacian_variance"], PAPER_TABLE19["contrast"]
    rows = [
        ("Table 17 coordinate ME (m)", g["coordinate_mean_error"], PAPER_TABLE17["coordinate_mean_error"]),
        ("Table 17 coordinate MaxE (m)", g["coordinate_max_error"], PAPER_TABLE17["coordinate_max_error"]),
        ("Table 17 placement MPE (m)", g["placement_mean_error"], PAPER_TABLE17["placement_mean_error"]),
        ("placement max (m)", g["placement_max_error"], None),
        ("Table 17 SSI mean", g["ssi_mean"], PAPER_TABLE17["ssi_mean"]),
        ("SSI min", g["ssi_min"], None),
        ("Table 19 Laplacian var., model roofs", cases["texture_model"]["laplacian_variance"], lap["WIT"]),
        ("Laplacian var., ortho in footprints", cases["texture_ortho_footprints"]["laplacian_variance"], None),
        ("Laplacian var., ortho (feather)", cases["texture_ortho_feather"]["laplacian_variance"], lap["V-World"]),
        ("Laplacian var., ortho (overwrite)", cases["texture_ortho_overwrite"]["laplacian_variance"], lap["Bing Maps"]),
        ("Table 19 contrast, model roofs", cases["texture_model"]["contrast"], con["WIT"]),
        ("contrast, ortho in footprints", cases["texture_ortho_footprints"]["contrast"], None),
        ("contrast, ortho (feather)", cases["texture_ortho_feather"]["contrast"], con["V-World"]),
        ("contrast, ortho (overwrite)", cases["texture_ortho_overwrite"]["contrast"], con["Bing Maps"]),
        ("seam step overwrite (DN)", cases["seam_overwrite"]["step"], None),
        ("seam step feather+gain (DN)", cases["seam_feather"]["step"], None),
        ("seam excess overwrite (DN)", cases["seam_overwrite"]["excess"], None),
        ("seam excess feather+gain (DN)", cases["seam_feather"]["excess"], None),
    ]
    print(f"Study area: {args.radius:g} m around Suseo station; {g['matched']} buildings matched, "
          f"{paths['tiles']} ortho sheets. Paper column for ortho rows: V-World / Bing Maps figures (context only).")
    print(f"{'measure':40} {'ours':>14} {'paper':>10}")
    for name, ours, paper in rows:
        print(f"{name:40} {_fmt(ours):>14} {_fmt(paper):>10}")
    print(f"\n{'stage':26} {'seconds':>8} {'peak RSS MB':>12}")
    for case, result in cases.items():
        print(f"{case:26} {result['seconds']:8.3f} {result['peak_rss_mb']:12.1f}")
    OUT.mkdir(parents=True, exist_ok=True)
    report = {"radius_m": args.radius, "center_lon_lat": CENTER, "data": paths, "prepare_s": prepared["prepare_s"],
              "paper_table17": PAPER_TABLE17, "paper_table19": PAPER_TABLE19, "cases": cases,
              "comparison": [{"measure": n, "ours": o, "paper": p} for n, o, p in rows]}
    (OUT / "metrics.json").write_text(json.dumps(report, indent=1, ensure_ascii=False), encoding="utf-8")
    print(f"\nWrote {OUT / 'metrics.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
