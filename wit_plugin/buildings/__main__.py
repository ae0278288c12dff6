"""``python -m wit_plugin.buildings BUILDINGS DEM OUTPUT [--height-field F] [--expression-column C]
[--expression-text T] [--storey-height M] [--default-height M] [--spatial-index]``: the LoD1 solids in their own
process (the chain runs them beside the terrain, which they do not read); prints the report as JSON."""
from __future__ import annotations

import argparse
import sys

from ..infra.step_process import run_step
from .extrude import extrude_buildings
from .heights import HeightOptions


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m wit_plugin.buildings", description=__doc__.splitlines()[0])
    parser.add_argument("buildings")
    parser.add_argument("dem")
    parser.add_argument("output")
    parser.add_argument("--height-field")
    parser.add_argument("--expression-column", help="a field holding the heights a QGIS expression gave")
    parser.add_argument("--expression-text", help="that expression, as the report names it")
    parser.add_argument("--storey-height", type=float, default=HeightOptions.storey_height)
    parser.add_argument("--default-height", type=float, default=HeightOptions.default_height)
    parser.add_argument("--spatial-index", action="store_true")
    args = parser.parse_args(argv)
    heights = HeightOptions(height_field=args.height_field, expression_text=args.expression_text,
                            expression_column=args.expression_column, storey_height=args.storey_height,
                            default_height=args.default_height)
    return run_step(lambda feedback: extrude_buildings(args.buildings, args.dem, args.output, heights,
                                                       spatial_index=args.spatial_index, feedback=feedback).as_dict())


if __name__ == "__main__":
    sys.exit(main())
