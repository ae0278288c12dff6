"""``python -m wit_plugin.tiles3d LOD1 TIN TEXTURES OUTPUT [--crs EPSG:5186]``: the export in its own process
(the chain runs it beside the CityGML and its checks on the second core); prints the report as JSON."""
from __future__ import annotations

import argparse
import sys
from dataclasses import asdict

from ..infra.errors import WitError
from ..infra.feedback import step_process_feedback
from ..infra.io import jsontext
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
    try:
        report = export_tileset(args.lod1 or None, args.tin or None, args.textures or None, args.output, args.crs,
                                step_process_feedback(), TilesetConfig(web=args.web))
    except WitError as exc:
        print(str(exc), file=sys.stderr)
        return 2
    print(jsontext.dumps(asdict(report)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
