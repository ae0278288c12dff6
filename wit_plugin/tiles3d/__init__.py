"""3D Tiles 1.1 export of the city model (``wit:export3dtiles``): see ``tileset`` for the layout.

Core only (no qgis import): ``export_tileset`` takes the chain's step outputs and writes a tileset
folder (``tileset.json``, ``tiles/<level>/<col>_<row>.glb``, ``textures/``).
"""
from .tileset import TILESET_FILE, TilesetConfig, TilesetReport, export_tileset

__all__ = ["TILESET_FILE", "TilesetConfig", "TilesetReport", "export_tileset"]
