"""Benchmark the streaming CityGML 3.0 writer (``wit:writecitygml``): speed and flat memory.

Generates synthetic LoD1 face layers of N box buildings (6 faces each, attributes with Korean
text, like ``wit:extrudebuildings`` writes them) plus a 10 × 10 grid of districts, then writes
CityGML for each N in its own process and reads that process's peak RSS. Constant memory shows
as the same peak for 10k and 100k buildings. Each case also runs through ``qgis_process`` as
users run it (QGIS's start-up measured in the same run and subtracted; the file must come out
byte-identical), and beside both times the references measured in the same run on the written
file: ``xmllint --stream --noout`` (a C reader parsing it once, no schema) and a plain read.
``--work`` adds a kept chain work folder (``wit:citymodel --KEEP_WORK=true``: the default
sample's TIN, roads and textures, a 353 MB model).

Usage: ``python benchmarks/bench_citygml.py [out.json] [--sizes 10000 100000] [--work DIR] [--no-qgis] [--keep]``.
Inputs are cached under /tmp and reused; the .gml outputs are deleted unless ``--keep``.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import measure  # noqa: E402  (benchmarks/measure.py, on the path set just above)

ORIGIN = (200000.0, 540000.0)  # EPSG:5186 metres, Seoul
SPACING, SIDE = 20.0, 12.0  # building pitch and footprint side (m)
GRID = 10  # districts per side


def make_inputs(folder: Path, n: int) -> tuple[str, str]:
    """(lod1.gpkg, districts.gpkg) for n buildings on a square grid; reused when present."""
    from osgeo import ogr, osr

    from wit_plugin.infra import step_layers

    folder.mkdir(parents=True, exist_ok=True)
    lod1, districts = folder / f"lod1_{n}.gpkg", folder / f"districts_{n}.gpkg"
    cols = int(n ** 0.5) + 1
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    if not lod1.exists():
        tmp = folder / f".lod1_{n}.gpkg"
        ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(tmp))
        layer = ds.CreateLayer(step_layers.LOD1_LAYER, srs, ogr.wkbPolygon25D, ["SPATIAL_INDEX=NO"])
        for name, kind in ((step_layers.WIT_ID, ogr.OFTString), (step_layers.FACE_TYPE, ogr.OFTString),
                           (step_layers.FACE_NUMBER, ogr.OFTInteger), (step_layers.BASE_Z, ogr.OFTReal),
                           (step_layers.HEIGHT, ogr.OFTReal), (step_layers.HEIGHT_SOURCE, ogr.OFTString),
                           (step_layers.STOREYS_ABOVE, ogr.OFTInteger), ("BULD_NM", ogr.OFTString),
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
                feature.SetField(step_layers.WIT_ID, f"BLD_{1111010100100000000000000 + i}")
                feature.SetField(step_layers.FACE_TYPE, kind)
                feature.SetField(step_layers.FACE_NUMBER, number)
                feature.SetField(step_layers.BASE_Z, base)
                feature.SetField(step_layers.HEIGHT, height)
                feature.SetField(step_layers.HEIGHT_SOURCE, "floors")
                feature.SetField(step_layers.STOREYS_ABOVE, 1 + i % 5)
                feature.SetField("BULD_NM", f"테스트 건물 {i}")
                feature.SetField("BDTYP_CD", "01001")
                feature.SetGeometry(ogr.CreateGeometryFromWkt(wkt))
                layer.CreateFeature(feature)
        layer.CommitTransaction()
        ds = None
        os.replace(tmp, lod1)
    if not districts.exists():
        ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(districts))
        layer = ds.CreateLayer(step_layers.PREPARED_DISTRICTS, srs, ogr.wkbPolygon)
        for name in (step_layers.WIT_ID, "EMD_KOR_NM"):
            layer.CreateField(ogr.FieldDefn(name, ogr.OFTString))
        step = cols * SPACING / GRID
        for r in range(GRID):
            for c in range(GRID):
                x0, y0 = ORIGIN[0] + c * step, ORIGIN[1] + r * step
                feature = ogr.Feature(layer.GetLayerDefn())
                feature.SetField(step_layers.WIT_ID, f"EMD_{11110100 + r * GRID + c}")
                feature.SetField("EMD_KOR_NM", f"테스트{r * GRID + c}동")
                feature.SetGeometry(ogr.CreateGeometryFromWkt(
                    f"POLYGON (({x0} {y0}, {x0 + step} {y0}, {x0 + step} {y0 + step}, {x0} {y0 + step}, {x0} {y0}))"))
                layer.CreateFeature(feature)
        ds = None
    return str(lod1), str(districts)


def child(output: str, inputs: str) -> None:
    """Run in the measured process: print seconds and RSS before/after as JSON."""
    sys.path.insert(0, str(ROOT))
    from wit_plugin.citygml import writer as citygml

    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    start = time.perf_counter()
    report = citygml.write_citygml(citygml.CityGMLInputs(**json.loads(inputs)), output)
    seconds = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(json.dumps({"seconds_in_call": seconds, "rss_before_mb": before / 1024, "peak_rss_mb": peak / 1024,
                      "buildings": report.buildings, "faces": report.faces, "triangles": report.triangles,
                      "textured_surfaces": report.textured_surfaces, "groups": report.groups,
                      "gml_mb": os.path.getsize(output) / 2**20}))


def _qgis_parameters(inputs: dict, output: Path) -> dict[str, str]:
    """wit:writecitygml's parameters for the same inputs (prepared layers named as the chain names them)."""
    from wit_plugin.infra import step_layers

    layers = {"LOD1": inputs["lod1"], "TIN": inputs.get("tin"),
              "ROADS": inputs.get("roads") and f"{inputs['roads']}|layername={step_layers.PREPARED_ROADS}",
              "DISTRICTS": inputs.get("districts")
              and f"{inputs['districts']}|layername={step_layers.PREPARED_DISTRICTS}",
              "TEXTURES": inputs.get("textures")}
    return {**{k: v for k, v in layers.items() if v}, "OUTPUT": str(output)}


def _case(name: str, inputs: dict, output: Path, qgis: bool) -> dict:
    """Core in a child process, through qgis_process, and the references on the written file, in this run."""
    run = measure.run([sys.executable, __file__, "--child", str(output), json.dumps(inputs)],
                      env={"PROJ_DATA": "/usr/share/proj"})
    result = {"case": name, **json.loads(run.stdout.strip().splitlines()[-1]), "core": run.as_dict()}
    result["rss_growth_mb"] = result["peak_rss_mb"] - result["rss_before_mb"]
    result["reference_xmllint_stream"] = measure.run(["xmllint", "--stream", "--noout", str(output)]).as_dict()
    result["reference_read"] = measure.run(["dd", f"if={output}", "of=/dev/null", "bs=1M", "status=none"]).as_dict()
    if qgis:
        copy = output.parent / "qgis" / output.name  # same name: same texture folder name in the image URIs
        copy.parent.mkdir(exist_ok=True)
        result["qgis_process"] = measure.through_qgis("wit:writecitygml", _qgis_parameters(inputs, copy))
        result["qgis_process"]["same_bytes"] = copy.read_bytes() == output.read_bytes()
        shutil.rmtree(copy.with_name(f"{copy.stem}_textures"), ignore_errors=True)
        copy.unlink()
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", default=str(ROOT / "out" / "bench" / "citygml.json"))
    parser.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--work", help="also a kept chain work folder (wit:citymodel KEEP_WORK: lod1.gpkg, tin.gpkg, "
                                       "prepared.gpkg, textures/), e.g. the default sample's")
    parser.add_argument("--no-qgis", action="store_true", help="core only (no qgis_process runs)")
    parser.add_argument("--keep", action="store_true")
    parser.add_argument("--child", nargs=2, metavar=("OUTPUT", "INPUTS_JSON"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(*args.child)
        return
    sys.path.insert(0, str(ROOT))
    cache = Path(tempfile.gettempdir()) / "wit-bench-citygml"
    cases = []
    for n in args.sizes:
        t0 = time.perf_counter()
        lod1, districts = make_inputs(cache, n)
        print(f"{n} buildings: inputs ready in {time.perf_counter() - t0:.1f} s", flush=True)
        cases.append((f"{n} buildings", {"lod1": lod1, "districts": districts}, cache / f"city_{n}.gml"))
    if args.work:
        work = Path(args.work)  # <model>/work of a kept chain run; the LoD1 and TIN layers are beside it
        cases.append((f"work folder ({work.name})", {"lod1": str(work.parent / "lod1.gpkg"),
                                                      "tin": str(work.parent / "tin.gpkg"),
                       "roads": str(work / "prepared.gpkg"), "districts": str(work / "prepared.gpkg"),
                       "textures": str(work / "textures")}, cache / "city_work.gml"))
    print("reference: xmllint --stream --noout (no schema) and a plain read (dd) of the written file; "
          "qgis_process: its start-up (a trivial algorithm) measured and subtracted in the same run", flush=True)
    results = []
    for name, inputs, output in cases:
        r = _case(name, inputs, output, qgis=not args.no_qgis)
        results.append(r)
        ref = r["reference_xmllint_stream"]["seconds"]
        head = (f"{name:24s} {r['gml_mb']:6.0f} MB GML | core {r['core']['seconds']:5.1f} s (CPU "
                f"{r['core']['cpu_seconds']:5.1f}), peak {r['peak_rss_mb']:4.0f} MB (+{r['rss_growth_mb']:3.0f})")
        line = measure.table_line(head, r["core"]["seconds"], r.get("qgis_process"),
                                  f"xmllint --stream {ref:4.1f} s, read {r['reference_read']['seconds']:4.2f} s", ref)
        print(line, flush=True)
        if not args.keep:
            output.unlink()
            shutil.rmtree(output.with_name(f"{output.stem}_textures"), ignore_errors=True)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"benchmark": "citygml", "load_average": os.getloadavg(),
                                          "results": results}, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
