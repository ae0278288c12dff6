"""Step 2: the study area, and the building, road and district layers cleaned, clipped and simplified."""
