"""The layers that pass between the steps: names, fields and meanings shared by the core.

Each step writes a file the next one reads (GeoPackage by default), so these names are the
contract between ``preparevectors`` → ``triangulateterrain`` / ``extrudebuildings`` →
``wittexture`` → ``writecitygml``. All geometries are in the target CRS (default EPSG:5186).

Stable ids (``wit_id``) derive from the source ids, so the same input gives the same
CityGML ``gml:id`` on every run:

* buildings: ``BLD_<BD_MGT_SN>`` (25-digit management number), else ``BLD_<SIG_CD>_<BUL_MAN_NO>``
* roads: ``RD_<SIG_CD>_<RDS_MAN_NO>``
* districts: ``EMD_<EMD_CD>``
"""

#: field holding the stable id on every layer the core writes
WIT_ID = "wit_id"

# -- wit:preparevectors outputs (Polygon layers, source attributes kept) ----------------------
PREPARED_BUILDINGS = "buildings"
PREPARED_ROADS = "roads"  # road polygons: centre lines buffered by ROAD_BT / 2
PREPARED_DISTRICTS = "districts"
STUDY_AREA = "study_area"  # the study-area polygon, so later steps need not be told it again
ROAD_WIDTH = "width_m"  # width used for the buffer
ROAD_WIDTH_SOURCE = "width_src"  # "ROAD_BT" or "default"

# -- wit:triangulateterrain output (PolygonZ, one triangle per feature) -----------------------
TIN_LAYER = "tin"
TIN_TRIANGLE_ID = "tri_id"
TIN_SURFACE = "surface"  # one of TIN_SURFACES
TIN_SURFACES = ("terrain", "road", "footprint")
TIN_FEATURE_ID = "feature_id"  # wit_id of the road / building the triangle lies in, else NULL

# -- wit:extrudebuildings output (PolygonZ faces of closed LoD1 solids, source attributes kept) --
LOD1_LAYER = "lod1_faces"
FACE_TYPE = "face"  # one of FACE_TYPES
FACE_TYPES = ("ground", "roof", "wall")
FACE_NUMBER = "face_no"  # 0-based order of the face within its building's shell
BASE_Z = "base_z"
HEIGHT = "height"
HEIGHT_SOURCE = "height_src"  # "floors", "field", "expression" or "default"
STOREYS_ABOVE = "storeys_above"
STOREYS_BELOW = "storeys_below"

# -- wit:wittexture output: images + a texture-coordinate table --------------------------------
# A folder of images (atlases) and a GeoPackage attribute table (no geometry) TEXCOORD_TABLE with
# one row per textured surface ring. Rings are the exterior rings as stored in the TIN / LoD1
# layers (closing point included), so the writer pairs them without re-deriving geometry.
TEXCOORD_FILE = "texcoords.gpkg"  # in the texture folder
TEXCOORD_TABLE = "texcoords"
TEX_TARGET = "target"  # "roof" (LoD1 face), "tin" (TIN triangle) or "road" (TIN triangle)
TEX_FEATURE = "feature"  # wit_id of the building for "roof"; tri_id (as text) for "tin"/"road"
TEX_FACE = "face_no"  # FACE_NUMBER of the roof face; NULL for triangles
TEX_IMAGE = "image"  # image path relative to the texture folder
TEX_COORDS = "uv"  # "u1 v1 u2 v2 …", one pair per ring point, closing point included
