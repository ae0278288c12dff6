"""``python -m wit_plugin.tiles3d LOD1 TIN TEXTURES OUTPUT [--crs EPSG:5186]``: the export in its own process
(the chain runs it beside the CityGML and its checks on the second core); prints the report as JSON."""
from __future__ import annotations

import argparse
import sys
from dataclasses import asdict

from ..infra.step_process import run_step
from .tileset import TilesetConfig, export_tileset


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m wit_plugin.tiles3d", description=__doc__.splitlines()[0])
    parser.add_argument("lod1")
    parser.add_argument("tin")
    parser.add_argument("textures")
    parser.add_argument("output")
    parser.add_argument("--crs", default="EPSG:5186")
    parser.add_argument("--web", action="store_true", help="the web profile (quantized, meshopt-compressed)")
    args = parser.parse_args(argv)
    return run_step(lambda feedback: asdict(export_tileset(
        args.lod1 or None, args.tin or None, args.textures or None, args.output, args.crs, feedback,
        TilesetConfig(web=args.web))))


if __name__ == "__main__":
    sys.exit(main())
