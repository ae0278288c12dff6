"""Stands in for QGIS's ``processing`` in a core test run (scripts/test.sh --core): importing it fails, as on a
machine without QGIS, so a core test that needs QGIS fails instead of passing by luck."""
raise ImportError("processing is not importable in a core test run (scripts/test.sh --core): mark the test qgis")
