"""A tiled run's CityJSONSeq: each tile writes its own ``model.city.jsonl`` as it finishes, all with the run's one
``transform`` and CRS, and the run writes ``index.city.jsonl``, the header line of the whole run.

The header names the run's extent and each tile's sequence (``metadata.parts``: file, features, extent), so
``cat``-joining the header and the tiles' features gives one valid sequence of the whole run::

    (cat index.city.jsonl; tail -q -n +2 tiles/*/model.city.jsonl) > run.city.jsonl

A tile's image paths start from the run's folder, where the joined sequence goes (``SequencePart.folder``);
ids that tiles share — roads crossing a border, the relief, a legal dong's group — carry the tile's sheet
number (``SequencePart.suffix``), so no id repeats in the joined sequence.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

from shapely.geometry.base import BaseGeometry

from ..infra.io.fileio import atomic_file
from .encoding import Transform, json_text
from .writer import SequencePart, header

RUN_INDEX = "index.city.jsonl"
PART_FILE = "model.city.jsonl"


def run_translate(area: BaseGeometry) -> tuple[float, float, float]:
    """The run's ``translate``: whole metres at the area's lower-left corner, heights from 0."""
    xmin, ymin, _, _ = area.bounds
    return float(math.floor(xmin)), float(math.floor(ymin)), 0.0


def tile_part(sheet: str, translate: list[float] | None, folder: str) -> SequencePart | None:
    """A tile's share of its run's sequence (None when the run writes no CityJSON); ``folder``: the tile's folder
    from the run's."""
    if translate is None:
        return None
    x, y, z = translate
    return SequencePart((x, y, z), f"_{sheet}", folder)


def write_run_index(output: Path, parts: list[tuple[str, str]], srs_name: str,
                    translate: tuple[float, float, float]) -> str:
    """``index.city.jsonl`` of a run: its header line, listing the parts (sheet, sequence file from ``output``)
    that exist, with their extents joined into the run's."""
    listed, lower, upper = [], [math.inf] * 3, [-math.inf] * 3
    for sheet, relative in parts:
        path = output / relative
        if not path.is_file():
            continue
        with open(path, encoding="utf-8") as stream:
            first = json.loads(stream.readline())
            features = sum(1 for line in stream if line.strip())
        extent = first.get("metadata", {}).get("geographicalExtent")
        if extent:
            lower = [min(a, b) for a, b in zip(lower, extent[:3])]
            upper = [max(a, b) for a, b in zip(upper, extent[3:])]
        listed.append({"sheet": sheet, "file": Path(relative).as_posix(), "features": features,
                       "geographicalExtent": extent})
    envelope = tuple(lower + upper) if listed and math.isfinite(lower[0]) else (*translate, *translate)
    start = header(srs_name, envelope, Transform(translate))
    start["metadata"]["parts"] = listed
    target, text = output / RUN_INDEX, json_text({**start, "CityObjects": {}, "vertices": []}) + "\n"
    if not (target.is_file() and target.read_text(encoding="utf-8") == text):  # an update: only where it changed
        with atomic_file(target) as tmp:
            tmp.write_text(text, encoding="utf-8")
    return str(target)


def remove_run_index(output: Path) -> None:
    """An earlier run's ``index.city.jsonl``: its parts are gone once the tiles are built without CityJSON."""
    (output / RUN_INDEX).unlink(missing_ok=True)
