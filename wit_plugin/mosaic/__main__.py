"""``python -m wit_plugin.mosaic OUTPUT INPUT... [--mode M] [--[no-]gain] [--extent X0 Y0 X1 Y1] [--compression C]``:
the merge in its own process (the chain runs it beside the terrain on the second core); prints the report as
JSON. GDAL's sidecars are off, as in the step: the inputs are the user's sheets or VRTs pointing at them."""
from __future__ import annotations

import argparse
import sys
from dataclasses import asdict

from ..infra.feedback import Feedback
from ..infra.gdal_env import no_sidecars
from ..infra.step_process import run_step
from . import MODES, merge_rasters
from .output import COMPRESSIONS


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m wit_plugin.mosaic", description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("inputs", nargs="+")
    parser.add_argument("--mode", choices=MODES, default="feather")
    parser.add_argument("--gain", action=argparse.BooleanOptionalAction, default=None,
                        help="tone correction (default: with feather only)")
    parser.add_argument("--extent", nargs=4, type=float, metavar=("XMIN", "YMIN", "XMAX", "YMAX"))
    parser.add_argument("--compression", choices=COMPRESSIONS, default="deflate")
    args = parser.parse_args(argv)
    extent = tuple(args.extent) if args.extent else None

    def merge(feedback: Feedback) -> dict:
        with no_sidecars():
            return asdict(merge_rasters(args.inputs, args.output, mode=args.mode, gain=args.gain, feedback=feedback,
                                        extent=extent, compression=args.compression))

    return run_step(merge)


if __name__ == "__main__":
    sys.exit(main())
