"""Benchmark wit:wittexture: ~5,000 roofs and a ~100,000-triangle TIN over an 8000 × 8000 ortho.

Generates (and caches under /tmp) a synthetic 0.25 m RGB orthoimage of 8000 × 8000 px (2 km
square, tiled GeoTIFF like wit:mergerasters writes), an LoD1 faces layer of 5,041 buildings
(roof + ground + 4 walls each) and a TIN of 100,352 grid triangles (70 % terrain, 20 % road,
10 % footprint), all in EPSG:5186 in the ``step_layers`` schema. Each configuration then runs
``texture_model`` in its own child process under ``/usr/bin/time``, whose peak RSS is the run's
own (the parent imports nothing heavy); the default configuration also runs through
``qgis_process`` as users run it (QGIS's start-up measured in the same run and subtracted). The
reference, in the same run, is ``gdal_translate`` of the same ortho window to JPEG (read and
encode the pixels once), printed beside each time. ``--work`` adds a kept chain work folder
(``wit:citymodel --KEEP_WORK=true``: the default sample's 592,000-triangle TIN). The paper has
no figure for this step; its Table 10 is the mip chain (full chain to 1 × 1 here) and Table 18
the model size (bytes written here).

Run: ``.venv/bin/python benchmarks/bench_texture.py [out.json] [--only NAME …] [--work DIR] [--no-qgis]``
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import measure  # noqa: E402  (benchmarks/measure.py, on the path set just above)

SIZE, PIXEL = 8000, 0.25
X0, Y0 = 208842.55, 544511.46  # north-west corner of sheet 37709005 (Suseo station)
BUILDINGS_PER_SIDE = 71  # 5,041 buildings
TIN_CELLS = 224  # 224 × 224 cells × 2 = 100,352 triangles
CONFIGS = {
    "S=1 JPEG": {"scale": 1.0},
    "S=0.5 JPEG": {"scale": 0.5},
    "S=1 JPEG + mip files": {"scale": 1.0, "write_mipmaps": True},
    "S=1 PNG": {"scale": 1.0, "image_format": "PNG"},
}


def make_inputs(folder: Path) -> tuple[str, str, str]:
    """Write (or reuse) the ortho, the LoD1 faces and the TIN; return their paths."""
    import numpy as np
    from osgeo import gdal, ogr, osr

    sys.path.insert(0, str(ROOT))
    from wit_plugin.infra import step_layers

    folder.mkdir(parents=True, exist_ok=True)
    ortho, lod1, tin = folder / "ortho.tif", folder / "lod1.gpkg", folder / "tin.gpkg"
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(5186)
    rng = np.random.default_rng(5)
    spacing = SIZE * PIXEL / BUILDINGS_PER_SIDE
    sizes = rng.uniform(6.0, 0.8 * spacing, (BUILDINGS_PER_SIDE ** 2, 2))
    if not ortho.exists():
        tmp = folder / ".ortho.tif"
        ds = gdal.GetDriverByName("GTiff").Create(str(tmp), SIZE, SIZE, 3, gdal.GDT_Byte, [
            "TILED=YES", "BLOCKXSIZE=512", "BLOCKYSIZE=512", "COMPRESS=DEFLATE", "PHOTOMETRIC=RGB"])
        ds.SetGeoTransform((X0, PIXEL, 0, Y0, 0, -PIXEL))
        ds.SetProjection(srs.ExportToWkt())
        for r in range(0, SIZE, 500):
            y, x = np.mgrid[r:r + 500, 0:SIZE].astype(np.float32)
            noise = rng.integers(0, 30, (500, SIZE))
            base = 120 + 40 * np.sin(x / 300.0) * np.cos(y / 420.0)
            xm, ym = (x + 0.5) * PIXEL, (y + 0.5) * PIXEL  # metres east / south of the corner
            bx, by = (xm // spacing).astype(int), (ym // spacing).astype(int)
            w, h = sizes[by * BUILDINGS_PER_SIDE + bx].transpose(2, 0, 1)
            roof = (xm - bx * spacing - 1.0 >= 0) & (xm - bx * spacing - 1.0 < w) \
                & (ym - by * spacing - 1.0 >= 0) & (ym - by * spacing - 1.0 < h)
            base = np.where(roof, 200 - base / 3, base)
            rgb = np.stack([base + noise, 0.9 * base + noise, 0.8 * base + 20 + noise])
            ds.WriteRaster(0, r, SIZE, 500, np.clip(rgb, 0, 255).astype(np.uint8).tobytes())
        ds.BuildOverviews("AVERAGE", [2, 4, 8, 16])
        ds = None
        os.replace(tmp, ortho)
    if not lod1.exists():
        _write_lod1(lod1, srs, sizes, spacing, step_layers, ogr)
    if not tin.exists():
        _write_tin(tin, srs, rng, step_layers, ogr)
    return str(ortho), str(lod1), str(tin)


def _face(ogr, points: list[tuple[float, float, float]]):
    ring = ogr.Geometry(ogr.wkbLinearRing)
    for p in points + points[:1]:
        ring.AddPoint(*p)
    poly = ogr.Geometry(ogr.wkbPolygon25D)
    poly.AddGeometry(ring)
    return poly


def _write_lod1(path: Path, srs, sizes, spacing: float, step_layers, ogr) -> None:
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path) + ".tmp.gpkg")
    layer = ds.CreateLayer(step_layers.LOD1_LAYER, srs, ogr.wkbPolygon25D)
    for name, kind in ((step_layers.WIT_ID, ogr.OFTString), (step_layers.FACE_TYPE, ogr.OFTString),
                       (step_layers.FACE_NUMBER, ogr.OFTInteger)):
        layer.CreateField(ogr.FieldDefn(name, kind))
    layer.StartTransaction()
    for k, (w, h) in enumerate(sizes):
        x = X0 + (k % BUILDINGS_PER_SIDE) * spacing + 1.0
        y = Y0 - (k // BUILDINGS_PER_SIDE) * spacing - 1.0
        corners = [(x, y - h), (x + w, y - h), (x + w, y), (x, y)]
        faces = [("ground", _face(ogr, [(a, b, 30.0) for a, b in corners[::-1]])),
                 ("roof", _face(ogr, [(a, b, 45.0) for a, b in corners]))]
        for (xa, ya), (xb, yb) in zip(corners, corners[1:] + corners[:1]):
            faces.append(("wall", _face(ogr, [(xa, ya, 30.0), (xb, yb, 30.0), (xb, yb, 45.0), (xa, ya, 45.0)])))
        for number, (kind, geom) in enumerate(faces):
            f = ogr.Feature(layer.GetLayerDefn())
            f.SetField(step_layers.WIT_ID, f"BLD_{k:07d}")
            f.SetField(step_layers.FACE_TYPE, kind)
            f.SetField(step_layers.FACE_NUMBER, number)
            f.SetGeometry(geom)
            layer.CreateFeature(f)
    layer.CommitTransaction()
    ds = None
    os.replace(str(path) + ".tmp.gpkg", path)


def _write_tin(path: Path, srs, rng, step_layers, ogr) -> None:
    ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path) + ".tmp.gpkg")
    layer = ds.CreateLayer(step_layers.TIN_LAYER, srs, ogr.wkbPolygon25D)
    for name, kind in ((step_layers.TIN_TRIANGLE_ID, ogr.OFTInteger), (step_layers.TIN_SURFACE, ogr.OFTString),
                       (step_layers.TIN_FEATURE_ID, ogr.OFTString)):
        layer.CreateField(ogr.FieldDefn(name, kind))
    step = SIZE * PIXEL / TIN_CELLS
    kinds = rng.choice(["terrain", "road", "footprint"], size=2 * TIN_CELLS ** 2, p=[0.7, 0.2, 0.1])
    layer.StartTransaction()
    n = 0
    for r in range(TIN_CELLS):
        for c in range(TIN_CELLS):
            a, b = (X0 + c * step, Y0 - r * step), (X0 + (c + 1) * step, Y0 - r * step)
            cc, d = (X0 + (c + 1) * step, Y0 - (r + 1) * step), (X0 + c * step, Y0 - (r + 1) * step)
            for tri in ((a, d, cc), (a, cc, b)):
                f = ogr.Feature(layer.GetLayerDefn())
                f.SetField(step_layers.TIN_TRIANGLE_ID, n)
                f.SetField(step_layers.TIN_SURFACE, str(kinds[n]))
                if kinds[n] == "road":
                    f.SetField(step_layers.TIN_FEATURE_ID, f"RD_{r // 16:03d}")
                f.SetGeometry(_face(ogr, [(x, y, 40.0) for x, y in tri]))
                layer.CreateFeature(f)
                n += 1
    layer.CommitTransaction()
    ds = None
    os.replace(str(path) + ".tmp.gpkg", path)


def _child(args: list[str]) -> None:
    """Child-process entry: run texture_model once, print its report as JSON."""
    sys.path.insert(0, str(ROOT))
    from dataclasses import asdict

    from wit_plugin.texture import TextureConfig, texture_model

    ortho, lod1, tin, out, config = args
    start = time.perf_counter()
    report = asdict(texture_model(ortho, lod1, tin, out, TextureConfig(**json.loads(config))))
    report["seconds_in_call"] = round(time.perf_counter() - start, 2)
    report["images"] = len(report["images"])
    print(json.dumps(report))


def _extent(lod1: str, tin: str) -> tuple[float, float, float, float]:
    """xmin, ymin, xmax, ymax of both layers: the ortho window the step textures."""
    from osgeo import ogr

    boxes = []
    for path in (lod1, tin):
        ds = ogr.Open(path)
        x0, x1, y0, y1 = ds.GetLayer(0).GetExtent()
        boxes.append((x0, y0, x1, y1))
    return (min(b[0] for b in boxes), min(b[1] for b in boxes), max(b[2] for b in boxes), max(b[3] for b in boxes))


def _case(name: str, ortho: str, lod1: str, tin: str, config: dict, qgis: bool) -> dict:
    """One configuration: core in a child process, through qgis_process (default parameters only)
    and the reference, gdal_translate of the same ortho window to JPEG, all in this run."""
    out = Path(tempfile.mkdtemp(prefix="wit_bench_texture_out_"))
    core = measure.run([sys.executable, __file__, "--child", ortho, lod1, tin, str(out / "core"), json.dumps(config)])
    report = json.loads(core.stdout.strip().splitlines()[-1])
    result = {"config": name, **core.as_dict(), "seconds_in_call": report["seconds_in_call"],
              "images": report["images"], "atlases": report["atlases"], "ground_images": report["ground_images"],
              "mip_files": report["mip_files"], "surfaces": report["surfaces"], "untextured": report["untextured"],
              "texel_size_m": report["texel_size"], "texels_per_m2": report["texels_per_m2"],
              "downscaled": report["downscaled"], "output_mb": round(report["bytes_written"] / 1e6, 1)}
    x0, y0, x1, y1 = _extent(lod1, tin)
    ref = measure.run(["gdal_translate", "-q", "-of", "JPEG", "-co", "QUALITY=90", "-projwin", str(x0), str(y1),
                       str(x1), str(y0), ortho, str(out / "reference.jpg")])
    result["reference_gdal_translate"] = ref.as_dict()
    if qgis:
        result["qgis_process"] = measure.through_qgis("wit:wittexture", {"ORTHO": ortho, "LOD1": lod1, "TIN": tin,
                                                                         "OUTPUT": str(out / "qgis")})
    shutil.rmtree(out)
    return result


def _print(r: dict) -> None:
    ref = r["reference_gdal_translate"]["seconds"]
    head = (f"{r['config']:24s} core {r['seconds']:6.1f} s (CPU {r['cpu_seconds']:5.1f}) {r['peak_rss_mb']:5d} MB"
            f" {r['output_mb']:6.1f} MB out {r['images']:3d} images")
    print(measure.table_line(head, r["seconds"], r.get("qgis_process"), f"reference {ref:4.1f} s", ref), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("json", nargs="?", default=str(ROOT / "out" / "bench" / "texture.json"))
    parser.add_argument("--only", nargs="*", help="run only these configuration names")
    parser.add_argument("--work", help="also a kept chain work folder (wit:citymodel KEEP_WORK: ortho.tif, "
                                       "lod1.gpkg, tin.gpkg), e.g. the default sample's")
    parser.add_argument("--no-qgis", action="store_true", help="core only (no qgis_process runs)")
    args = parser.parse_args()
    os.environ.setdefault("PROJ_DATA", "/usr/share/proj")
    data = Path(tempfile.gettempdir()) / "wit_bench_texture"
    start = time.perf_counter()
    subprocess.run([sys.executable, __file__, "--make", str(data)], check=True)
    print(f"inputs ready in {time.perf_counter() - start:.1f} s ({data}); reference: gdal_translate of the same "
          "ortho window to JPEG; qgis_process with wit:wittexture's defaults (S=1 JPEG), its start-up "
          "(a trivial algorithm) measured and subtracted in the same run", flush=True)
    cases = [(name, (str(data / "ortho.tif"), str(data / "lod1.gpkg"), str(data / "tin.gpkg")), config)
             for name, config in CONFIGS.items() if not args.only or name in args.only]
    if args.work:
        work = Path(args.work)  # <model>/work of a kept chain run; the LoD1 and TIN layers are beside it
        cases.append((f"work folder ({work.name})", (str(work / "ortho.tif"), str(work.parent / "lod1.gpkg"),
                                                      str(work.parent / "tin.gpkg")), {}))
    results = []
    for name, (ortho, lod1, tin), config in cases:
        defaults = config in ({}, {"scale": 1.0})  # what qgis_process runs without parameters
        results.append(_case(name, ortho, lod1, tin, config, qgis=defaults and not args.no_qgis))
        _print(results[-1])
    ortho_mb = round(SIZE * SIZE * 3 / 1e6, 1)
    info = {"ortho_px": [SIZE, SIZE], "pixel_m": PIXEL, "ortho_uncompressed_mb": ortho_mb,
            "buildings": BUILDINGS_PER_SIDE ** 2, "tin_triangles": 2 * TIN_CELLS ** 2, "cpus": os.cpu_count(),
            "load_average": os.getloadavg(),
            "paper": "no figure for texturing (Table 10: mip chain to 1x1; Table 18: 796 -> 216 MB model)",
            "results": results}
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(info, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        _child(sys.argv[2:])
    elif len(sys.argv) > 1 and sys.argv[1] == "--make":
        make_inputs(Path(sys.argv[2]))
    else:
        main()
