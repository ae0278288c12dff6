<?xml version="1.0" encoding="utf-8"?>
<!DOCTYPE TS>
<TS version="2.1" language="en_US">
  <context>
    <name>WitCityModel</name>
    <message>
      <source>WIT City Model</source>
      <translation>WIT City Model</translation>
    </message>
    <message>
      <source>Install Python dependencies…</source>
      <translation>Install Python dependencies…</translation>
    </message>
    <message>
      <source>Missing Python packages: {packages}.</source>
      <translation>Missing Python packages: {packages}.</translation>
    </message>
    <message>
      <source>Build a spatial index (slower to write, faster to display)</source>
      <translation>Build a spatial index (slower to write, faster to display)</translation>
    </message>
    <message>
      <source>Cancelled: no output was written.</source>
      <translation>Cancelled: no output was written.</translation>
    </message>
    <message>
      <source>Missing Python packages: {packages}. Run 'Install Python dependencies' (wit:installdependencies, group Tools) to install them into your QGIS profile.</source>
      <translation>Missing Python packages: {packages}. Run 'Install Python dependencies' (wit:installdependencies, group Tools) to install them into your QGIS profile.</translation>
    </message>
    <message>
      <source>Run 'Install Python dependencies' (wit:installdependencies, group Tools) to install a shapely that uses QGIS's GEOS into your QGIS profile, then restart QGIS.</source>
      <translation>Run 'Install Python dependencies' (wit:installdependencies, group Tools) to install a shapely that uses QGIS's GEOS into your QGIS profile, then restart QGIS.</translation>
    </message>
    <message>
      <source>City model (whole chain)</source>
      <translation>City model (whole chain)</translation>
    </message>
    <message>
      <source>Chain</source>
      <translation>Chain</translation>
    </message>
    <message>
      <source>Runs the whole chain in one call, with one progress bar and Cancel honoured in every step: prepare the building, road and legal-dong layers for the study area; check, in seconds and before any heavy work, that the DEM and the orthoimage sheets (from their sheet numbers) cover it, naming the missing sheets (a DEM, or sheets georeferenced in another CRS than the target, are reprojected on the fly, bilinear); georeference and merge only the sheets it needs (WIT feather + gain); triangulate the terrain (it also covers the buildings that cross the area's edge); extrude LoD1 buildings (heights as in wit:extrudebuildings: floors, a height field or expression, or the height and floor fields of the common layers recognised by name; buildings given the default height are a warning and the DEFAULT_HEIGHTS output); texture them from the orthoimage (walls: generated facades from each building's use and storeys, marked as generated; FACADES); write CityGML 3.0, validate it and measure its quality. The output folder receives model.gml with its textures (and, with CITYJSON, the same model as CityJSON 2.0: model.city.json, validated alike), validation.html, metrics.csv (and metrics.html), the LoD1 and TIN GeoPackages, a 3D Tiles 1.1 tileset (3dtiles/, for CesiumJS or QGIS ≥ 3.34) and steps.json (time per step); from the QGIS window the layers load into the project as a group for the 3D map view. Everything appears at the end, so a failed or cancelled run leaves nothing. Intermediate files are deleted unless kept (then in &lt;output&gt;/work). Study area: a legal dong (code or name) if given, else the polygon layer, else the centre point and radius. Run again into the same folder, it compares what the model was built from (build.json: every setting, the plugin's version, the triangulator, and the inputs as the run reads them, by content) and builds it again only if something changed, saying what (REBUILT, REBUILD_REASON); otherwise it does no work and reports the result recorded. REBUILD builds it again anyway.</source>
      <translation>Runs the whole chain in one call, with one progress bar and Cancel honoured in every step: prepare the building, road and legal-dong layers for the study area; check, in seconds and before any heavy work, that the DEM and the orthoimage sheets (from their sheet numbers) cover it, naming the missing sheets (a DEM, or sheets georeferenced in another CRS than the target, are reprojected on the fly, bilinear); georeference and merge only the sheets it needs (WIT feather + gain); triangulate the terrain (it also covers the buildings that cross the area's edge); extrude LoD1 buildings (heights as in wit:extrudebuildings: floors, a height field or expression, or the height and floor fields of the common layers recognised by name; buildings given the default height are a warning and the DEFAULT_HEIGHTS output); texture them from the orthoimage (walls: generated facades from each building's use and storeys, marked as generated; FACADES); write CityGML 3.0, validate it and measure its quality. The output folder receives model.gml with its textures (and, with CITYJSON, the same model as CityJSON 2.0: model.city.json, validated alike), validation.html, metrics.csv (and metrics.html), the LoD1 and TIN GeoPackages, a 3D Tiles 1.1 tileset (3dtiles/, for CesiumJS or QGIS ≥ 3.34) and steps.json (time per step); from the QGIS window the layers load into the project as a group for the 3D map view. Everything appears at the end, so a failed or cancelled run leaves nothing. Intermediate files are deleted unless kept (then in &lt;output&gt;/work). Study area: a legal dong (code or name) if given, else the polygon layer, else the centre point and radius. Run again into the same folder, it compares what the model was built from (build.json: every setting, the plugin's version, the triangulator, and the inputs as the run reads them, by content) and builds it again only if something changed, saying what (REBUILT, REBUILD_REASON); otherwise it does no work and reports the result recorded. REBUILD builds it again anyway.</translation>
    </message>
    <message>
      <source>Write a 3D Tiles 1.1 tileset for viewers (3dtiles/)</source>
      <translation>Write a 3D Tiles 1.1 tileset for viewers (3dtiles/)</translation>
    </message>
    <message>
      <source>Keep the intermediate files</source>
      <translation>Keep the intermediate files</translation>
    </message>
    <message>
      <source>Output folder</source>
      <translation>Output folder</translation>
    </message>
    <message>
      <source>CityGML file</source>
      <translation>CityGML file</translation>
    </message>
    <message>
      <source>CityJSON file (model.city.json)</source>
      <translation>CityJSON file (model.city.json)</translation>
    </message>
    <message>
      <source>Validation report (HTML)</source>
      <translation>Validation report (HTML)</translation>
    </message>
    <message>
      <source>Metrics table (CSV)</source>
      <translation>Metrics table (CSV)</translation>
    </message>
    <message>
      <source>All files valid</source>
      <translation>All files valid</translation>
    </message>
    <message>
      <source>Number of errors</source>
      <translation>Number of errors</translation>
    </message>
    <message>
      <source>Buildings written</source>
      <translation>Buildings written</translation>
    </message>
    <message>
      <source>Buildings with the default height</source>
      <translation>Buildings with the default height</translation>
    </message>
    <message>
      <source>Surfaces left untextured outside the orthoimage</source>
      <translation>Surfaces left untextured outside the orthoimage</translation>
    </message>
    <message>
      <source>3D Tiles tileset (tileset.json)</source>
      <translation>3D Tiles tileset (tileset.json)</translation>
    </message>
    <message>
      <source>Seconds per step (JSON)</source>
      <translation>Seconds per step (JSON)</translation>
    </message>
    <message>
      <source>Built by this run (false: nothing had changed since the last run into the folder)</source>
      <translation>Built by this run (false: nothing had changed since the last run into the folder)</translation>
    </message>
    <message>
      <source>Why it was built (what changed)</source>
      <translation>Why it was built (what changed)</translation>
    </message>
    <message>
      <source>Orthoimage TIFs or folders</source>
      <translation>Orthoimage TIFs or folders</translation>
    </message>
    <message>
      <source>DEM</source>
      <translation>DEM</translation>
    </message>
    <message>
      <source>Buildings (TL_SPBD_BULD, NGII, AL_D010, OpenStreetMap…)</source>
      <translation>Buildings (TL_SPBD_BULD, NGII, AL_D010, OpenStreetMap…)</translation>
    </message>
    <message>
      <source>Legal dongs (TL_SCCO_EMD)</source>
      <translation>Legal dongs (TL_SCCO_EMD)</translation>
    </message>
    <message>
      <source>Target CRS</source>
      <translation>Target CRS</translation>
    </message>
    <message>
      <source>Texture scale S (0 &lt; S ≤ 1)</source>
      <translation>Texture scale S (0 &lt; S ≤ 1)</translation>
    </message>
    <message>
      <source>Surfaces outside the orthoimage</source>
      <translation>Surfaces outside the orthoimage</translation>
    </message>
    <message>
      <source>Schema folder overriding the shipped schemas (with citygml3-all.xsd)</source>
      <translation>Schema folder overriding the shipped schemas (with citygml3-all.xsd)</translation>
    </message>
    <message>
      <source>Fail and name the missing sheets</source>
      <translation>Fail and name the missing sheets</translation>
    </message>
    <message>
      <source>Leave them untextured (warning)</source>
      <translation>Leave them untextured (warning)</translation>
    </message>
    <message>
      <source>City model in map-sheet tiles (Dask)</source>
      <translation>City model in map-sheet tiles (Dask)</translation>
    </message>
    <message>
      <source>The whole chain (as wit:citymodel, with the same inputs and options) over a district or a whole city, cut into tiles on the NGII map-sheet grid (1:5,000 by default, 1:1,000 for dense cities): the sheet number is the tile id, so tiles line up with the orthoimage sheets. Area: a legal dong (code or name), else a polygon layer, else a bounding box, else everything the buildings layer covers (when asked), else the centre and radius. Every building belongs to exactly one tile, the sheet of its point on surface; the terrain of neighbouring tiles shares its border vertices and heights, roads are cut along the same border, and a building crossing it lies on terrain in its own tile. Tiles run in parallel on Dask distributed: an embedded scheduler with WORKERS worker processes of a plain Python (never QGIS itself; WORKER_PYTHON to choose it), or an existing scheduler (SCHEDULER, e.g. tcp://10.0.0.5:8786: a stock dask scheduler, whose workers import the plugin's core wit_plugin and see the same files). The output folder receives tiles/&lt;sheet&gt;/model.gml (with textures and validation.html) per tile and index.gpkg, a map of the run (status done / failed / empty, buildings, triangles, seconds, peak memory, error, fingerprint, reason). A tile whose data cannot be made fails with its reason and the others go on; the algorithm then ends with an error giving the count and the first reasons, the tiles done kept; Cancel stops every tile. Run again into the same folder, it updates the city: each tile records what it was built from (every setting, the plugin's version, the triangulator, and its inputs as they fall in its area with the margin it reads, by content); the tiles whose inputs and settings have not changed are kept as they are, the others built again, tiles that left the area removed and new ones built, and the levels above refreshed where a child changed (TILES_KEPT, TILES_REBUILT with REBUILD_REASONS, TILES_ADDED, TILES_REMOVED). REBUILD builds every tile again. A tile that keeps no building (a park, a hill, buildings that all belong to neighbouring tiles or are too small) still gets its terrain and roads (status empty). With 3D Tiles on, each tile writes its tileset and tileset.json at the top of the output folder joins them into one, below groups by map sheet (1:5,000, 1:50,000, 1° block, as many levels as the run needs) that show the terrain and the largest buildings from afar (open it in the viewer, or as a 3D Tiles layer in QGIS 3.34 and later). With CITYJSON, each tile also writes model.city.jsonl, a CityJSONSeq in the run's one transform, and index.city.jsonl at the top is the run's header line listing them: its line and the tiles' features, joined, are one CityJSONSeq of the whole run.</source>
      <translation>The whole chain (as wit:citymodel, with the same inputs and options) over a district or a whole city, cut into tiles on the NGII map-sheet grid (1:5,000 by default, 1:1,000 for dense cities): the sheet number is the tile id, so tiles line up with the orthoimage sheets. Area: a legal dong (code or name), else a polygon layer, else a bounding box, else everything the buildings layer covers (when asked), else the centre and radius. Every building belongs to exactly one tile, the sheet of its point on surface; the terrain of neighbouring tiles shares its border vertices and heights, roads are cut along the same border, and a building crossing it lies on terrain in its own tile. Tiles run in parallel on Dask distributed: an embedded scheduler with WORKERS worker processes of a plain Python (never QGIS itself; WORKER_PYTHON to choose it), or an existing scheduler (SCHEDULER, e.g. tcp://10.0.0.5:8786: a stock dask scheduler, whose workers import the plugin's core wit_plugin and see the same files). The output folder receives tiles/&lt;sheet&gt;/model.gml (with textures and validation.html) per tile and index.gpkg, a map of the run (status done / failed / empty, buildings, triangles, seconds, peak memory, error, fingerprint, reason). A tile whose data cannot be made fails with its reason and the others go on; the algorithm then ends with an error giving the count and the first reasons, the tiles done kept; Cancel stops every tile. Run again into the same folder, it updates the city: each tile records what it was built from (every setting, the plugin's version, the triangulator, and its inputs as they fall in its area with the margin it reads, by content); the tiles whose inputs and settings have not changed are kept as they are, the others built again, tiles that left the area removed and new ones built, and the levels above refreshed where a child changed (TILES_KEPT, TILES_REBUILT with REBUILD_REASONS, TILES_ADDED, TILES_REMOVED). REBUILD builds every tile again. A tile that keeps no building (a park, a hill, buildings that all belong to neighbouring tiles or are too small) still gets its terrain and roads (status empty). With 3D Tiles on, each tile writes its tileset and tileset.json at the top of the output folder joins them into one, below groups by map sheet (1:5,000, 1:50,000, 1° block, as many levels as the run needs) that show the terrain and the largest buildings from afar (open it in the viewer, or as a 3D Tiles layer in QGIS 3.34 and later). With CITYJSON, each tile also writes model.city.jsonl, a CityJSONSeq in the run's one transform, and index.city.jsonl at the top is the run's header line listing them: its line and the tiles' features, joined, are one CityJSONSeq of the whole run.</translation>
    </message>
    <message>
      <source>Python interpreter of the workers (empty = found automatically)</source>
      <translation>Python interpreter of the workers (empty = found automatically)</translation>
    </message>
    <message>
      <source>Bounding box (instead of centre and radius)</source>
      <translation>Bounding box (instead of centre and radius)</translation>
    </message>
    <message>
      <source>Everything the buildings layer covers (instead of centre and radius)</source>
      <translation>Everything the buildings layer covers (instead of centre and radius)</translation>
    </message>
    <message>
      <source>Tile grid (NGII map sheets)</source>
      <translation>Tile grid (NGII map sheets)</translation>
    </message>
    <message>
      <source>Dask scheduler address (empty = an embedded one on this computer)</source>
      <translation>Dask scheduler address (empty = an embedded one on this computer)</translation>
    </message>
    <message>
      <source>Worker processes (embedded scheduler)</source>
      <translation>Worker processes (embedded scheduler)</translation>
    </message>
    <message>
      <source>Write a 3D Tiles 1.1 tileset over all tiles (tileset.json) for viewers</source>
      <translation>Write a 3D Tiles 1.1 tileset over all tiles (tileset.json) for viewers</translation>
    </message>
    <message>
      <source>Tile index</source>
      <translation>Tile index</translation>
    </message>
    <message>
      <source>CityJSONSeq header of the run (index.city.jsonl)</source>
      <translation>CityJSONSeq header of the run (index.city.jsonl)</translation>
    </message>
    <message>
      <source>3D Tiles tileset over all tiles (tileset.json)</source>
      <translation>3D Tiles tileset over all tiles (tileset.json)</translation>
    </message>
    <message>
      <source>Tiles done</source>
      <translation>Tiles done</translation>
    </message>
    <message>
      <source>Tiles failed</source>
      <translation>Tiles failed</translation>
    </message>
    <message>
      <source>Tiles without buildings</source>
      <translation>Tiles without buildings</translation>
    </message>
    <message>
      <source>Tiles kept as they were (nothing they read had changed)</source>
      <translation>Tiles kept as they were (nothing they read had changed)</translation>
    </message>
    <message>
      <source>Tiles already done before this run (kept: as TILES_KEPT)</source>
      <translation>Tiles already done before this run (kept: as TILES_KEPT)</translation>
    </message>
    <message>
      <source>Tiles built again (what they read had changed)</source>
      <translation>Tiles built again (what they read had changed)</translation>
    </message>
    <message>
      <source>Tiles new to the output</source>
      <translation>Tiles new to the output</translation>
    </message>
    <message>
      <source>Tiles removed (they left the area)</source>
      <translation>Tiles removed (they left the area)</translation>
    </message>
    <message>
      <source>Why tiles were built again (JSON: reason → number of tiles)</source>
      <translation>Why tiles were built again (JSON: reason → number of tiles)</translation>
    </message>
    <message>
      <source>1:5,000 sheets</source>
      <translation>1:5,000 sheets</translation>
    </message>
    <message>
      <source>1:1,000 sheets (dense cities)</source>
      <translation>1:1,000 sheets (dense cities)</translation>
    </message>
    <message>
      <source>{failed} of {tiles} tile(s) failed. First reasons: {reasons}. The tiles done are kept in {output} (map of the run: index.gpkg); run the algorithm again on this folder to build only the others.</source>
      <translation>{failed} of {tiles} tile(s) failed. First reasons: {reasons}. The tiles done are kept in {output} (map of the run: index.gpkg); run the algorithm again on this folder to build only the others.</translation>
    </message>
    <message>
      <source>Cannot write {path}: {error}</source>
      <translation>Cannot write {path}: {error}</translation>
    </message>
    <message>
      <source>Build colour store</source>
      <translation>Build colour store</translation>
    </message>
    <message>
      <source>Texture</source>
      <translation>Texture</translation>
    </message>
    <message>
      <source>Query colour store</source>
      <translation>Query colour store</translation>
    </message>
    <message>
      <source>RGB orthoimage</source>
      <translation>RGB orthoimage</translation>
    </message>
    <message>
      <source>Colour tolerance (RMS, 0–255)</source>
      <translation>Colour tolerance (RMS, 0–255)</translation>
    </message>
    <message>
      <source>PostGIS connection (empty = GeoPackage)</source>
      <translation>PostGIS connection (empty = GeoPackage)</translation>
    </message>
    <message>
      <source>Table</source>
      <translation>Table</translation>
    </message>
    <message>
      <source>Colour store (GeoPackage)</source>
      <translation>Colour store (GeoPackage)</translation>
    </message>
    <message>
      <source>GeoPackage (*.gpkg)</source>
      <translation>GeoPackage (*.gpkg)</translation>
    </message>
    <message>
      <source>Cells</source>
      <translation>Cells</translation>
    </message>
    <message>
      <source>Store size (bytes)</source>
      <translation>Store size (bytes)</translation>
    </message>
    <message>
      <source>Image size (bytes)</source>
      <translation>Image size (bytes)</translation>
    </message>
    <message>
      <source>Give a GeoPackage output or a PostGIS connection.</source>
      <translation>Give a GeoPackage output or a PostGIS connection.</translation>
    </message>
    <message>
      <source>Colour store (GeoPackage path or PostGIS connection)</source>
      <translation>Colour store (GeoPackage path or PostGIS connection)</translation>
    </message>
    <message>
      <source>Points to colour</source>
      <translation>Points to colour</translation>
    </message>
    <message>
      <source>Patch extent</source>
      <translation>Patch extent</translation>
    </message>
    <message>
      <source>Patch resolution (m)</source>
      <translation>Patch resolution (m)</translation>
    </message>
    <message>
      <source>Coloured points</source>
      <translation>Coloured points</translation>
    </message>
    <message>
      <source>Texture patch</source>
      <translation>Texture patch</translation>
    </message>
    <message>
      <source>Points coloured</source>
      <translation>Points coloured</translation>
    </message>
    <message>
      <source>Give points to colour, a patch extent, or both.</source>
      <translation>Give points to colour, a patch extent, or both.</translation>
    </message>
    <message>
      <source>Export 3D Tiles</source>
      <translation>Export 3D Tiles</translation>
    </message>
    <message>
      <source>CityGML</source>
      <translation>CityGML</translation>
    </message>
    <message>
      <source>Writes the city model as an OGC 3D Tiles 1.1 tileset (tileset.json, glTF binary tiles and the texture images) for CesiumJS, QGIS 3.34 or later (3D Tiles layer) and other 3D Tiles viewers. Full-detail tiles hold the LoD1 buildings (roofs with the texture atlases of wit:wittexture, plain lit walls) and the terrain and roads of the TIN with their ground images, reused as they are; coarser tiles above them hold a terrain grid with its own image and the larger buildings on smaller mip levels of the atlases, so a large area streams. Coordinates are Earth-centred (from the model CRS), each tile in its own local frame. Every building carries its id and attributes (name, height, storeys, height source, source fields) as 3D Tiles metadata (EXT_mesh_features and EXT_structural_metadata): a click in a viewer shows them. The output folder is replaced whole; it must be new, empty or an earlier tileset. The web profile (off by default) quantizes the tiles' geometry and compresses it with meshoptimizer (KHR_mesh_quantization, EXT_meshopt_compression) for browsers such as CesiumJS: smaller and faster to load, but QGIS's 3D Tiles layer cannot read it; it needs the Python package meshoptimizer.</source>
      <translation>Writes the city model as an OGC 3D Tiles 1.1 tileset (tileset.json, glTF binary tiles and the texture images) for CesiumJS, QGIS 3.34 or later (3D Tiles layer) and other 3D Tiles viewers. Full-detail tiles hold the LoD1 buildings (roofs with the texture atlases of wit:wittexture, plain lit walls) and the terrain and roads of the TIN with their ground images, reused as they are; coarser tiles above them hold a terrain grid with its own image and the larger buildings on smaller mip levels of the atlases, so a large area streams. Coordinates are Earth-centred (from the model CRS), each tile in its own local frame. Every building carries its id and attributes (name, height, storeys, height source, source fields) as 3D Tiles metadata (EXT_mesh_features and EXT_structural_metadata): a click in a viewer shows them. The output folder is replaced whole; it must be new, empty or an earlier tileset. The web profile (off by default) quantizes the tiles' geometry and compresses it with meshoptimizer (KHR_mesh_quantization, EXT_meshopt_compression) for browsers such as CesiumJS: smaller and faster to load, but QGIS's 3D Tiles layer cannot read it; it needs the Python package meshoptimizer.</translation>
    </message>
    <message>
      <source>Side of a full-detail tile (m)</source>
      <translation>Side of a full-detail tile (m)</translation>
    </message>
    <message>
      <source>Texture folder (wit:wittexture)</source>
      <translation>Texture folder (wit:wittexture)</translation>
    </message>
    <message>
      <source>Model CRS (when the layers carry none)</source>
      <translation>Model CRS (when the layers carry none)</translation>
    </message>
    <message>
      <source>Tileset folder</source>
      <translation>Tileset folder</translation>
    </message>
    <message>
      <source>tileset.json</source>
      <translation>tileset.json</translation>
    </message>
    <message>
      <source>Tiles written</source>
      <translation>Tiles written</translation>
    </message>
    <message>
      <source>Size of the tileset (MB)</source>
      <translation>Size of the tileset (MB)</translation>
    </message>
    <message>
      <source>Export CityJSON 2.0</source>
      <translation>Export CityJSON 2.0</translation>
    </message>
    <message>
      <source>Writes the model's layers as CityJSON 2.0 (.city.json), or as a CityJSONSeq (.city.jsonl: a header line, then one feature a line): the same objects, ids, attributes and textures as wit:writecitygml. Buildings with a LoD1 Solid whose surfaces are GroundSurface, RoofSurface and WallSurface, every source attribute, height (with heightStatus: measured or estimated) and storeys; roads as their draped triangles (TrafficArea); the other TIN triangles as one TINRelief; one CityObjectGroup per legal dong, its buildings naming it as their parent. Textures: the same images and texture coordinates, in the themes of the CityGML (rgbTexture: the orthoimage; generatedFacade: the walls' generated facades, which repeat along the wall: wrapMode wrap). Vertices are integers on the millimetre grid (transform); the CRS is the metadata's referenceSystem (an OGC CRS URL, coordinates easting first). Streaming: memory does not grow with the number of buildings. The file is written whole or not at all. Validate it with wit:validatecitygml (schemas and geometry).</source>
      <translation>Writes the model's layers as CityJSON 2.0 (.city.json), or as a CityJSONSeq (.city.jsonl: a header line, then one feature a line): the same objects, ids, attributes and textures as wit:writecitygml. Buildings with a LoD1 Solid whose surfaces are GroundSurface, RoofSurface and WallSurface, every source attribute, height (with heightStatus: measured or estimated) and storeys; roads as their draped triangles (TrafficArea); the other TIN triangles as one TINRelief; one CityObjectGroup per legal dong, its buildings naming it as their parent. Textures: the same images and texture coordinates, in the themes of the CityGML (rgbTexture: the orthoimage; generatedFacade: the walls' generated facades, which repeat along the wall: wrapMode wrap). Vertices are integers on the millimetre grid (transform); the CRS is the metadata's referenceSystem (an OGC CRS URL, coordinates easting first). Streaming: memory does not grow with the number of buildings. The file is written whole or not at all. Validate it with wit:validatecitygml (schemas and geometry).</translation>
    </message>
    <message>
      <source>Copy texture images beside the CityJSON file</source>
      <translation>Copy texture images beside the CityJSON file</translation>
    </message>
    <message>
      <source>CityJSON file</source>
      <translation>CityJSON file</translation>
    </message>
    <message>
      <source>CityJSON files (*.city.json);;CityJSONSeq files (*.city.jsonl)</source>
      <translation>CityJSON files (*.city.json);;CityJSONSeq files (*.city.jsonl)</translation>
    </message>
    <message>
      <source>Roads written</source>
      <translation>Roads written</translation>
    </message>
    <message>
      <source>Terrain triangles written</source>
      <translation>Terrain triangles written</translation>
    </message>
    <message>
      <source>District groups</source>
      <translation>District groups</translation>
    </message>
    <message>
      <source>Vertices written</source>
      <translation>Vertices written</translation>
    </message>
    <message>
      <source>Texture images beside the CityJSON file</source>
      <translation>Texture images beside the CityJSON file</translation>
    </message>
    <message>
      <source>The expression {expression} failed on {count} feature(s) (e.g. {error}); the next rule was used for them.</source>
      <translation>The expression {expression} failed on {count} feature(s) (e.g. {error}); the next rule was used for them.</translation>
    </message>
    <message>
      <source>{label}: the expression {expression} has a syntax error: {error}</source>
      <translation>{label}: the expression {expression} has a syntax error: {error}</translation>
    </message>
    <message>
      <source>{label}: the expression {expression} uses the field(s) {unknown}, which the layer '{layer}' does not have; its fields are: {fields}.</source>
      <translation>{label}: the expression {expression} uses the field(s) {unknown}, which the layer '{layer}' does not have; its fields are: {fields}.</translation>
    </message>
    <message>
      <source>{label}: the expression {expression} fails on the first feature of '{layer}': {error}</source>
      <translation>{label}: the expression {expression} fails on the first feature of '{layer}': {error}</translation>
    </message>
    <message>
      <source>Extrude LoD1 buildings</source>
      <translation>Extrude LoD1 buildings</translation>
    </message>
    <message>
      <source>Geometry</source>
      <translation>Geometry</translation>
    </message>
    <message>
      <source>Builds a closed, outward-oriented LoD1 solid per building: ground face, roof and one wall per footprint edge (courtyards included). The base is one height per building: the minimum of the DEM (bilinear; a DEM in another CRS is reprojected on the fly) over the footprint, so no building floats, or the median. Height: GRO_FLO_CO × storey height when the road-name-address floor count is known, else the height field, else the expression; with neither given, the height and floor fields of common layers are recognised by name (NGII digital map BFLR_CO, or 층수 as NGII ships it; building-integrated information AL_D010 A16 height, A26 floors; OpenStreetMap height, building:levels; Korean 높이, 지상층수); else the default height, which is a warning with the count. The log says which rule was used, and every building records it (wit_height_src, wit_height_rule). Output: PolygonZ faces with the building id (wit_id), face type, face number, base height, height, storeys (all derived fields named wit_…) and every source attribute under its own name.</source>
      <translation>Builds a closed, outward-oriented LoD1 solid per building: ground face, roof and one wall per footprint edge (courtyards included). The base is one height per building: the minimum of the DEM (bilinear; a DEM in another CRS is reprojected on the fly) over the footprint, so no building floats, or the median. Height: GRO_FLO_CO × storey height when the road-name-address floor count is known, else the height field, else the expression; with neither given, the height and floor fields of common layers are recognised by name (NGII digital map BFLR_CO, or 층수 as NGII ships it; building-integrated information AL_D010 A16 height, A26 floors; OpenStreetMap height, building:levels; Korean 높이, 지상층수); else the default height, which is a warning with the count. The log says which rule was used, and every building records it (wit_height_src, wit_height_rule). Output: PolygonZ faces with the building id (wit_id), face type, face number, base height, height, storeys (all derived fields named wit_…) and every source attribute under its own name.</translation>
    </message>
    <message>
      <source>Building footprints (any polygon layer, e.g. of wit:preparevectors)</source>
      <translation>Building footprints (any polygon layer, e.g. of wit:preparevectors)</translation>
    </message>
    <message>
      <source>Base height from the DEM</source>
      <translation>Base height from the DEM</translation>
    </message>
    <message>
      <source>LoD1 solids (GeoPackage)</source>
      <translation>LoD1 solids (GeoPackage)</translation>
    </message>
    <message>
      <source>LoD1 faces</source>
      <translation>LoD1 faces</translation>
    </message>
    <message>
      <source>Solids</source>
      <translation>Solids</translation>
    </message>
    <message>
      <source>Minimum on the footprint</source>
      <translation>Minimum on the footprint</translation>
    </message>
    <message>
      <source>Median on the footprint</source>
      <translation>Median on the footprint</translation>
    </message>
    <message>
      <source>Generate sample data</source>
      <translation>Generate sample data</translation>
    </message>
    <message>
      <source>Data</source>
      <translation>Data</translation>
    </message>
    <message>
      <source>Generates a deterministic sample of the Korean national data around a centre point: buildings (TL_SPBD_BULD), roads (TL_SPRD_MANAGE) and legal dongs (TL_SCCO_EMD) as CP949 shapefiles without .cpg in EPSG:5179 with a few real-world defects, a DEM GeoTIFF in EPSG:5186 with -9999 cells and no NoData flag, and unreferenced orthoimage TIFs named by NGII 1:5,000 map-sheet number (sheet envelope + 50 m, one brightness per tile). Set either the radius or the number of buildings (0 = from the radius).&lt;br&gt;&lt;br&gt;With a building and/or road layer given (any CRS and schema: road-name-address, NGII, OpenStreetMap; roads as centre lines, buffered by ROAD_BT / 2, else by their class width or 6 m, or as polygons), it draws the orthoimage tiles from them instead, and the DEM over their area: roofs where the footprints are, roads where the roads are, paving, lawn and forest elsewhere. The tiles are the NGII sheets that cover the study area (centre and radius, a polygon layer, or a legal dong of the district layer) clipped to the layers' extent, or that whole extent. The given layers are only read; the output folder receives the tiles, the DEM and sample_manifest.json, which names the layers they were drawn from.</source>
      <translation>Generates a deterministic sample of the Korean national data around a centre point: buildings (TL_SPBD_BULD), roads (TL_SPRD_MANAGE) and legal dongs (TL_SCCO_EMD) as CP949 shapefiles without .cpg in EPSG:5179 with a few real-world defects, a DEM GeoTIFF in EPSG:5186 with -9999 cells and no NoData flag, and unreferenced orthoimage TIFs named by NGII 1:5,000 map-sheet number (sheet envelope + 50 m, one brightness per tile). Set either the radius or the number of buildings (0 = from the radius).&lt;br&gt;&lt;br&gt;With a building and/or road layer given (any CRS and schema: road-name-address, NGII, OpenStreetMap; roads as centre lines, buffered by ROAD_BT / 2, else by their class width or 6 m, or as polygons), it draws the orthoimage tiles from them instead, and the DEM over their area: roofs where the footprints are, roads where the roads are, paving, lawn and forest elsewhere. The tiles are the NGII sheets that cover the study area (centre and radius, a polygon layer, or a legal dong of the district layer) clipped to the layers' extent, or that whole extent. The given layers are only read; the output folder receives the tiles, the DEM and sample_manifest.json, which names the layers they were drawn from.</translation>
    </message>
    <message>
      <source>Buildings to draw the orthoimage from (empty = a synthetic city)</source>
      <translation>Buildings to draw the orthoimage from (empty = a synthetic city)</translation>
    </message>
    <message>
      <source>Roads to draw the orthoimage from: centre lines or polygons</source>
      <translation>Roads to draw the orthoimage from: centre lines or polygons</translation>
    </message>
    <message>
      <source>Legal dongs (TL_SCCO_EMD), to name a district as the area</source>
      <translation>Legal dongs (TL_SCCO_EMD), to name a district as the area</translation>
    </message>
    <message>
      <source>Draw over the whole extent of the given layers (instead of the study area)</source>
      <translation>Draw over the whole extent of the given layers (instead of the study area)</translation>
    </message>
    <message>
      <source>Number of buildings (0 = from the radius)</source>
      <translation>Number of buildings (0 = from the radius)</translation>
    </message>
    <message>
      <source>Random seed</source>
      <translation>Random seed</translation>
    </message>
    <message>
      <source>Orthoimage pixel size (m)</source>
      <translation>Orthoimage pixel size (m)</translation>
    </message>
    <message>
      <source>DEM cell size (m)</source>
      <translation>DEM cell size (m)</translation>
    </message>
    <message>
      <source>Generate orthoimage tiles</source>
      <translation>Generate orthoimage tiles</translation>
    </message>
    <message>
      <source>Generate the DEM</source>
      <translation>Generate the DEM</translation>
    </message>
    <message>
      <source>Buildings (TL_SPBD_BULD)</source>
      <translation>Buildings (TL_SPBD_BULD)</translation>
    </message>
    <message>
      <source>Roads (TL_SPRD_MANAGE)</source>
      <translation>Roads (TL_SPRD_MANAGE)</translation>
    </message>
    <message>
      <source>Orthoimage tile folder</source>
      <translation>Orthoimage tile folder</translation>
    </message>
    <message>
      <source>Sample manifest (JSON)</source>
      <translation>Sample manifest (JSON)</translation>
    </message>
    <message>
      <source>Given buildings drawn</source>
      <translation>Given buildings drawn</translation>
    </message>
    <message>
      <source>Given roads drawn</source>
      <translation>Given roads drawn</translation>
    </message>
    <message>
      <source>Orthoimage tiles written</source>
      <translation>Orthoimage tiles written</translation>
    </message>
    <message>
      <source>A district layer, a study-area layer, a district or the whole extent apply only when drawing from a given building or road layer.</source>
      <translation>A district layer, a study-area layer, a district or the whole extent apply only when drawing from a given building or road layer.</translation>
    </message>
    <message>
      <source>The number of buildings applies to the synthetic city only: set it to 0 when drawing from given layers.</source>
      <translation>The number of buildings applies to the synthetic city only: set it to 0 when drawing from given layers.</translation>
    </message>
    <message>
      <source>Georeference map-sheet orthoimages</source>
      <translation>Georeference map-sheet orthoimages</translation>
    </message>
    <message>
      <source>Rasters</source>
      <translation>Rasters</translation>
    </message>
    <message>
      <source>Reads the NGII map-sheet number (도엽번호, 1:50,000 to 1:1,000) anywhere in each TIF's file name, computes the sheet's envelope in the target CRS from the sheet's degree bounds on the source datum (Korea 2000 / GRS80, EPSG:4737, by default) plus a margin (NGII tiles cover the sheet + about 50 m), and writes a georeferenced, tiled, compressed GeoTIFF — or a VRT that points at the untouched pixels. A TIF that already carries a georeference in another CRS than the target is reprojected from it instead (bilinear, its pixel size in metres). Names without a valid sheet number and files GDAL cannot open are skipped with the reason in the log and in the footprint index; nothing is guessed. Input: TIF files and/or folders (their *.tif, not recursive).</source>
      <translation>Reads the NGII map-sheet number (도엽번호, 1:50,000 to 1:1,000) anywhere in each TIF's file name, computes the sheet's envelope in the target CRS from the sheet's degree bounds on the source datum (Korea 2000 / GRS80, EPSG:4737, by default) plus a margin (NGII tiles cover the sheet + about 50 m), and writes a georeferenced, tiled, compressed GeoTIFF — or a VRT that points at the untouched pixels. A TIF that already carries a georeference in another CRS than the target is reprojected from it instead (bilinear, its pixel size in metres). Names without a valid sheet number and files GDAL cannot open are skipped with the reason in the log and in the footprint index; nothing is guessed. Input: TIF files and/or folders (their *.tif, not recursive).</translation>
    </message>
    <message>
      <source>Datum of the sheet degrees</source>
      <translation>Datum of the sheet degrees</translation>
    </message>
    <message>
      <source>Margin around the sheet (m)</source>
      <translation>Margin around the sheet (m)</translation>
    </message>
    <message>
      <source>Output format</source>
      <translation>Output format</translation>
    </message>
    <message>
      <source>Footprint index</source>
      <translation>Footprint index</translation>
    </message>
    <message>
      <source>Georeferenced rasters</source>
      <translation>Georeferenced rasters</translation>
    </message>
    <message>
      <source>Sheets georeferenced</source>
      <translation>Sheets georeferenced</translation>
    </message>
    <message>
      <source>Files skipped</source>
      <translation>Files skipped</translation>
    </message>
    <message>
      <source>Files failed</source>
      <translation>Files failed</translation>
    </message>
    <message>
      <source>GeoTIFF</source>
      <translation>GeoTIFF</translation>
    </message>
    <message>
      <source>VRT</source>
      <translation>VRT</translation>
    </message>
    <message>
      <source>Install Python dependencies</source>
      <translation>Install Python dependencies</translation>
    </message>
    <message>
      <source>Tools</source>
      <translation>Tools</translation>
    </message>
    <message>
      <source>Installs the Python packages the algorithms need and QGIS's Python lacks (shapely 2, pythoncdt, pygltflib, Dask…; triangle, free for non-commercial use only, when you tick it) into a folder of your QGIS profile (python/wit_citymodel_deps), which the plugin puts on Python's path when it loads: no administrator rights, nothing changed outside the profile. Packages that are present already are left alone. The log shows each pip command; Cancel stops pip and installs nothing. Where QGIS's Python has no pip (Debian's and Ubuntu's QGIS do not install it), pip runs from its own wheel, downloaded from the package index pip is configured for into a work folder of the profile and deleted afterwards.&lt;br&gt;&lt;br&gt;On Linux, a shapely from PyPI carries its own GEOS and would crash QGIS: shapely is built from source against the system GEOS (that needs the GEOS development files, a C compiler and the Python headers), or, where the system offers shapely 2 (Debian testing/sid: python3-shapely), the message names the command that installs it. Restart QGIS when the log asks for it (a package that was already loaded in another version).</source>
      <translation>Installs the Python packages the algorithms need and QGIS's Python lacks (shapely 2, pythoncdt, pygltflib, Dask…; triangle, free for non-commercial use only, when you tick it) into a folder of your QGIS profile (python/wit_citymodel_deps), which the plugin puts on Python's path when it loads: no administrator rights, nothing changed outside the profile. Packages that are present already are left alone. The log shows each pip command; Cancel stops pip and installs nothing. Where QGIS's Python has no pip (Debian's and Ubuntu's QGIS do not install it), pip runs from its own wheel, downloaded from the package index pip is configured for into a work folder of the profile and deleted afterwards.&lt;br&gt;&lt;br&gt;On Linux, a shapely from PyPI carries its own GEOS and would crash QGIS: shapely is built from source against the system GEOS (that needs the GEOS development files, a C compiler and the Python headers), or, where the system offers shapely 2 (Debian testing/sid: python3-shapely), the message names the command that installs it. Restart QGIS when the log asks for it (a package that was already loaded in another version).</translation>
    </message>
    <message>
      <source>Python interpreter to run pip with (empty: QGIS's own)</source>
      <translation>Python interpreter to run pip with (empty: QGIS's own)</translation>
    </message>
    <message>
      <source>Packages to install when missing</source>
      <translation>Packages to install when missing</translation>
    </message>
    <message>
      <source>Package folder</source>
      <translation>Package folder</translation>
    </message>
    <message>
      <source>Installed packages</source>
      <translation>Installed packages</translation>
    </message>
    <message>
      <source>Cancelled: pip was stopped and nothing was installed.</source>
      <translation>Cancelled: pip was stopped and nothing was installed.</translation>
    </message>
    <message>
      <source>Restart QGIS to use the new {modules}: this session loaded an older version.</source>
      <translation>Restart QGIS to use the new {modules}: this session loaded an older version.</translation>
    </message>
    <message>
      <source>WIT city model</source>
      <translation>WIT city model</translation>
    </message>
    <message>
      <source>Tiles of the run</source>
      <translation>Tiles of the run</translation>
    </message>
    <message>
      <source>LoD1 buildings</source>
      <translation>LoD1 buildings</translation>
    </message>
    <message>
      <source>Terrain (TIN)</source>
      <translation>Terrain (TIN)</translation>
    </message>
    <message>
      <source>3D Tiles</source>
      <translation>3D Tiles</translation>
    </message>
    <message>
      <source>Merge rasters (WIT seam feathering)</source>
      <translation>Merge rasters (WIT seam feathering)</translation>
    </message>
    <message>
      <source>Mosaics georeferenced tiles into one tiled, compressed GeoTIFF with internal overviews, block by block so memory does not grow with the mosaic. The output grid is the one gdal_merge.py builds (union extent, first input's pixel size). Overlap 'overwrite' lets later tiles overwrite earlier ones (the paper's method); 'feather' (WIT) blends each overlap pixel as the mean of the tiles weighted by the distance to each tile's edge. Tone correction (GAIN) equalises the tiles' tone from their overlaps: every pixel of a tile becomes gain × value + offset, per band, solved over all overlaps at once; heights (one band of floats or signed integers, a DEM) get an offset only, never a gain. NoData pixels are never blended. Inputs with another CRS or pixel size are resampled onto the first input's grid, with a warning. A mosaic that would be mostly empty (tiles far apart) is refused beyond the maximum empty share (advanced). With an extent, only the mosaic's pixels that meet it are written, with the tone and feathering of the whole mosaic.</source>
      <translation>Mosaics georeferenced tiles into one tiled, compressed GeoTIFF with internal overviews, block by block so memory does not grow with the mosaic. The output grid is the one gdal_merge.py builds (union extent, first input's pixel size). Overlap 'overwrite' lets later tiles overwrite earlier ones (the paper's method); 'feather' (WIT) blends each overlap pixel as the mean of the tiles weighted by the distance to each tile's edge. Tone correction (GAIN) equalises the tiles' tone from their overlaps: every pixel of a tile becomes gain × value + offset, per band, solved over all overlaps at once; heights (one band of floats or signed integers, a DEM) get an offset only, never a gain. NoData pixels are never blended. Inputs with another CRS or pixel size are resampled onto the first input's grid, with a warning. A mosaic that would be mostly empty (tiles far apart) is refused beyond the maximum empty share (advanced). With an extent, only the mosaic's pixels that meet it are written, with the tone and feathering of the whole mosaic.</translation>
    </message>
    <message>
      <source>Maximum empty share of the mosaic (%)</source>
      <translation>Maximum empty share of the mosaic (%)</translation>
    </message>
    <message>
      <source>Input rasters</source>
      <translation>Input rasters</translation>
    </message>
    <message>
      <source>Overlap</source>
      <translation>Overlap</translation>
    </message>
    <message>
      <source>Equalise tile tone (gain and offset; with feather)</source>
      <translation>Equalise tile tone (gain and offset; with feather)</translation>
    </message>
    <message>
      <source>NoData value of the inputs (empty = as declared)</source>
      <translation>NoData value of the inputs (empty = as declared)</translation>
    </message>
    <message>
      <source>Write only this extent of the mosaic (empty = all of it)</source>
      <translation>Write only this extent of the mosaic (empty = all of it)</translation>
    </message>
    <message>
      <source>Mosaic</source>
      <translation>Mosaic</translation>
    </message>
    <message>
      <source>Blended pixels</source>
      <translation>Blended pixels</translation>
    </message>
    <message>
      <source>Overwrite (paper)</source>
      <translation>Overwrite (paper)</translation>
    </message>
    <message>
      <source>Feather (WIT)</source>
      <translation>Feather (WIT)</translation>
    </message>
    <message>
      <source>Prepare vector layers</source>
      <translation>Prepare vector layers</translation>
    </message>
    <message>
      <source>Reads the building (TL_SPBD_BULD, NGII N3A_B0010000, AL_D010, OpenStreetMap…), road and legal-dong (TL_SCCO_EMD) layers — any layer of the right geometry type; shapefiles are read in their text's encoding (the .cpg's when it fits the text, else CP949 or UTF-8 as the text shows), field names included — reprojects them (EPSG:5186 by default), repairs them (closes rings, orients exteriors counter-clockwise and holes clockwise, makes them valid, removes duplicate vertices, drops slivers, features with infinite or NaN coordinates and exact duplicates (same id and footprint) with the reason and a count; the same id on different footprints gets _2, _3… on its wit_id), clips them to the study area and simplifies them with Douglas–Peucker (buildings 0.5 m, roads and districts 5 m by default) so that polygons stay valid and buildings sharing a wall still share it. Road polygons (NGII N3A_A0010000) are the road surfaces as they are; centre lines become polygons buffered by width / 2, the width from the layer's width field (ROAD_BT, NGII 도로폭 / RVWD, OpenStreetMap width), else its lanes × 3.25 m (CARTRK_CO, 차로수, RDLN, lanes), else its class (ROA_CLS_SE, highway), else the default width; the log names the rule and counts. Study area: a legal-dong code if given, else a polygon layer if given, else the centre point and radius. Writes one GeoPackage (buildings, roads, districts, stats, dropped) and a stats CSV: features in/out, repairs, drops and vertices per layer.</source>
      <translation>Reads the building (TL_SPBD_BULD, NGII N3A_B0010000, AL_D010, OpenStreetMap…), road and legal-dong (TL_SCCO_EMD) layers — any layer of the right geometry type; shapefiles are read in their text's encoding (the .cpg's when it fits the text, else CP949 or UTF-8 as the text shows), field names included — reprojects them (EPSG:5186 by default), repairs them (closes rings, orients exteriors counter-clockwise and holes clockwise, makes them valid, removes duplicate vertices, drops slivers, features with infinite or NaN coordinates and exact duplicates (same id and footprint) with the reason and a count; the same id on different footprints gets _2, _3… on its wit_id), clips them to the study area and simplifies them with Douglas–Peucker (buildings 0.5 m, roads and districts 5 m by default) so that polygons stay valid and buildings sharing a wall still share it. Road polygons (NGII N3A_A0010000) are the road surfaces as they are; centre lines become polygons buffered by width / 2, the width from the layer's width field (ROAD_BT, NGII 도로폭 / RVWD, OpenStreetMap width), else its lanes × 3.25 m (CARTRK_CO, 차로수, RDLN, lanes), else its class (ROA_CLS_SE, highway), else the default width; the log names the rule and counts. Study area: a legal-dong code if given, else a polygon layer if given, else the centre point and radius. Writes one GeoPackage (buildings, roads, districts, stats, dropped) and a stats CSV: features in/out, repairs, drops and vertices per layer.</translation>
    </message>
    <message>
      <source>Douglas–Peucker tolerance, buildings (m)</source>
      <translation>Douglas–Peucker tolerance, buildings (m)</translation>
    </message>
    <message>
      <source>Douglas–Peucker tolerance, roads (m)</source>
      <translation>Douglas–Peucker tolerance, roads (m)</translation>
    </message>
    <message>
      <source>Douglas–Peucker tolerance, districts (m)</source>
      <translation>Douglas–Peucker tolerance, districts (m)</translation>
    </message>
    <message>
      <source>Minimum building area (m²)</source>
      <translation>Minimum building area (m²)</translation>
    </message>
    <message>
      <source>Road width when a centre line has no width, lanes or class (m)</source>
      <translation>Road width when a centre line has no width, lanes or class (m)</translation>
    </message>
    <message>
      <source>Shapefile text encoding (empty = detect; CP949 for juso.go.kr files)</source>
      <translation>Shapefile text encoding (empty = detect; CP949 for juso.go.kr files)</translation>
    </message>
    <message>
      <source>Prepared layers (GeoPackage)</source>
      <translation>Prepared layers (GeoPackage)</translation>
    </message>
    <message>
      <source>Prepared buildings</source>
      <translation>Prepared buildings</translation>
    </message>
    <message>
      <source>Prepared road polygons</source>
      <translation>Prepared road polygons</translation>
    </message>
    <message>
      <source>Prepared legal dongs</source>
      <translation>Prepared legal dongs</translation>
    </message>
    <message>
      <source>Study area</source>
      <translation>Study area</translation>
    </message>
    <message>
      <source>Statistics (CSV)</source>
      <translation>Statistics (CSV)</translation>
    </message>
    <message>
      <source>Buildings kept</source>
      <translation>Buildings kept</translation>
    </message>
    <message>
      <source>Give at least one of the building, road and district layers.</source>
      <translation>Give at least one of the building, road and district layers.</translation>
    </message>
    <message>
      <source>City model (graphical model)</source>
      <translation>City model (graphical model)</translation>
    </message>
    <message>
      <source>WIT City Model: textured CityGML 3.0 from Korean national GIS data</source>
      <translation>WIT City Model: textured CityGML 3.0 from Korean national GIS data</translation>
    </message>
    <message>
      <source>Quality metrics</source>
      <translation>Quality metrics</translation>
    </message>
    <message>
      <source>Measures the model against its sources, as the paper's Tables 17 and 19 (paper figures beside ours). Geometry (the CityGML file or the LoD1 layer against the prepared 2D footprints, matched by wit_id): placement error = distance between the centroids of footprint and ground face; coordinate error = each roof vertex to the nearest footprint vertex (mean, max); Hausdorff distance of the outlines; shape similarity index SSI = area(A∩B) / area(A∪B) (intersection over union) of footprint and ground face. Texture: sharpness = variance of the 4-neighbour Laplacian of the grey image (0.299R + 0.587G + 0.114B, as OpenCV's Laplacian().var()) and contrast = standard deviation of the grey values, on the texture images (inside the texture islands) and on the orthoimage for comparison. Seams: mean colour step across tile borders in the mosaic. Writes a CSV table, per-building rows, a GeoPackage and an HTML report.</source>
      <translation>Measures the model against its sources, as the paper's Tables 17 and 19 (paper figures beside ours). Geometry (the CityGML file or the LoD1 layer against the prepared 2D footprints, matched by wit_id): placement error = distance between the centroids of footprint and ground face; coordinate error = each roof vertex to the nearest footprint vertex (mean, max); Hausdorff distance of the outlines; shape similarity index SSI = area(A∩B) / area(A∪B) (intersection over union) of footprint and ground face. Texture: sharpness = variance of the 4-neighbour Laplacian of the grey image (0.299R + 0.587G + 0.114B, as OpenCV's Laplacian().var()) and contrast = standard deviation of the grey values, on the texture images (inside the texture islands) and on the orthoimage for comparison. Seams: mean colour step across tile borders in the mosaic. Writes a CSV table, per-building rows, a GeoPackage and an HTML report.</translation>
    </message>
    <message>
      <source>Model: CityGML file or LoD1 GeoPackage</source>
      <translation>Model: CityGML file or LoD1 GeoPackage</translation>
    </message>
    <message>
      <source>2D source footprints (prepared buildings)</source>
      <translation>2D source footprints (prepared buildings)</translation>
    </message>
    <message>
      <source>Orthoimage for comparison</source>
      <translation>Orthoimage for comparison</translation>
    </message>
    <message>
      <source>Merged mosaic (seam step)</source>
      <translation>Merged mosaic (seam step)</translation>
    </message>
    <message>
      <source>Tile footprints (index of wit:georeferencemapsheets)</source>
      <translation>Tile footprints (index of wit:georeferencemapsheets)</translation>
    </message>
    <message>
      <source>CSV files (*.csv)</source>
      <translation>CSV files (*.csv)</translation>
    </message>
    <message>
      <source>HTML report</source>
      <translation>HTML report</translation>
    </message>
    <message>
      <source>HTML files (*.html)</source>
      <translation>HTML files (*.html)</translation>
    </message>
    <message>
      <source>Mean placement error (m)</source>
      <translation>Mean placement error (m)</translation>
    </message>
    <message>
      <source>Maximum coordinate error (m)</source>
      <translation>Maximum coordinate error (m)</translation>
    </message>
    <message>
      <source>Mean shape similarity (IoU)</source>
      <translation>Mean shape similarity (IoU)</translation>
    </message>
    <message>
      <source>Texture sharpness (Laplacian variance)</source>
      <translation>Texture sharpness (Laplacian variance)</translation>
    </message>
    <message>
      <source>Texture contrast (grey std)</source>
      <translation>Texture contrast (grey std)</translation>
    </message>
    <message>
      <source>Seam step across tile borders</source>
      <translation>Seam step across tile borders</translation>
    </message>
    <message>
      <source>points</source>
      <translation>points</translation>
    </message>
    <message>
      <source>lines</source>
      <translation>lines</translation>
    </message>
    <message>
      <source>polygons</source>
      <translation>polygons</translation>
    </message>
    <message>
      <source>no geometry</source>
      <translation>no geometry</translation>
    </message>
    <message>
      <source>{label}: the layer '{layer}' ({source}) has {found} ({wkb}); expected {wanted}.</source>
      <translation>{label}: the layer '{layer}' ({source}) has {found} ({wkb}); expected {wanted}.</translation>
    </message>
    <message>
      <source>The output '{output}' ({output_path}) would overwrite the input '{input}' ({input_path}){via}: choose another output name or folder. Nothing was written.</source>
      <translation>The output '{output}' ({output_path}) would overwrite the input '{input}' ({input_path}){via}: choose another output name or folder. Nothing was written.</translation>
    </message>
    <message>
      <source>The output folder '{output}' ({output_path}) holds the input '{input}' ({input_path}): choose an output folder that holds none of the inputs. Nothing was written.</source>
      <translation>The output folder '{output}' ({output_path}) holds the input '{input}' ({input_path}): choose an output folder that holds none of the inputs. Nothing was written.</translation>
    </message>
    <message>
      <source> (through {file})</source>
      <translation> (through {file})</translation>
    </message>
    <message>
      <source>unknown geometries</source>
      <translation>unknown geometries</translation>
    </message>
    <message>
      <source> or </source>
      <translation> or </translation>
    </message>
    <message>
      <source>Roads: centre lines or road polygons (TL_SPRD_MANAGE, NGII N3L_A0020000 or N3A_A0010000, OpenStreetMap…)</source>
      <translation>Roads: centre lines or road polygons (TL_SPRD_MANAGE, NGII N3L_A0020000 or N3A_A0010000, OpenStreetMap…)</translation>
    </message>
    <message>
      <source>Triangle (non-commercial licence)</source>
      <translation>Triangle (non-commercial licence)</translation>
    </message>
    <message>
      <source>CDT (MPL-2.0)</source>
      <translation>CDT (MPL-2.0)</translation>
    </message>
    <message>
      <source>None: plain walls</source>
      <translation>None: plain walls</translation>
    </message>
    <message>
      <source>Generated from each building's use and storeys (marked as generated)</source>
      <translation>Generated from each building's use and storeys (marked as generated)</translation>
    </message>
    <message>
      <source>3D Tiles web profile: compressed geometry for browsers (QGIS cannot read it)</source>
      <translation>3D Tiles web profile: compressed geometry for browsers (QGIS cannot read it)</translation>
    </message>
    <message>
      <source>Centre of the study area</source>
      <translation>Centre of the study area</translation>
    </message>
    <message>
      <source>Radius of the study area (m)</source>
      <translation>Radius of the study area (m)</translation>
    </message>
    <message>
      <source>Study area polygons (instead of centre and radius)</source>
      <translation>Study area polygons (instead of centre and radius)</translation>
    </message>
    <message>
      <source>Legal dong: code (EMD_CD) or name, e.g. 11680101 or 역삼동 (instead of centre and radius)</source>
      <translation>Legal dong: code (EMD_CD) or name, e.g. 11680101 or 역삼동 (instead of centre and radius)</translation>
    </message>
    <message>
      <source>Triangulator (licence: Triangle is free for non-commercial use only)</source>
      <translation>Triangulator (licence: Triangle is free for non-commercial use only)</translation>
    </message>
    <message>
      <source>Maximum edge length (m)</source>
      <translation>Maximum edge length (m)</translation>
    </message>
    <message>
      <source>Vertical tolerance (m)</source>
      <translation>Vertical tolerance (m)</translation>
    </message>
    <message>
      <source>Triangle (package 'triangle') is not installed: the terrain is meshed with CDT (MPL-2.0).</source>
      <translation>Triangle (package 'triangle') is not installed: the terrain is meshed with CDT (MPL-2.0).</translation>
    </message>
    <message>
      <source>Storey height (m)</source>
      <translation>Storey height (m)</translation>
    </message>
    <message>
      <source>Height field (m), when floors are unknown (empty = recognised by name)</source>
      <translation>Height field (m), when floors are unknown (empty = recognised by name)</translation>
    </message>
    <message>
      <source>Height expression (m), when floors and field are unknown</source>
      <translation>Height expression (m), when floors and field are unknown</translation>
    </message>
    <message>
      <source>Default height (m)</source>
      <translation>Default height (m)</translation>
    </message>
    <message>
      <source>LoD1 buildings (wit:extrudebuildings)</source>
      <translation>LoD1 buildings (wit:extrudebuildings)</translation>
    </message>
    <message>
      <source>Terrain TIN (wit:triangulateterrain)</source>
      <translation>Terrain TIN (wit:triangulateterrain)</translation>
    </message>
    <message>
      <source>Road polygons (wit:preparevectors)</source>
      <translation>Road polygons (wit:preparevectors)</translation>
    </message>
    <message>
      <source>Legal dongs (wit:preparevectors)</source>
      <translation>Legal dongs (wit:preparevectors)</translation>
    </message>
    <message>
      <source>Wall textures (an orthoimage sees no facades)</source>
      <translation>Wall textures (an orthoimage sees no facades)</translation>
    </message>
    <message>
      <source>Write CityJSON 2.0 beside the CityGML (model.city.json; a tiled run: a CityJSONSeq per tile and index.city.jsonl)</source>
      <translation>Write CityJSON 2.0 beside the CityGML (model.city.json; a tiled run: a CityJSONSeq per tile and index.city.jsonl)</translation>
    </message>
    <message>
      <source>Build everything again, even what has not changed since the last run into this folder</source>
      <translation>Build everything again, even what has not changed since the last run into this folder</translation>
    </message>
    <message>
      <source>Code field of the district layer (empty = EMD_CD)</source>
      <translation>Code field of the district layer (empty = EMD_CD)</translation>
    </message>
    <message>
      <source>Name field of the district layer (empty = EMD_KOR_NM, EMD_ENG_NM)</source>
      <translation>Name field of the district layer (empty = EMD_KOR_NM, EMD_ENG_NM)</translation>
    </message>
    <message>
      <source>Triangulate terrain (constrained Delaunay)</source>
      <translation>Triangulate terrain (constrained Delaunay)</translation>
    </message>
    <message>
      <source>Meshes the study area with a constrained Delaunay triangulation (library: Triangle, free for non-commercial use only, or CDT, MPL-2.0, free for commercial use too; the same checks whichever): building footprints and road polygons are constraints whose edges appear in the mesh; footprints become holes (buildings stand on them) or constrained edges. Edges are at most the maximum edge length (paper: 5 m), and the mesh is refined where the DEM surface departs from the TIN by more than the vertical tolerance (a rigorous bound clears most triangles; the others are measured exactly along every edge and at the DEM cell centres inside, and so is the reported maximum). Heights: bilinear interpolation of the four surrounding DEM cell centres (a DEM in another CRS than the layers' is reprojected on the fly to theirs, bilinear, on a grid of its own cell size, and the tolerance is measured against that surface); DEM NoData (declared, or ≤ −1000 when none is declared) is filled from neighbours, never used. Messy constraints (duplicates, crossings, slivers) are cleaned first so the triangulator cannot crash. Output: one PolygonZ triangle per feature (tri_id, surface: terrain/road/footprint, feature_id), plus counts and the measured maximum vertical error.</source>
      <translation>Meshes the study area with a constrained Delaunay triangulation (library: Triangle, free for non-commercial use only, or CDT, MPL-2.0, free for commercial use too; the same checks whichever): building footprints and road polygons are constraints whose edges appear in the mesh; footprints become holes (buildings stand on them) or constrained edges. Edges are at most the maximum edge length (paper: 5 m), and the mesh is refined where the DEM surface departs from the TIN by more than the vertical tolerance (a rigorous bound clears most triangles; the others are measured exactly along every edge and at the DEM cell centres inside, and so is the reported maximum). Heights: bilinear interpolation of the four surrounding DEM cell centres (a DEM in another CRS than the layers' is reprojected on the fly to theirs, bilinear, on a grid of its own cell size, and the tolerance is measured against that surface); DEM NoData (declared, or ≤ −1000 when none is declared) is filled from neighbours, never used. Messy constraints (duplicates, crossings, slivers) are cleaned first so the triangulator cannot crash. Output: one PolygonZ triangle per feature (tri_id, surface: terrain/road/footprint, feature_id), plus counts and the measured maximum vertical error.</translation>
    </message>
    <message>
      <source>Study area (polygon layer, e.g. study_area of wit:preparevectors)</source>
      <translation>Study area (polygon layer, e.g. study_area of wit:preparevectors)</translation>
    </message>
    <message>
      <source>Building footprints (constraints)</source>
      <translation>Building footprints (constraints)</translation>
    </message>
    <message>
      <source>Road polygons (constraints)</source>
      <translation>Road polygons (constraints)</translation>
    </message>
    <message>
      <source>Building footprints become</source>
      <translation>Building footprints become</translation>
    </message>
    <message>
      <source>TIN (GeoPackage)</source>
      <translation>TIN (GeoPackage)</translation>
    </message>
    <message>
      <source>TIN triangles</source>
      <translation>TIN triangles</translation>
    </message>
    <message>
      <source>Triangles</source>
      <translation>Triangles</translation>
    </message>
    <message>
      <source>Measured maximum vertical error (m)</source>
      <translation>Measured maximum vertical error (m)</translation>
    </message>
    <message>
      <source>Measured maximum edge length (m)</source>
      <translation>Measured maximum edge length (m)</translation>
    </message>
    <message>
      <source>Holes (buildings stand on them)</source>
      <translation>Holes (buildings stand on them)</translation>
    </message>
    <message>
      <source>Constrained edges</source>
      <translation>Constrained edges</translation>
    </message>
    <message>
      <source>Validate CityGML 3.0</source>
      <translation>Validate CityGML 3.0</translation>
    </message>
    <message>
      <source>Validates CityGML 3.0 files offline and reports every problem with file, line and gml:id: XSD validity against all CityGML 3.0 modules (a file using an ADE whose schema is missing is reported as such), unique gml:id, every #id / xlink:href reference resolves, building solids closed, consistently outward-oriented, with planar and non-self-intersecting faces, TIN triangles non-degenerate, all positions 3D, texture images present and texture coordinates matching their rings. Geometric tolerances are in metres whatever the CRS: coordinates in degrees (e.g. EPSG:4326, EPSG:6697) are measured in local metres; an unknown CRS is read as metres, with a warning. Axis order as GDAL reads it: the short form EPSG:n is longitude (easting) first, the URN and URL forms follow EPSG's order (latitude or northing first for EPSG:4326, 6697, 5186…); latitudes beyond ±90° are read swapped, with a warning. A file that is empty, not XML, not CityGML 3.0 or truncated gets one message saying so. CityJSON 2.0 files (.city.json) and CityJSONSeq files (.city.jsonl) are validated alike: against the official CityJSON 2.0 schemas the plugin ships, and with the same checks and tolerances (ids, parents and children, vertex indices, solids, TIN triangles, texture images and values); a tile's sequence of a tiled run finds its images from the run's folder. Large files are streamed. External entities and network access are disabled while parsing. Schemas: the SCHEMA_DIR folder (an override, e.g. for an ADE), else the folder set in the plugin settings, else the CityGML 3.0 schemas the plugin ships (no network needed); the log says which was used. Results: VALID, ERROR_COUNT and a per-file table (file, status, details) as in the paper's Table 13, plus HTML and CSV reports (the HTML report goes to a temporary file when none is chosen).</source>
      <translation>Validates CityGML 3.0 files offline and reports every problem with file, line and gml:id: XSD validity against all CityGML 3.0 modules (a file using an ADE whose schema is missing is reported as such), unique gml:id, every #id / xlink:href reference resolves, building solids closed, consistently outward-oriented, with planar and non-self-intersecting faces, TIN triangles non-degenerate, all positions 3D, texture images present and texture coordinates matching their rings. Geometric tolerances are in metres whatever the CRS: coordinates in degrees (e.g. EPSG:4326, EPSG:6697) are measured in local metres; an unknown CRS is read as metres, with a warning. Axis order as GDAL reads it: the short form EPSG:n is longitude (easting) first, the URN and URL forms follow EPSG's order (latitude or northing first for EPSG:4326, 6697, 5186…); latitudes beyond ±90° are read swapped, with a warning. A file that is empty, not XML, not CityGML 3.0 or truncated gets one message saying so. CityJSON 2.0 files (.city.json) and CityJSONSeq files (.city.jsonl) are validated alike: against the official CityJSON 2.0 schemas the plugin ships, and with the same checks and tolerances (ids, parents and children, vertex indices, solids, TIN triangles, texture images and values); a tile's sequence of a tiled run finds its images from the run's folder. Large files are streamed. External entities and network access are disabled while parsing. Schemas: the SCHEMA_DIR folder (an override, e.g. for an ADE), else the folder set in the plugin settings, else the CityGML 3.0 schemas the plugin ships (no network needed); the log says which was used. Results: VALID, ERROR_COUNT and a per-file table (file, status, details) as in the paper's Table 13, plus HTML and CSV reports (the HTML report goes to a temporary file when none is chosen).</translation>
    </message>
    <message>
      <source>CityGML or CityJSON files</source>
      <translation>CityGML or CityJSON files</translation>
    </message>
    <message>
      <source>Schema folder (with citygml3-all.xsd)</source>
      <translation>Schema folder (with citygml3-all.xsd)</translation>
    </message>
    <message>
      <source>CSV report (one row per problem)</source>
      <translation>CSV report (one row per problem)</translation>
    </message>
    <message>
      <source>Validation table</source>
      <translation>Validation table</translation>
    </message>
    <message>
      <source>Schemas used</source>
      <translation>Schemas used</translation>
    </message>
    <message>
      <source>Schemas: {source} ({folder})</source>
      <translation>Schemas: {source} ({folder})</translation>
    </message>
    <message>
      <source>WIT texturing</source>
      <translation>WIT texturing</translation>
    </message>
    <message>
      <source>Cuts textures for roofs (LoD1 roof faces), terrain and road triangles (TIN) from the merged orthoimage. Texture coordinates follow U = (x − xmin)/(xmax − xmin), V = (y − ymin)/(ymax − ymin) over each image's ground extent with the half-pixel correction, so a vertex at a pixel centre lands on that pixel's texel centre. Roofs are packed into atlases with gutters (edge pixels repeated) so that mipmaps do not bleed neighbours in; terrain and roads use one image per ground square. An orthoimage sees no facades: walls get generated facades (FACADES, the default), storey modules drawn by the plugin for each building's use (the national use code BDTYP_CD, NGII's 용도/종류, AL_D010, OpenStreetMap's building tag, else its storeys) with one image row per storey (the layer's floor count, else its height), kept apart and marked as generated (facades.gpkg, the CityGML theme generatedFacade); or none. Scale S (0 &lt; S ≤ 1) sets the resolution; the mip chain down to 1×1 can be written too. The orthoimage is read in windows, never whole; one in another CRS than the layers is reprojected as it is read (bilinear). Output: a folder of images and texcoords.gpkg, the input of wit:writecitygml.</source>
      <translation>Cuts textures for roofs (LoD1 roof faces), terrain and road triangles (TIN) from the merged orthoimage. Texture coordinates follow U = (x − xmin)/(xmax − xmin), V = (y − ymin)/(ymax − ymin) over each image's ground extent with the half-pixel correction, so a vertex at a pixel centre lands on that pixel's texel centre. Roofs are packed into atlases with gutters (edge pixels repeated) so that mipmaps do not bleed neighbours in; terrain and roads use one image per ground square. An orthoimage sees no facades: walls get generated facades (FACADES, the default), storey modules drawn by the plugin for each building's use (the national use code BDTYP_CD, NGII's 용도/종류, AL_D010, OpenStreetMap's building tag, else its storeys) with one image row per storey (the layer's floor count, else its height), kept apart and marked as generated (facades.gpkg, the CityGML theme generatedFacade); or none. Scale S (0 &lt; S ≤ 1) sets the resolution; the mip chain down to 1×1 can be written too. The orthoimage is read in windows, never whole; one in another CRS than the layers is reprojected as it is read (bilinear). Output: a folder of images and texcoords.gpkg, the input of wit:writecitygml.</translation>
    </message>
    <message>
      <source>Merged orthoimage</source>
      <translation>Merged orthoimage</translation>
    </message>
    <message>
      <source>Image format</source>
      <translation>Image format</translation>
    </message>
    <message>
      <source>JPEG quality</source>
      <translation>JPEG quality</translation>
    </message>
    <message>
      <source>Atlas size limit (px)</source>
      <translation>Atlas size limit (px)</translation>
    </message>
    <message>
      <source>Gutter width (px)</source>
      <translation>Gutter width (px)</translation>
    </message>
    <message>
      <source>Write the mip chain (to 1×1)</source>
      <translation>Write the mip chain (to 1×1)</translation>
    </message>
    <message>
      <source>Texture folder</source>
      <translation>Texture folder</translation>
    </message>
    <message>
      <source>Images written</source>
      <translation>Images written</translation>
    </message>
    <message>
      <source>Textured surfaces</source>
      <translation>Textured surfaces</translation>
    </message>
    <message>
      <source>Buildings with a generated facade</source>
      <translation>Buildings with a generated facade</translation>
    </message>
    <message>
      <source>Give the LoD1 buildings, the TIN, or both.</source>
      <translation>Give the LoD1 buildings, the TIN, or both.</translation>
    </message>
    <message>
      <source>Write CityGML 3.0</source>
      <translation>Write CityGML 3.0</translation>
    </message>
    <message>
      <source>Writes a CityGML 3.0 city model, streaming (memory does not grow with the number of buildings): bldg:Building with a closed, outward-oriented lod1Solid, con:height, storeys and every source attribute as a typed generic attribute (from wit:extrudebuildings); tran:Road with traffic areas draped on the terrain and dem:ReliefFeature with a TIN (from wit:triangulateterrain, with the prepared roads' attributes); one grp:CityObjectGroup per legal dong (districts); and, when given, the textures of wit:wittexture as app:ParameterizedTexture (images copied beside the .gml, relative image URIs). gml:ids derive from the source ids, so the same input gives the same ids. srsName: EPSG:n, coordinates easting first, as GIS software reads that form. Runs in the main thread.</source>
      <translation>Writes a CityGML 3.0 city model, streaming (memory does not grow with the number of buildings): bldg:Building with a closed, outward-oriented lod1Solid, con:height, storeys and every source attribute as a typed generic attribute (from wit:extrudebuildings); tran:Road with traffic areas draped on the terrain and dem:ReliefFeature with a TIN (from wit:triangulateterrain, with the prepared roads' attributes); one grp:CityObjectGroup per legal dong (districts); and, when given, the textures of wit:wittexture as app:ParameterizedTexture (images copied beside the .gml, relative image URIs). gml:ids derive from the source ids, so the same input gives the same ids. srsName: EPSG:n, coordinates easting first, as GIS software reads that form. Runs in the main thread.</translation>
    </message>
    <message>
      <source>Copy texture images beside the .gml</source>
      <translation>Copy texture images beside the .gml</translation>
    </message>
    <message>
      <source>CityGML files (*.gml)</source>
      <translation>CityGML files (*.gml)</translation>
    </message>
    <message>
      <source>Texture images beside the CityGML file</source>
      <translation>Texture images beside the CityGML file</translation>
    </message>
    <message>
      <source>triangle (J. R. Shewchuk's Triangle) is free for non-commercial use only; commercial use needs a licence from its author.</source>
      <translation>triangle (J. R. Shewchuk's Triangle) is free for non-commercial use only; commercial use needs a licence from its author.</translation>
    </message>
    <message>
      <source>Missing: {names}.</source>
      <translation>Missing: {names}.</translation>
    </message>
    <message>
      <source>Installed into {folder}: {packages}.</source>
      <translation>Installed into {folder}: {packages}.</translation>
    </message>
    <message>
      <source>QGIS's Python ({python}) has no pip, and pip's own wheel could not be fetched from the package index ({reason}): {command}</source>
      <translation>QGIS's Python ({python}) has no pip, and pip's own wheel could not be fetched from the package index ({reason}): {command}</translation>
    </message>
    <message>
      <source>QGIS's Python has no pip that can install: pip {version} runs from its own wheel, downloaded from {url}.</source>
      <translation>QGIS's Python has no pip that can install: pip {version} runs from its own wheel, downloaded from {url}.</translation>
    </message>
    <message>
      <source>Run: {command}</source>
      <translation>Run: {command}</translation>
    </message>
    <message>
      <source>shapely: a shapely wheel bundles its own GEOS, which crashes QGIS on Linux; it must be built against the system GEOS, which needs the GEOS development files, a C compiler and the Python headers ({packages}).</source>
      <translation>shapely: a shapely wheel bundles its own GEOS, which crashes QGIS on Linux; it must be built against the system GEOS, which needs the GEOS development files, a C compiler and the Python headers ({packages}).</translation>
    </message>
    <message>
      <source>Every selected package is present already: {names}.</source>
      <translation>Every selected package is present already: {names}.</translation>
    </message>
    <message>
      <source>QGIS's Python ({python}) has pip {version}; installing needs pip 22.2 or later, and pip's own wheel could not be fetched from the package index ({reason}): {command}</source>
      <translation>QGIS's Python ({python}) has pip {version}; installing needs pip 22.2 or later, and pip's own wheel could not be fetched from the package index ({reason}): {command}</translation>
    </message>
    <message>
      <source>QGIS's Python ({python}) has no pip, and pip's own wheel could not be fetched from the package index ({reason}).</source>
      <translation>QGIS's Python ({python}) has no pip, and pip's own wheel could not be fetched from the package index ({reason}).</translation>
    </message>
    <message>
      <source>Running: {command}</source>
      <translation>Running: {command}</translation>
    </message>
    <message>
      <source>Nothing was installed.</source>
      <translation>Nothing was installed.</translation>
    </message>
    <message>
      <source>Then run 'Install Python dependencies' again.</source>
      <translation>Then run 'Install Python dependencies' again.</translation>
    </message>
    <message>
      <source>{module}: a wheel from PyPI bundles a C library that QGIS loads itself and would crash QGIS; the platform's package {package} is the safe one.</source>
      <translation>{module}: a wheel from PyPI bundles a C library that QGIS loads itself and would crash QGIS; the platform's package {package} is the safe one.</translation>
    </message>
    <message>
      <source>shapely: the system GEOS development files are version {system}, but QGIS runs GEOS {qgis}; a shapely built against them would crash QGIS. Install the GEOS development files of QGIS's GEOS.</source>
      <translation>shapely: the system GEOS development files are version {system}, but QGIS runs GEOS {qgis}; a shapely built against them would crash QGIS. Install the GEOS development files of QGIS's GEOS.</translation>
    </message>
    <message>
      <source>The installed packages do not import; nothing was installed:</source>
      <translation>The installed packages do not import; nothing was installed:</translation>
    </message>
    <message>
      <source>The shapely built here uses GEOS {built}, QGIS uses GEOS {qgis}; it would crash QGIS, so nothing was installed.</source>
      <translation>The shapely built here uses GEOS {built}, QGIS uses GEOS {qgis}; it would crash QGIS, so nothing was installed.</translation>
    </message>
    <message>
      <source>pip's own wheel could not be downloaded ({reason}).</source>
      <translation>pip's own wheel could not be downloaded ({reason}).</translation>
    </message>
    <message>
      <source>{module}: a wheel from PyPI bundles a C library that QGIS loads itself and would crash QGIS; install your distribution's package ({package}).</source>
      <translation>{module}: a wheel from PyPI bundles a C library that QGIS loads itself and would crash QGIS; install your distribution's package ({package}).</translation>
    </message>
    <message>
      <source>pip wants {name} in two versions ({first}, {second}); install the packages one at a time.</source>
      <translation>pip wants {name} in two versions ({first}, {second}); install the packages one at a time.</translation>
    </message>
    <message>
      <source>pip failed installing {package} (exit code {code}); nothing was installed:</source>
      <translation>pip failed installing {package} (exit code {code}); nothing was installed:</translation>
    </message>
    <message>
      <source>pip cannot install {module} on this Python ({requirements}):</source>
      <translation>pip cannot install {module} on this Python ({requirements}):</translation>
    </message>
  </context>
</TS>
