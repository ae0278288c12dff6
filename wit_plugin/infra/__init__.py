"""What every step stands on: errors and progress, files and layers (``io``), the shared layer contract
(``step_layers``), DEM sampling, map-sheet numbers, mesh and polygon helpers, GDAL settings, and the
plugin's own Python environment (dependencies, installer, worker interpreter)."""
