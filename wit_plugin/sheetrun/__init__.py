"""Map-sheet runs: a district or a whole city in NGII map-sheet tiles, in parallel on Dask distributed.

``plan`` decides the tiles and which tile owns each building (pure, no Dask); ``layers`` and
``job`` give a tile's layers so that neighbours agree at their border; ``worker`` builds one tile
with the ordinary chain (``wit_plugin.chain``); ``runner`` maps the tiles to Dask workers and
keeps the index of the run (``index``).
"""
