"""Benchmark the streaming CityGML 3.0 writer (``wit:writecitygml``): speed and flat memory.

Generates synthetic LoD1 face layers of N box buildings (6 faces each, attributes with Korean
text, like ``wit:extrudebuildings`` writes them) plus a 10 × 10 grid of districts, then writes
CityGML for each N in its own process and reads that process's peak RSS. Constant memory shows
as the same peak for 10k and 100k buildings.

Usage: ``python benchmarks/bench_citygml.py [out.json] [--sizes 10000 100000] [--keep]``.
Inputs are cached under /tmp and reused; the .gml outputs are deleted unless ``--keep``.
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
ORIGIN = (200000.0, 540000.0)  # EPSG:5186 metres, Seoul
SPACING, SIDE = 20.0, 12.0  # building pitch and footprint side (m)
GRID = 10  # districts per side


def make_inputs(folder: Path, n: int) -> tuple[str, str]:
    """(lod1.gpkg, districts.gpkg) for n buildings on a square grid; reused when present."""
    from osgeo import ogr, osr

    from wit_plugin import model

    folder.mkdir(parents=True, exist_ok=True)
    lod1, districts = folder / f"lod1_{n}.gpkg", folder / f"districts_{n}.gpkg"
    cols = int(n ** 0.5) + 1
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    if not lod1.exists():
        tmp = folder / f".lod1_{n}.gpkg"
        ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(tmp))
        layer = ds.CreateLayer(model.LOD1_LAYER, srs, ogr.wkbPolygon25D, ["SPATIAL_INDEX=NO"])
        for name, kind in ((model.WIT_ID, ogr.OFTString), (model.FACE_TYPE, ogr.OFTString),
                           (model.FACE_NUMBER, ogr.OFTInteger), (model.BASE_Z, ogr.OFTReal),
                           (model.HEIGHT, ogr.OFTReal), (model.HEIGHT_SOURCE, ogr.OFTString),
                           (model.STOREYS_ABOVE, ogr.OFTInteger), ("BULD_NM", ogr.OFTString),
                           ("BDTYP_CD", ogr.OFTString)):
            layer.CreateField(ogr.FieldDefn(name, kind))
        defn = layer.GetLayerDefn()
        layer.StartTransaction()
        for i in range(n):
            x0, y0 = ORIGIN[0] + (i % cols) * SPACING, ORIGIN[1] + (i // cols) * SPACING
            x1, y1 = x0 + SIDE, y0 + SIDE
            base, height = 20.0 + (i % 7) * 0.5, 3.0 * (1 + i % 5)
            top = base + height
            square = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
            faces = [("ground", [(x, y, base) for x, y in square[::-1]]), ("roof", [(x, y, top) for x, y in square])]
            faces += [("wall", [(*p, base), (*q, base), (*q, top), (*p, top)])
                      for p, q in zip(square, square[1:] + square[:1])]
            for number, (kind, ring) in enumerate(faces):
                wkt = "POLYGON Z ((" + ", ".join(f"{x} {y} {z}" for x, y, z in ring + ring[:1]) + "))"
                feature = ogr.Feature(defn)
                feature.SetField(model.WIT_ID, f"BLD_{1111010100100000000000000 + i}")
                feature.SetField(model.FACE_TYPE, kind)
                feature.SetField(model.FACE_NUMBER, number)
                feature.SetField(model.BASE_Z, base)
                feature.SetField(model.HEIGHT, height)
                feature.SetField(model.HEIGHT_SOURCE, "floors")
                feature.SetField(model.STOREYS_ABOVE, 1 + i % 5)
                feature.SetField("BULD_NM", f"테스트 건물 {i}")
                feature.SetField("BDTYP_CD", "01001")
                feature.SetGeometry(ogr.CreateGeometryFromWkt(wkt))
                layer.CreateFeature(feature)
        layer.CommitTransaction()
        ds = None
        os.replace(tmp, lod1)
    if not districts.exists():
        ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(districts))
        layer = ds.CreateLayer(model.PREPARED_DISTRICTS, srs, ogr.wkbPolygon)
        for name in (model.WIT_ID, "EMD_KOR_NM"):
            layer.CreateField(ogr.FieldDefn(name, ogr.OFTString))
        step = cols * SPACING / GRID
        for r in range(GRID):
            for c in range(GRID):
                x0, y0 = ORIGIN[0] + c * step, ORIGIN[1] + r * step
                feature = ogr.Feature(layer.GetLayerDefn())
                feature.SetField(model.WIT_ID, f"EMD_{11110100 + r * GRID + c}")
                feature.SetField("EMD_KOR_NM", f"테스트{r * GRID + c}동")
                feature.SetGeometry(ogr.CreateGeometryFromWkt(
                    f"POLYGON (({x0} {y0}, {x0 + step} {y0}, {x0 + step} {y0 + step}, {x0} {y0 + step}, {x0} {y0}))"))
                layer.CreateFeature(feature)
        ds = None
    return str(lod1), str(districts)


def child(lod1: str, districts: str, output: str) -> None:
    """Run in the measured process: print seconds and RSS before/after as JSON."""
    sys.path.insert(0, str(ROOT))
    from wit_plugin.citygml import writer as citygml

    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    start = time.perf_counter()
    report = citygml.write_citygml(citygml.CityGMLInputs(lod1=lod1, districts=districts), output)
    seconds = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(json.dumps({"seconds": seconds, "rss_before_mb": before / 1024, "peak_rss_mb": peak / 1024,
                      "buildings": report.buildings, "faces": report.faces, "groups": report.groups,
                      "gml_mb": os.path.getsize(output) / 2**20}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", default=str(ROOT / "out" / "bench" / "citygml.json"))
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--keep", action="store_true")
    parser.add_argument("--child", nargs=3, metavar=("LOD1", "DISTRICTS", "OUTPUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(*args.child)
        return
    sys.path.insert(0, str(ROOT))
    cache = Path(tempfile.gettempdir()) / "wit-bench-citygml"
    results = []
    for n in args.sizes:
        t0 = time.perf_counter()
        lod1, districts = make_inputs(cache, n)
        generate = time.perf_counter() - t0
        output = cache / f"city_{n}.gml"
        run = subprocess.run([sys.executable, __file__, "--child", lod1, districts, str(output)],
                             capture_output=True, text=True, env={**os.environ, "PROJ_DATA": "/usr/share/proj"})
        if run.returncode:
            sys.exit(run.stderr)
        result = json.loads(run.stdout.strip().splitlines()[-1])
        result.update(n=n, generate_seconds=generate, buildings_per_second=result["buildings"] / result["seconds"],
                      rss_growth_mb=result["peak_rss_mb"] - result["rss_before_mb"])
        results.append(result)
        if not args.keep:
            output.unlink()
    print(f"{'buildings':>10} {'faces':>8} {'seconds':>8} {'bldg/s':>8} {'RSS before':>11} {'peak RSS':>9} "
          f"{'growth':>7} {'GML MB':>7}")
    for r in results:
        print(f"{r['buildings']:>10} {r['faces']:>8} {r['seconds']:>8.1f} {r['buildings_per_second']:>8.0f} "
              f"{r['rss_before_mb']:>9.0f}MB {r['peak_rss_mb']:>7.0f}MB {r['rss_growth_mb']:>5.0f}MB {r['gml_mb']:>7.0f}")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"benchmark": "citygml", "results": results}, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
