"""Read any OGR vector source into shapely arrays and write GeoPackage layers and tables.

Text comes in whatever encoding the source has: shapefiles are opened with the encoding
``encoding.shapefile_encoding`` decides (GDAL's ``ENCODING`` open option), and text GDAL hands
over undecoded is decoded here. Everything written is UTF-8 (GeoPackage).
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj
import shapely
from osgeo import gdal, ogr, osr

from ..errors import InputError
from ..feedback import SILENT, Feedback
from ..gdal_env import quiet_gdal
from . import bulk_read
from .encoding import decode_text, gdal_encoding, python_codec, shapefile_encoding
from .fileio import vector_file_problem
from .layersource import LayerSource

# Expected fields of the road-name-address layers (paper Tables 2–4, with the names the real
# files use where they differ: BUL_ENG_NM, EQB_MAN_SN, NTFC_DE, EMD_CD). Missing ones are reported.
BUILDING_FIELDS = ("BD_MGT_SN", "BUL_MAN_NO", "SIG_CD", "RN_CD", "RDS_MAN_NO", "BSI_INT_SN", "EQB_MAN_SN",
                   "BULD_SE_CD", "BULD_MNNM", "BUL_ENG_NM", "BULD_NM_DC", "BDTYP_CD", "BUL_DPN_SE",
                   "POS_BUL_NM", "EMD_CD", "GRO_FLO_CO", "UND_FLO_CO")


ROAD_FIELDS = ("SIG_CD", "RDS_MAN_NO", "RN", "RN_CD", "ENG_RN", "NTFC_DE", "WDR_RD_CD", "ROA_CLS_SE",
               "RDS_DPN_SE", "RBP_CN", "REP_CN", "ROAD_BT", "ROAD_LT", "BSI_INT", "OPERT_DE")


DISTRICT_FIELDS = ("EMD_CD", "EMD_ENG_NM", "EMD_KOR_NM")


@dataclass(frozen=True)
class FieldDef:
    """An attribute column as OGR defines it, so the output keeps the source types."""

    name: str
    type: int
    subtype: int = ogr.OFSTNone
    width: int = 0
    precision: int = 0


def create_fields(layer: ogr.Layer, fields: Sequence[FieldDef]) -> None:
    """Add ``fields`` to a new OGR layer with their types, subtypes, widths and precisions."""
    for fd in fields:
        defn = ogr.FieldDefn(fd.name, fd.type)
        defn.SetSubType(fd.subtype)
        defn.SetWidth(fd.width)
        defn.SetPrecision(fd.precision)
        layer.CreateField(defn)


@dataclass
class VectorLayer:
    """A layer in memory: one shapely geometry (or None) and one attribute row per feature."""

    path: str
    name: str
    geoms: np.ndarray
    fids: np.ndarray
    fields: list[FieldDef]
    columns: dict[str, list]
    crs: pyproj.CRS
    encoding: str | None = None
    unclosed_rings: np.ndarray = field(default_factory=lambda: np.zeros(0, int))  # per feature

    def __len__(self) -> int:
        return len(self.geoms)

    def take(self, index: Sequence[int] | np.ndarray) -> VectorLayer:
        """The features at ``index`` (in that order), sharing field definitions."""
        index = np.asarray(index, dtype=int)
        return VectorLayer(self.path, self.name, self.geoms[index], self.fids[index], self.fields,
                           {k: [v[i] for i in index] for k, v in self.columns.items()}, self.crs,
                           self.encoding, self.unclosed_rings[index])

    def field_map(self, expected: Sequence[str], feedback: Feedback = SILENT) -> dict[str, str]:
        """Map expected field names to this layer's (case-insensitive); warn about missing ones."""
        by_upper = {f.name.upper(): f.name for f in self.fields}
        found = {name: by_upper[name] for name in expected if name in by_upper}
        missing = [name for name in expected if name not in found]
        if missing:
            feedback.warning(f"{self.name}: fields not found (defaults used where needed): {', '.join(missing)}")
        return found


def keep_source_fields(source: Sequence[FieldDef], own: Sequence[str], layer: str,
                       feedback: Feedback = SILENT) -> list[tuple[FieldDef, str]]:
    """(output field, source name) for every source field: none is lost or shadows a derived one.

    A source field whose name clashes with one the core derives (GeoPackage names are
    case-insensitive) is kept as ``<name>_src`` (``_src2``… if that is taken too), with a warning.
    """
    taken = {name.lower() for name in own} | {f.name.lower() for f in source}
    kept, renamed = [], []
    for f in source:
        name = f.name
        if name.lower() in {o.lower() for o in own}:
            suffix, n = "_src", 1
            while (name + suffix).lower() in taken:
                n += 1
                suffix = f"_src{n}"
            name += suffix
            taken.add(name.lower())
            renamed.append(f"{f.name} → {name}")
        kept.append((FieldDef(name, f.type, f.subtype, f.width, f.precision), f.name))
    if renamed:
        feedback.warning(f"{layer}: source fields renamed so they do not clash with the derived ones: "
                         f"{', '.join(renamed)}.")
    return kept


def _crs_of(lyr: ogr.Layer, path: str, crs: str | None) -> pyproj.CRS:
    """The layer's CRS (from its .prj / metadata), else the given one; no usable CRS is an input error."""
    srs = lyr.GetSpatialRef()
    if srs is not None:
        try:
            return pyproj.CRS.from_wkt(srs.ExportToWkt())
        except pyproj.exceptions.CRSError:
            if not crs:
                raise InputError(f"{path}: cannot understand its coordinate reference system; "
                                 "give the source CRS explicitly (e.g. EPSG:5179).") from None
    if not crs:
        raise InputError(f"{path} has no coordinate reference system (no .prj file); "
                         "give the source CRS explicitly (e.g. EPSG:5179 for road-name-address data).")
    try:
        return pyproj.CRS.from_user_input(crs)
    except pyproj.exceptions.CRSError as exc:
        raise InputError(f"Unknown source CRS {crs!r}: {exc}") from exc


def open_layer(path: str | os.PathLike | LayerSource, layer: str | None = None, encoding: str | None = None,
               feedback: Feedback = SILENT, preferred: str | None = None) -> tuple[gdal.Dataset, ogr.Layer, str | None]:
    """Open a vector source with the right text encoding; return the dataset (keep it alive), layer, encoding.

    ``path`` may be a QGIS-style source, ``file.gpkg|layername=buildings`` (or ``|layerid=1``).
    Without a layer named, a file's only layer is taken; a file with several takes ``preferred``
    (the name the step that writes such files gives it) if it has it, else its first layer when no
    name is preferred. Shapefiles with non-ASCII text are always opened with an explicit encoding
    (``shapefile_encoding``).
    """
    source = LayerSource.parse(path)
    path, named, index = source.path, source.layer, source.index
    layer = layer or named
    if not Path(path).exists():
        raise InputError(f"Input file {path} does not exist.")
    problem = vector_file_problem(path)
    if problem:
        raise InputError(problem)
    if encoding and python_codec(encoding) is None:
        raise InputError(f"Unknown text encoding {encoding!r}; use a name such as CP949, EUC-KR or UTF-8.")
    is_shp = Path(path).suffix.lower() in (".shp", ".dbf")
    if is_shp and not encoding:
        encoding = shapefile_encoding(path, feedback)
    elif encoding and not is_shp:
        feedback.warning(f"{Path(path).name}: the encoding parameter applies to shapefiles only; ignored.")
        encoding = None
    options = [f"ENCODING={gdal_encoding(encoding)}"] if is_shp and encoding else []
    with quiet_gdal():
        try:
            ds = gdal.OpenEx(path, gdal.OF_VECTOR, open_options=options)
        except RuntimeError as exc:
            raise InputError(f"Cannot open {path} as a vector layer: {exc}") from exc
    if ds is None:
        raise InputError(f"Cannot open {path} as a vector layer.")
    names = [ds.GetLayer(i).GetName() for i in range(ds.GetLayerCount())]
    lyr, problem = None, None
    if not names:
        problem = f"{path} contains no layers."
    elif layer is not None:
        lyr = ds.GetLayerByName(layer)
        problem = None if lyr is not None else f"{path} has no layer {layer!r}; it has: {', '.join(names)}."
    elif index is not None:
        lyr = ds.GetLayer(index) if index < len(names) else None
        problem = None if lyr is not None else \
            f"{path} has no layer number {index}; it has {len(names)}: {', '.join(names)}."
    elif len(names) == 1 or preferred is None:
        lyr = ds.GetLayer(0)
    else:
        lyr = ds.GetLayerByName(preferred)
        problem = None if lyr is not None else (
            f"{path} has no layer {preferred!r} and holds {len(names)} layers ({', '.join(names)}): "
            f"name the one to use, as {Path(path).name}|layername=<name>.")
    if problem:
        ds = None  # closed now, not whenever the traceback that holds this frame goes
        raise InputError(problem)
    return ds, lyr, gdal_encoding(encoding) if encoding else None


def field_names(layer: ogr.Layer) -> list[str]:
    """The layer's field names as GDAL gives them (names that are not UTF-8 carry surrogate escapes)."""
    defn = layer.GetLayerDefn()
    return [defn.GetFieldDefn(i).GetName() for i in range(defn.GetFieldCount())]


def open_step_layer(source: str | LayerSource, name: str, role: str, fields: Sequence[str] = ()
                    ) -> tuple[gdal.Dataset, ogr.Layer, list[str]]:
    """A step's input: the layer of ``source`` (``file|layername=x``, a file's only layer, or its layer
    ``name`` — the one the step that makes such layers writes), checked for ``fields``.

    Returns the dataset (keep it alive while using the layer), the layer and its field names;
    every problem is an ``InputError`` that names the step (``role``) that makes such layers.
    """
    path = LayerSource.parse(source).path
    if not Path(path).is_file():
        raise InputError(f"The {role} file {path} does not exist.")
    ds, layer, _ = open_layer(source, preferred=name)
    present = field_names(layer)
    missing = [f for f in fields if f not in present]
    if missing:
        problem = (f"Layer '{layer.GetName()}' in {path} lacks the field(s) {', '.join(missing)} of the {role}: "
                   "give that step's output (made again with this version if it came from an older one).")
        layer = ds = None  # closed now, not whenever the traceback that holds this frame goes
        raise InputError(problem)
    return ds, layer, present


def layer_extent(path: str | os.PathLike, target: pyproj.CRS, layer: str | None = None,
                 crs: str | None = None) -> tuple[float, float, float, float] | None:
    """The layer's bounding box in ``target`` without reading its features (None when it has none).

    ``crs`` is the source CRS for a layer that declares none; an extent that is not finite (a
    feature with an infinite or NaN coordinate) is an input error, since it bounds nothing.
    """
    ds, lyr, _ = open_layer(path, layer)
    source = _crs_of(lyr, str(path), crs)
    if lyr.GetFeatureCount() == 0:
        return None
    with quiet_gdal():
        xmin, xmax, ymin, ymax = lyr.GetExtent()
    del lyr, ds
    bounds = pyproj.Transformer.from_crs(source, target, always_xy=True).transform_bounds(
        xmin, ymin, xmax, ymax, densify_pts=21)
    if not all(np.isfinite(bounds)):
        raise InputError(f"{path}: its extent ({xmin}, {ymin}, {xmax}, {ymax}) is not finite in {target.name}: "
                         "a feature has an infinite or NaN coordinate, or lies outside the CRS's area of use.")
    return bounds


def read_prepared(source: str | os.PathLike | LayerSource, default_layer: str | None, feedback: Feedback = SILENT,
                  **options) -> VectorLayer:
    """A step's input layer: ``file.gpkg|layername=x`` as given, a file's only layer, or the model's layer
    name in a file of several (see ``open_layer``).

    Geometries with an infinite or NaN coordinate (never in a layer wit:preparevectors wrote) become
    None with a warning, so the step counts them as skipped instead of meshing or extruding them.
    """
    layer = read_layer(source, feedback=feedback, preferred=default_layer, **options)
    bad = non_finite(layer.geoms)
    if bad.any():
        layer.geoms[bad] = None
        feedback.warning(f"{layer.name}: {int(bad.sum())} feature(s) with infinite or NaN coordinates left out.")
    return layer


def bbox_transformer(bbox_crs: pyproj.CRS, source_crs: pyproj.CRS) -> pyproj.Transformer | None:
    """What takes a box in ``bbox_crs`` to the layer's CRS (``source_bbox``); None when they are the same."""
    return None if bbox_crs.equals(source_crs) else pyproj.Transformer.from_crs(bbox_crs, source_crs, always_xy=True)


def source_bbox(bbox: tuple[float, float, float, float],
                to_source: pyproj.Transformer | None) -> tuple[float, float, float, float]:
    """``bbox`` as the box in the layer's CRS that ``read_layer`` filters with (``to_source``: ``bbox_transformer``)."""
    return bbox if to_source is None else to_source.transform_bounds(*bbox, densify_pts=21)


def read_layer(path: str | os.PathLike | LayerSource, layer: str | None = None, encoding: str | None = None,
               crs: str | None = None, bbox: tuple[float, float, float, float] | None = None,
               bbox_crs: pyproj.CRS | None = None, feedback: Feedback = SILENT,
               preferred: str | None = None) -> VectorLayer:
    """Read features, optionally only those whose envelope meets ``bbox`` (given in ``bbox_crs``).

    The bounding-box filter lets GDAL skip everything far from the study area (its spatial index
    when the format has one), so a small area in a national file reads quickly; features with an
    infinite or NaN coordinate, which no filter can place, are read too (``non_finite``). Unclosed rings
    (OGR passes them through, e.g. from a hand-written shapefile) are closed here and counted per
    feature in ``unclosed_rings``; geometries nothing can read become None. ``crs`` is the source
    CRS for a layer that declares none (no .prj). ``layer``/``preferred``: see ``open_layer``.
    """
    ds, lyr, encoding = open_layer(path, layer, encoding, feedback, preferred)
    source_crs = _crs_of(lyr, str(path), crs)
    if bbox is not None and bbox_crs is not None:
        bbox = source_bbox(bbox, bbox_transformer(bbox_crs, source_crs))
    defn = lyr.GetLayerDefn()
    raw_names = field_names(lyr)
    fields = [FieldDef(decode_text(name), fd.GetType(), fd.GetSubType(), fd.GetWidth(), fd.GetPrecision())
              for name, fd in zip(raw_names, (defn.GetFieldDefn(i) for i in range(defn.GetFieldCount())))]
    undecoded = [name for name in raw_names if not bulk_read.is_utf8(name)]
    if undecoded:
        feedback.warning(f"{LayerSource.parse(path).file.name}: {len(undecoded)} field name(s) are not UTF-8 "
                         f"(read as {', '.join(f.name for f in fields if f.name not in raw_names)}); the layer is read "
                         "feature by feature.")
    if bbox is not None:
        lyr.SetSpatialFilterRect(*bbox)
    with quiet_gdal():
        columns, wkbs, fids = _read_rows(lyr, fields, feedback)
        if bbox is not None:  # the filter drops them unread: they would vanish uncounted
            read = set(fids)
            # on a handle of its own: GDAL allows one Arrow stream per layer at a time, and the first one may
            # outlive its reading (a profiler, e.g. Dask's, keeps the frames it samples for a moment)
            scan_ds, scan_lyr, _ = open_layer(path, layer, encoding, feedback, preferred)
            for fid in _non_finite_fids(scan_lyr, raw_names):
                if fid not in read:
                    _append_feature(lyr.GetFeature(fid), fields, columns, wkbs, fids)
            del scan_lyr, scan_ds
    name = lyr.GetName()
    del lyr, ds
    geoms = shapely.from_wkb(np.array(wkbs, dtype=object), on_invalid="ignore")
    unclosed = np.zeros(len(wkbs), dtype=int)
    for i in np.flatnonzero(shapely.is_missing(geoms)):
        if wkbs[i] is not None:
            unclosed[i] = _count_unclosed_rings(wkbs[i])
            geoms[i] = shapely.from_wkb(wkbs[i], on_invalid="fix")  # closes the rings; None if hopeless
    geoms = shapely.force_2d(geoms)
    feedback.progress(100.0)
    return VectorLayer(str(path), name, geoms, np.array(fids, dtype=np.int64), fields, columns,
                       source_crs, encoding, unclosed)


def _read_rows(lyr: ogr.Layer, fields: list[FieldDef],
               feedback: Feedback) -> tuple[dict[str, list], list[bytes | None], list[int]]:
    """Attribute columns (Python values, text as str), WKB and FIDs of the layer's (filtered) features.

    GDAL's Arrow interface (3.6+) reads whole batches into numpy, about ten times faster than
    one call per field and feature; older GDAL, and field names that are not UTF-8 (on which GDAL
    3.6's Arrow reader crashes: ``bulk_read.arrow_ready``), take the feature loop.
    """
    total = max(lyr.GetFeatureCount(force=0), 1)
    columns: dict[str, list] = {f.name: [] for f in fields}
    wkbs: list[bytes | None] = []
    fids: list[int] = []
    if bulk_read.arrow_ready(lyr):
        fid_name, geom_name = lyr.GetFIDColumn() or "OGC_FID", lyr.GetGeometryColumn() or "wkb_geometry"
        for batch in lyr.GetArrowStreamAsNumPy(options=["USE_MASKED_ARRAYS=YES"]):
            feedback.check_canceled()
            fids += batch[fid_name].tolist()
            wkbs += [bytes(w) if w is not None else None for w in batch[geom_name]]
            for f in fields:
                columns[f.name] += _python_values(batch[f.name])
            feedback.progress(100.0 * len(fids) / total)
        return columns, wkbs, fids
    for i, feat in enumerate(lyr):
        if i % 5000 == 0:
            feedback.check_canceled()
            feedback.progress(100.0 * i / total)
        _append_feature(feat, fields, columns, wkbs, fids)
    return columns, wkbs, fids


def _append_feature(feat: ogr.Feature, fields: list[FieldDef], columns: dict[str, list], wkbs: list[bytes | None],
                    fids: list[int]) -> None:
    for j, f in enumerate(fields):
        value = feat.GetField(j)
        columns[f.name].append(decode_text(value) if isinstance(value, str) else value)
    geom = feat.GetGeometryRef()
    wkbs.append(bytes(geom.ExportToIsoWkb()) if geom is not None and not geom.IsEmpty() else None)
    fids.append(feat.GetFID())


def non_finite(geoms: np.ndarray) -> np.ndarray:
    """Per feature: has a coordinate that is ±inf or NaN (shapely would silently drop or keep it)."""
    out = np.zeros(len(geoms), dtype=bool)
    coords, index = shapely.get_coordinates(geoms, return_index=True)
    out[index[~np.isfinite(coords).all(axis=1)]] = True
    return out


def _non_finite_fids(lyr: ogr.Layer, names: list[str]) -> list[int]:
    """FIDs of the layer's features with an infinite or NaN coordinate, from one geometry-only pass
    without the spatial filter (``names``: the layer's fields, all ignored)."""
    lyr.SetSpatialFilter(None)
    bulk_read.ignore_fields(lyr, names)
    try:
        found = []
        for batch in bulk_read.batches(lyr, fid=True):
            wkbs = np.array([bytes(w) if w is not None else None for w in batch["geometry"]] + [None], dtype=object)
            found += np.asarray(batch["fid"])[non_finite(shapely.from_wkb(wkbs[:-1], on_invalid="ignore"))].tolist()
        return found
    finally:
        lyr.SetIgnoredFields([])


def _python_values(column: np.ndarray) -> list:
    """A numpy column from the Arrow reader as Python values: masked → None, bytes → str, datetimes → ISO text."""
    values = column.tolist()
    if column.dtype.kind in "SO":
        return [v.decode("utf-8", "replace") if isinstance(v, bytes) else v for v in values]
    if column.dtype.kind == "M":
        return [v.isoformat() if v is not None else None for v in values]
    return values


def _count_unclosed_rings(wkb: bytes) -> int:
    geom = ogr.CreateGeometryFromWkb(wkb)
    count = 0
    for part in (geom.GetGeometryRef(i) for i in range(geom.GetGeometryCount())):
        rings = [part.GetGeometryRef(j) for j in range(part.GetGeometryCount())] or [part]
        count += sum(1 for r in rings
                     if r.GetPointCount() > 1 and r.GetPoint_2D(0) != r.GetPoint_2D(r.GetPointCount() - 1))
    return count


@dataclass
class OutputLayer:
    """A layer to write: field definitions, columns and polygon geometries (or a plain table)."""

    name: str
    fields: list[FieldDef]
    columns: dict[str, list]
    geoms: np.ndarray | None = None  # polygonal, written as MultiPolygon; None for a table


_SETTERS = {ogr.OFTString: ogr.Feature.SetFieldString, ogr.OFTInteger: ogr.Feature.SetFieldInteger64,
            ogr.OFTInteger64: ogr.Feature.SetFieldInteger64}  # skip SetField's per-call type dispatch


def _as_multi(geoms: np.ndarray) -> np.ndarray:
    """Polygons as one-part MultiPolygons (the layer type), vectorised."""
    out = geoms.copy()
    single = shapely.get_type_id(geoms) == 3
    out[single] = shapely.multipolygons(geoms[single], indices=np.arange(np.count_nonzero(single)))
    return out


def write_gpkg(path: str | os.PathLike, layers: Sequence[OutputLayer], crs: pyproj.CRS,
               feedback: Feedback = SILENT) -> None:
    """Write layers (and non-spatial tables) into a new GeoPackage at ``path`` (caller makes it atomic)."""
    srs = osr.SpatialReference()
    srs.ImportFromWkt(crs.to_wkt())
    srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    with quiet_gdal():
        try:
            ds = ogr.GetDriverByName("GPKG").CreateDataSource(str(path))
        except RuntimeError:
            ds = None
    if ds is None:
        raise InputError(f"Cannot create the GeoPackage {path}: {gdal.GetLastErrorMsg()}")
    total = sum(len(next(iter(lay.columns.values()), [])) for lay in layers) or 1
    done = 0
    for lay in layers:
        spatial = lay.geoms is not None
        lyr = ds.CreateLayer(lay.name, srs if spatial else None, ogr.wkbMultiPolygon if spatial else ogr.wkbNone,
                             options=["SPATIAL_INDEX=YES"] if spatial else [])
        create_fields(lyr, lay.fields)
        n = len(lay.geoms) if lay.geoms is not None else len(next(iter(lay.columns.values()), []))
        wkbs = shapely.to_wkb(_as_multi(lay.geoms)) if lay.geoms is not None else None
        layer_defn = lyr.GetLayerDefn()
        setters = [_SETTERS.get(fd.type, ogr.Feature.SetField) for fd in lay.fields]
        columns = [lay.columns[fd.name] for fd in lay.fields]
        lyr.StartTransaction()
        for i in range(n):
            if i % 5000 == 0:
                feedback.check_canceled()
                feedback.progress(100.0 * (done + i) / total)
            feat = ogr.Feature(layer_defn)
            for j, (setter, column) in enumerate(zip(setters, columns)):
                value = column[i]
                if value is None:
                    feat.SetFieldNull(j)
                else:
                    setter(feat, j, value)
            if wkbs is not None and wkbs[i] is not None:
                feat.SetGeometryDirectly(ogr.CreateGeometryFromWkb(wkbs[i]))
            lyr.CreateFeature(feat)
        lyr.CommitTransaction()
        done += n
    ds.FlushCache()  # every layer (an empty one too) in the file now, whenever ds is destroyed: a profiler
    ds = None  # (Dask's) may keep it alive for a moment in the frames it samples
    feedback.progress(100.0)
