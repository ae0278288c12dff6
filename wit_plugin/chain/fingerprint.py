"""What an output was made from: its fingerprint — the settings, and the inputs as the run reads them, by content.

A rerun into an existing output compares the new fingerprint with the one recorded beside the output
(``build.json``, written last, so a folder without it was never finished) and rebuilds only when they
differ, saying which setting or input did. Inputs are taken by content, never by file time or path: the
features of a vector layer that the run reads (their geometry and every attribute: the LoD1 layer keeps
them all), the DEM cells of the window it reads, the orthoimage sheets it uses (their bytes).

Each input is read once for all the parts of a run (``LayerDigests``, ``DemDigests``, ``OrthoDigests``),
then asked for the digest of a box: a map-sheet run's thousands of tiles are fingerprinted in seconds.
The boxes are never smaller than what a reader takes (``SLACK``, ``DEM_MARGIN_CELLS``): a change there
always shows, a change just outside may rebuild a part needlessly, never the reverse.
"""
from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyproj
import shapely

from ..infra.dem import reprojection
from ..infra.io import jsontext
from ..infra.io.digests import digest, file_digest, raster_window_digest, raw_digest
from ..infra.io.fileio import atomic_file
from ..infra.io.raster_io import open_raster
from ..infra.io.vector_io import VectorLayer, bbox_transformer, non_finite, read_layer, source_bbox
from ..infra.raster_crs import cell_size
from ..infra.version import plugin_version
from ..prepare.vectors import source_ids
from ..terrain import triangulators
from .coverage import OrthoCoverage

BUILD_FILE = "build.json"
SLACK = 1.0
"""m: every box is grown by this much beyond what a reader takes (rounding, reprojected boxes)."""
DEM_MARGIN_CELLS = 8
"""DEM cells around a box: more than any reader takes (``Dem.open``: 4; reprojected: 4 + 2)."""
FEATURE_BYTES = 16
Bounds = tuple[float, float, float, float]


def grown(bounds: Bounds, by: float) -> Bounds:
    return bounds[0] - by, bounds[1] - by, bounds[2] + by, bounds[3] + by


def union_bounds(*boxes: Bounds | None) -> Bounds:
    given = [b for b in boxes if b is not None]
    return (min(b[0] for b in given), min(b[1] for b in given), max(b[2] for b in given), max(b[3] for b in given))


@dataclass
class Fingerprint:
    """The settings (plain values, by name) and one digest per input; ``digest`` sums them up."""

    settings: dict
    inputs: dict[str, str]

    def __post_init__(self):
        self.settings = json.loads(jsontext.dumps(self.settings, sort_keys=True))  # as read back from build.json

    @property
    def digest(self) -> str:
        return digest(jsontext.dumps({"settings": self.settings, "inputs": self.inputs}, sort_keys=True))

    def changes(self, record: dict | None) -> list[str]:
        """What differs from the fingerprint of ``record`` (a ``build.json``): the settings by name, then the
        inputs; empty when nothing does."""
        old_settings, old_inputs = (record or {}).get("settings", {}), (record or {}).get("inputs", {})
        names = sorted(k for k in set(self.settings) | set(old_settings) if self.settings.get(k) != old_settings.get(k))
        return names + [k for k in self.inputs if self.inputs[k] != old_inputs.get(k)] + sorted(
            k for k in old_inputs if k not in self.inputs)

    def as_dict(self) -> dict:
        return {"fingerprint": self.digest, "settings": self.settings, "inputs": self.inputs}


def chain_settings(options) -> dict:
    """Every setting of ``ChainOptions`` that shapes the result, with the plugin's version and the triangulator
    the run uses (the default resolved); the area is an input, the schema cache only a place."""
    backend = triangulators.backend(options.triangulator)
    skip = {"area", "part_layers", "schema_cache", "triangulator", "heights", "cityjson_part"}
    settings = {f.name: getattr(options, f.name) for f in dataclasses.fields(options) if f.name not in skip}
    heights = dataclasses.asdict(dataclasses.replace(options.heights, expression=None))
    settings.update({f"heights.{k}": v for k, v in heights.items() if k != "expression"})
    settings.update(plugin=plugin_version(), triangulator=f"{backend.key} ({backend.label})")
    return settings


def read_record(folder: Path) -> dict | None:
    """The ``build.json`` of ``folder``; None when there is none or it cannot be read (an unfinished build)."""
    try:
        record = json.loads((folder / BUILD_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and "fingerprint" in record else None


def write_record(folder: Path, record: dict) -> None:
    with atomic_file(folder / BUILD_FILE) as tmp:
        tmp.write_text(jsontext.dumps(record, ensure_ascii=False, indent=1, sort_keys=True), encoding="utf-8")


class LayerDigests:
    """The features of a vector layer read once, each with two digests and its box in the layer's CRS.

    ``full``: the geometry and every attribute (with the feature id). ``shape``: the geometry and the id the
    run gives the feature (``vectors.source_ids``) only: all a neighbour takes of a building it does not own
    (its footprint, simplified with its own, a hole in its terrain; ids numbered in the order read).
    """

    def __init__(self, layer: VectorLayer, id_prefix: str = "", id_keys: Sequence[Sequence[str]] | None = None):
        self.crs = layer.crs
        self.header = digest(layer.crs.to_wkt(), repr([dataclasses.astuple(f) for f in layer.fields]),
                             layer.encoding or "")
        ids = source_ids(layer, id_prefix, id_keys) if id_keys else [""] * len(layer)
        wkb = shapely.to_wkb(layer.geoms)
        rows = zip(*(layer.columns[f.name] for f in layer.fields)) if layer.fields else ((),) * len(layer)
        full, shape = [], []
        for i, row in enumerate(rows):
            geometry = (wkb[i] or b"") + int(layer.unclosed_rings[i]).to_bytes(4, "little")
            shape.append(raw_digest(geometry, ids[i])[:FEATURE_BYTES])
            full.append(raw_digest(geometry, ids[i], repr((int(layer.fids[i]), row)))[:FEATURE_BYTES])
        self.full = np.frombuffer(b"".join(full), dtype=np.uint8).reshape(-1, FEATURE_BYTES)
        self.shape = np.frombuffer(b"".join(shape), dtype=np.uint8).reshape(-1, FEATURE_BYTES)
        self.bounds = shapely.bounds(layer.geoms)
        self.everywhere = np.flatnonzero(non_finite(layer.geoms))  # read by every filtered read
        placed = np.flatnonzero(np.isfinite(self.bounds).all(axis=1))
        placed = placed[~np.isin(placed, self.everywhere)]
        self._placed = placed
        self._tree = shapely.STRtree(shapely.box(*self.bounds[placed].T)) if len(placed) else None
        self._transformers: dict[str, tuple] = {}

    def _to(self, target_crs: str) -> tuple[pyproj.Transformer | None, pyproj.Transformer | None]:
        """(target → layer CRS, layer → target CRS), made once (a transformer takes milliseconds to make)."""
        if target_crs not in self._transformers:
            target = pyproj.CRS.from_user_input(target_crs)
            self._transformers[target_crs] = (bbox_transformer(target, self.crs), bbox_transformer(self.crs, target))
        return self._transformers[target_crs]

    @staticmethod
    def layer(path: str, encoding: str | None, bbox: Bounds | None, target_crs: str) -> VectorLayer:
        """The features of ``path`` that a read of ``bbox`` (target CRS; None: all) finds, and more."""
        return read_layer(path, encoding=encoding, bbox=None if bbox is None else grown(bbox, SLACK),
                          bbox_crs=pyproj.CRS.from_user_input(target_crs))

    @classmethod
    def read(cls, path: str, encoding: str | None, bbox: Bounds | None, target_crs: str) -> LayerDigests:
        return cls(cls.layer(path, encoding, bbox, target_crs))

    def select(self, bbox: Bounds | None, target_crs: str) -> np.ndarray:
        """The features (indices, in the layer's order) whose box meets ``bbox`` (target CRS; None: all)."""
        if bbox is None:
            return np.arange(len(self.full))
        box = source_bbox(grown(bbox, SLACK), self._to(target_crs)[0])
        near = self._placed[self._tree.query(shapely.box(*box))] if self._tree is not None else np.empty(0, int)
        return np.sort(np.concatenate([near, self.everywhere]).astype(np.int64))

    def digest(self, selected: np.ndarray, full: np.ndarray | None = None) -> str:
        """The digest of the ``selected`` features, in order: the full digest where ``full`` (a mask over
        ``selected``; None: everywhere), else the shape digest."""
        rows = self.full[selected] if full is None else np.where(full[:, None], self.full[selected],
                                                                  self.shape[selected])
        return digest(self.header, rows.tobytes())

    def target_bounds(self, selected: np.ndarray, target_crs: str) -> Bounds | None:
        """The box (target CRS) of the ``selected`` features' boxes, each corner reprojected; None if none is placed."""
        boxes = self.bounds[selected]
        boxes = boxes[np.isfinite(boxes).all(axis=1)]
        if not len(boxes):
            return None
        x = np.concatenate([boxes[:, 0], boxes[:, 2], boxes[:, 0], boxes[:, 2]])
        y = np.concatenate([boxes[:, 1], boxes[:, 1], boxes[:, 3], boxes[:, 3]])
        to_target = self._to(target_crs)[1]
        if to_target is not None:
            x, y = to_target.transform(x, y)
        return grown((float(np.min(x)), float(np.min(y)), float(np.max(x)), float(np.max(y))), SLACK)


class DemDigests:
    """The DEM's cells under a box (target CRS), as ``Dem.open`` reads them — reprojected DEMs in their own CRS."""

    def __init__(self, path: str, target_crs: str):
        self.path, self.target = path, pyproj.CRS.from_user_input(target_crs)
        ds = open_raster(path, "DEM")
        source = reprojection(path, ds, self.target)
        self.extra = () if source is None else (f"cell {cell_size(ds, source, self.target)}",)
        self.grow = SLACK if source is None else SLACK + DEM_MARGIN_CELLS * cell_size(ds, source, self.target)
        self.to_source = None if source is None else bbox_transformer(self.target, source)

    def digest(self, bounds: Bounds) -> str:
        return raster_window_digest(self.path, source_bbox(grown(bounds, self.grow), self.to_source),
                                    DEM_MARGIN_CELLS, self.extra)


class OrthoDigests:
    """The orthoimage sheets a box needs (their footprints, as the coverage check finds them) by their bytes."""

    def __init__(self, coverage: OrthoCoverage):
        self.sheets = sorted(coverage.used + coverage.unused, key=lambda s: s.path)
        self._tree = shapely.STRtree([s.footprint for s in self.sheets])
        self._files: dict[str, str] = {}

    def digest(self, bounds: Bounds) -> str:
        found = sorted(self._tree.query(shapely.box(*grown(bounds, SLACK)), predicate="intersects"))
        return digest(*(f"{Path(self.sheets[k].path).name} {self._file(self.sheets[k].path)}" for k in found))

    def _file(self, path: str) -> str:
        if path not in self._files:
            self._files[path] = file_digest(path)
        return self._files[path]

