"""Benchmark wit:validatecitygml beside ``xmllint --stream`` on the same files: time, ratio, peak memory.

Files hold N LoD1 box buildings (closed, outward solids, gml:ids on every polygon and ring) plus
one TIN relief of about N triangles in a single feature, so both the per-member parts and the
parts of one huge feature are exercised; ``--textured`` adds one appearance member with a roof
texture association per building and one TIN association listing every triangle (the huge
appearance member of a real model). ``--file`` measures given files instead.

Each file is measured ``--repeat`` times, alternating ours and ``xmllint --stream --schema`` (the
reference: libxml2 validating the XSD alone, in constant memory), each run in a fresh process whose
peak RSS comes from ``resource.getrusage(RUSAGE_CHILDREN)`` of an intermediate process; the best
time of each is kept, with the CPU seconds of all its threads (ours validates the XSD in a second
thread while the other checks run). Timings on a shared machine are noisy: read the ratio,
measured in the same run, not the seconds.

    python benchmarks/bench_validate.py [--sizes 10000 100000] [--textured] [--repeat 3] [--out out/bench/validate.json]
    python benchmarks/bench_validate.py --file model.gml other.gml   # -> out/bench/validate_files.json
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

HEAD = """<?xml version="1.0" encoding="UTF-8"?>
<core:CityModel gml:id="cm" xmlns:core="http://www.opengis.net/citygml/3.0"
 xmlns:bldg="http://www.opengis.net/citygml/building/3.0" xmlns:con="http://www.opengis.net/citygml/construction/3.0"
 xmlns:dem="http://www.opengis.net/citygml/relief/3.0" xmlns:gen="http://www.opengis.net/citygml/generics/3.0"
 xmlns:app="http://www.opengis.net/citygml/appearance/3.0"
 xmlns:gml="http://www.opengis.net/gml/3.2" xmlns:xlink="http://www.w3.org/1999/xlink">
 <gml:boundedBy><gml:Envelope srsName="EPSG:5186" srsDimension="3"><gml:lowerCorner>{x0} {y0} 0</gml:lowerCorner>
 <gml:upperCorner>{x1} {y1} 100</gml:upperCorner></gml:Envelope></gml:boundedBy>
"""


def _face(fid: str, pts: list[tuple[float, float, float]]) -> str:
    ring = " ".join(f"{x:.3f} {y:.3f} {z:.3f}" for x, y, z in pts + pts[:1])
    return (f'<gml:surfaceMember><gml:Polygon gml:id="{fid}"><gml:exterior><gml:LinearRing gml:id="{fid}_r">'
            f'<gml:posList srsDimension="3">{ring}</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>'
            f'</gml:surfaceMember>\n')


def _building(i: int, x: float, y: float, w: float = 12.0, d: float = 9.0, z: float = 30.0, h: float = 9.0) -> str:
    b = f"b{i}"
    g = [(x, y, z), (x, y + d, z), (x + w, y + d, z), (x + w, y, z)]  # ground seen from below: clockwise from above
    t = [(px, py, z + h) for px, py, _ in g[::-1]]
    walls = [[(g[k][0], g[k][1], z), (g[k - 1][0], g[k - 1][1], z), (g[k - 1][0], g[k - 1][1], z + h),
              (g[k][0], g[k][1], z + h)] for k in range(4)]
    faces = _face(f"{b}_g", g) + _face(f"{b}_t", t) + "".join(_face(f"{b}_w{k}", wall) for k, wall in enumerate(walls))
    return (f'<core:cityObjectMember><bldg:Building gml:id="{b}"><core:genericAttribute><gen:StringAttribute>'
            f'<gen:name>BD_MGT_SN</gen:name><gen:value>1111010100100{i:08d}</gen:value></gen:StringAttribute>'
            f'</core:genericAttribute><core:lod1Solid><gml:Solid gml:id="{b}_s"><gml:exterior><gml:Shell>\n{faces}'
            f'</gml:Shell></gml:exterior></gml:Solid></core:lod1Solid><con:height><con:Height>'
            f'<con:highReference>highestRoofEdge</con:highReference><con:lowReference>lowestGroundPoint</con:lowReference>'
            f'<con:status>measured</con:status><con:value uom="m">{h}</con:value></con:Height></con:height>'
            f'<bldg:storeysAboveGround>3</bldg:storeysAboveGround></bldg:Building></core:cityObjectMember>\n')


def generate(path: Path, n: int, textured: bool = False) -> None:
    """Write a valid file with ``n`` buildings on a grid and a TIN of ~``n`` triangles, streaming.

    ``textured``: plus one appearance member texturing every roof and every triangle from one image.
    """
    side = int(n ** 0.5) + 1
    x0, y0 = 200000.0, 500000.0
    with open(path, "w", encoding="utf-8") as out:
        out.write(HEAD.format(x0=x0, y0=y0, x1=x0 + side * 20, y1=y0 + side * 20))
        for i in range(n):
            out.write(_building(i, x0 + (i % side) * 20 + 4, y0 + (i // side) * 20 + 4))
        out.write('<core:cityObjectMember><dem:ReliefFeature gml:id="relief"><dem:lod>1</dem:lod><dem:reliefComponent>'
                  '<dem:TINRelief gml:id="tin"><dem:lod>1</dem:lod><dem:tin><gml:TriangulatedSurface gml:id="tin_s">'
                  '<gml:patches>\n')
        cells = int((n / 2) ** 0.5) + 1
        step = side * 20 / cells
        for r in range(cells):
            for c in range(cells):
                a = (x0 + c * step, y0 + r * step, 29.0 + (c % 3) * 0.1)
                b = (a[0] + step, a[1], 29.1)
                d = (a[0], a[1] + step, 29.2)
                e = (a[0] + step, a[1] + step, 29.0)
                for k, tri in enumerate(((a, b, e), (a, e, d))):
                    pos = " ".join(f"{x:.3f} {y:.3f} {z:.3f}" for x, y, z in tri + tri[:1])
                    out.write(f'<gml:Triangle><gml:exterior><gml:LinearRing gml:id="t{r}_{c}_{k}"><gml:posList>{pos}'
                              '</gml:posList></gml:LinearRing></gml:exterior></gml:Triangle>\n')
        out.write("</gml:patches></gml:TriangulatedSurface></dem:tin></dem:TINRelief></dem:reliefComponent>"
                  "</dem:ReliefFeature></core:cityObjectMember>\n")
        if textured:
            _appearance(out, path, n, cells)
        out.write("</core:CityModel>\n")


def _appearance(out, path: Path, n: int, cells: int) -> None:
    """One ParameterizedTexture: an association per roof, then one for the TIN listing every triangle."""
    image = path.with_suffix(".jpg")
    image.write_bytes(b"\xff\xd8\xff\xd9")
    out.write('<core:appearanceMember><app:Appearance gml:id="app"><app:theme>ortho</app:theme><app:surfaceData>'
              f'<app:ParameterizedTexture gml:id="tex"><app:imageURI>{image.name}</app:imageURI>'
              '<app:mimeType>image/jpeg</app:mimeType>\n')
    for i in range(n):
        out.write(f'<app:textureParameterization><app:TextureAssociation><app:target>#b{i}_t</app:target>'
                  '<app:textureParameterization><app:TexCoordList><app:textureCoordinates>0.1 0.1 0.1 0.9 0.9 0.9 '
                  f'0.9 0.1 0.1 0.1</app:textureCoordinates><app:ring>#b{i}_t_r</app:ring></app:TexCoordList>'
                  '</app:textureParameterization></app:TextureAssociation></app:textureParameterization>\n')
    triangles = [f"t{r}_{c}_{k}" for r in range(cells) for c in range(cells) for k in (0, 1)]
    out.write('<app:textureParameterization><app:TextureAssociation><app:target>#tin_s</app:target>'
              '<app:textureParameterization><app:TexCoordList>\n')
    out.writelines("<app:textureCoordinates>0 0 1 0 1 1 0 0</app:textureCoordinates>\n" for _ in triangles)
    out.writelines(f"<app:ring>#{t}</app:ring>\n" for t in triangles)
    out.write("</app:TexCoordList></app:textureParameterization></app:TextureAssociation>"
              "</app:textureParameterization></app:ParameterizedTexture></app:surfaceData></app:Appearance>"
              "</core:appearanceMember>\n")


def worker(path: str) -> None:
    """Run one validation in this process (schemas compiled inside the clock, as xmllint's) and print it as JSON."""
    sys.path.insert(0, str(ROOT))
    from wit_plugin.citygml import schemas, validate
    start = time.perf_counter()
    report = validate.validate_files([path], schemas.EMBEDDED_DIR)[0]
    result = {"valid": report.valid, "errors": [i.message for i in report.issues][:5]}
    result["seconds"] = time.perf_counter() - start
    print(json.dumps(result))


def xmllint(path: str) -> None:
    """``xmllint --stream`` with the same schemas, timed in this process (its child's peak RSS is ours to read)."""
    sys.path.insert(0, str(ROOT))
    from wit_plugin.citygml import schemas
    start = time.perf_counter()
    run = subprocess.run(["xmllint", "--stream", "--noout", "--nonet", "--schema",
                          str(schemas.EMBEDDED_DIR / schemas.ENTRY_POINT), path], capture_output=True, text=True,
                         check=False)
    seconds = time.perf_counter() - start
    print(json.dumps({"valid": run.returncode == 0, "errors": run.stderr.splitlines()[-3:], "seconds": seconds}))


def measure(mode: str, path: str) -> None:
    """Run the measurement in a child and add its peak RSS (this process does nothing else)."""
    command = [sys.executable, __file__, "--xmllint" if mode == "xmllint" else "--worker", path]
    run = subprocess.run(command, capture_output=True, text=True, check=True)
    result = json.loads(run.stdout.strip().splitlines()[-1])
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    result["peak_rss_mb"] = usage.ru_maxrss / 1024
    result["cpu_seconds"] = usage.ru_utime + usage.ru_stime  # all threads; includes interpreter start-up
    print(json.dumps(result))


def run_pair(path: Path, repeat: int, row: dict) -> dict:
    """Ours and xmllint --stream, alternated ``repeat`` times; the best time of each and their ratio."""
    mb = path.stat().st_size / 1e6
    best: dict[str, dict] = {}
    for _ in range(repeat):
        for mode in ("ours", "xmllint"):
            run = subprocess.run([sys.executable, __file__, "--measure", mode, str(path)], capture_output=True,
                                 text=True, check=True)
            res = json.loads(run.stdout.strip().splitlines()[-1])
            if mode not in best or res["seconds"] < best[mode]["seconds"]:
                best[mode] = res
    ours, ref = best["ours"], best["xmllint"]
    ratio = ours["seconds"] / ref["seconds"]
    print(f"{path.name:>28} {mb:8.1f} MB  ours {ours['seconds']:7.2f} s (cpu {ours['cpu_seconds']:6.1f})  "
          f"xmllint --stream {ref['seconds']:6.2f} s (cpu {ref['cpu_seconds']:5.1f})  ratio {ratio:5.2f}  "
          f"peak {ours['peak_rss_mb']:6.1f} MB (xmllint {ref['peak_rss_mb']:.0f})  "
          f"valid={ours['valid']}/{ref['valid']}  "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    return {**row, "file_mb": round(mb, 1), "seconds": round(ours["seconds"], 2),
            "xmllint_stream_seconds": round(ref["seconds"], 2), "ratio": round(ratio, 2),
            "cpu_seconds": round(ours["cpu_seconds"], 1), "xmllint_cpu_seconds": round(ref["cpu_seconds"], 1),
            "peak_rss_mb": round(ours["peak_rss_mb"], 1), "xmllint_peak_rss_mb": round(ref["peak_rss_mb"], 1),
            "valid": ours["valid"], "xmllint_valid": ref["valid"], "errors": ours["errors"],
            "load_average": os.getloadavg()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    ap.add_argument("--textured", action="store_true", help="generated files also carry roof and TIN textures")
    ap.add_argument("--file", nargs="+", type=Path, metavar="PATH",
                    help="measure these files instead of generated ones")
    ap.add_argument("--repeat", type=int, default=2, help="alternated runs per file; the best time of each is kept")
    ap.add_argument("--tmp", default="/tmp")
    ap.add_argument("--out", help="JSON results (default out/bench/validate.json, with --file validate_files.json)")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--xmllint", help=argparse.SUPPRESS)
    ap.add_argument("--measure", nargs=2, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        return worker(args.worker)
    if args.xmllint:
        return xmllint(args.xmllint)
    if args.measure:
        return measure(*args.measure)
    rows = []
    if args.file:
        for path in args.file:
            rows.append(run_pair(path, args.repeat, {"file": str(path)}))
    for n in [] if args.file else args.sizes:
        path = Path(args.tmp) / f"wit_bench_{n}{'_textured' if args.textured else ''}.gml"
        start = time.perf_counter()
        generate(path, n, args.textured)
        gen_s = time.perf_counter() - start
        rows.append(run_pair(path, args.repeat,
                             {"buildings": n, "textured": args.textured, "generate_s": round(gen_s, 1)}))
        os.unlink(path)
        path.with_suffix(".jpg").unlink(missing_ok=True)
    out = Path(args.out or ROOT / "out" / "bench" / ("validate_files.json" if args.file else "validate.json"))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(rows, indent=2), encoding="utf-8")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
