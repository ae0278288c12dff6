"""Reading and writing files, beneath the steps: none of these modules knows a pipeline step.

``fileio`` (atomic outputs and published staging folders, inputs never overwritten), ``layersource`` (a
layer's source, ``file|layername=x``), ``vector_io`` (any OGR source in, GeoPackage
out), ``encoding`` (a source's text encoding decided), ``raster_io`` (input rasters opened and read),
``bulk_read`` (big layers in Arrow batches), ``gpkg_bulk`` (big GeoPackage layers written in bulk).
"""
