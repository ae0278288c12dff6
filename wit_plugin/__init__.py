"""WIT City Model core: 2D national GIS data to textured CityGML 3.0.

Pure Python on GDAL, numpy, shapely, pythoncdt (or triangle), lxml and pyproj. Nothing here imports ``qgis``,
so the core runs in tests, scripts and worker processes without QGIS.
"""

__all__ = [
    "area", "arrays", "chain", "citygml", "colorstore", "dem", "deps", "errors", "extrude", "feedback", "gc_pause",
    "gdal_env", "georef", "heights", "installer", "interpreter", "io", "mapsheet", "meshes", "metrics",
    "mosaic", "numtext", "polygons", "preview", "raster_crs", "roads", "sample", "sheetrun", "simplify",
    "steiner", "step_layers", "terrain", "texture", "tiles3d", "tone", "triangulators", "vectors",
]
