"""QGIS Processing glue: the ``wit`` provider and one thin algorithm per file."""
