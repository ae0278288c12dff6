"""``python -m wit_plugin.metrics OUTPUT_CSV [--model LOD1 --buildings PREPARED] [--textures DIR] [--ortho TIF]
[--mosaic TIF --footprints GPKG] [--html HTML] [--images-when-told]``: the quality metrics in their own process
(the chain starts them beside the texture step and tells them, a line on standard input, when the texture images
are written); prints the written files as JSON."""
from __future__ import annotations

import argparse
import sys

from ..infra.errors import InputError
from ..infra.step_process import run_step
from .report import quality_report


def _wait_until_told() -> None:
    """Wait for the line saying the texture folder is written; the input's end without it: the chain stopped."""
    if not sys.stdin.readline():
        raise InputError("The texture images were never written (the run stopped): nothing was measured.")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m wit_plugin.metrics", description=__doc__.splitlines()[0])
    parser.add_argument("output_csv")
    parser.add_argument("--model", help="the LoD1 faces GeoPackage (or a CityGML file)")
    parser.add_argument("--buildings", help="the prepared source buildings (file|layername=...)")
    parser.add_argument("--textures", help="the texture folder")
    parser.add_argument("--ortho", help="the orthoimage the textures were cut from")
    parser.add_argument("--mosaic", help="the merged orthoimage, for the seam step")
    parser.add_argument("--footprints", help="the sheets' footprints, for the seam step")
    parser.add_argument("--html", help="the HTML report")
    parser.add_argument("--images-when-told", action="store_true",
                        help="measure all else first, then wait for a line on standard input before reading the "
                             "texture images")
    args = parser.parse_args(argv)
    return run_step(lambda feedback: quality_report(
        args.output_csv, model_source=args.model, source_buildings=args.buildings, textures=args.textures,
        ortho=args.ortho, mosaic=args.mosaic, footprints=args.footprints, output_html=args.html,
        feedback=feedback, images_ready=_wait_until_told if args.images_when_told else None).outputs)


if __name__ == "__main__":
    sys.exit(main())
