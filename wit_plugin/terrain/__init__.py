"""Step 3: the terrain TIN, a constrained Delaunay triangulation of the study area (wit:triangulateterrain).

``build`` runs the step (reads the layers and the DEM, then writes the TIN); ``constraints`` cleans the
footprints and roads the triangles must respect; ``triangulators`` (Triangle or CDT) and ``steiner`` mesh them;
``mesh`` refines the mesh to the DEM; ``output`` writes it on the millimetre grid. Nothing is imported here:
the glue reads ``triangulators`` (the choices of its parameter) where the heavier modules may not import.
"""
