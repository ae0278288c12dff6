"""Step 4: each building's height from its layer, and its LoD1 solid on the DEM."""
