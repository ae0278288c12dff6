"""WIT City Model core: 2D national GIS data to textured CityGML 3.0.

Pure Python on GDAL, numpy, shapely, pythoncdt (or triangle), lxml and pyproj. Nothing here imports ``qgis``,
so the core runs in tests, scripts and worker processes without QGIS.
"""

