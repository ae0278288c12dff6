"""The layers that pass between the steps: names, fields and meanings shared by the core.

Each step writes a file the next one reads (GeoPackage by default), so these names are the
contract between ``preparevectors`` → ``triangulateterrain`` / ``extrudebuildings`` →
``wittexture`` → ``writecitygml``. All geometries are in the target CRS (default EPSG:5186).

Stable ids (``wit_id``) derive from the source ids, so the same input gives the same
CityGML ``gml:id`` on every run:

* buildings: ``BLD_<BD_MGT_SN>`` (25-digit management number), else ``BLD_<SIG_CD>_<BUL_MAN_NO>``,
  else ``BLD_<UFID>`` (the NGII digital map's feature id), else ``BLD_<osm_id>`` (OpenStreetMap)
* roads: ``RD_<SIG_CD>_<RDS_MAN_NO>``, else ``RD_<UFID>``, else ``RD_<osm_id>``
* else ``<prefix>_F<source FID>``; characters that cannot be in an XML name become ``_``
* districts: ``EMD_<EMD_CD>``

Every field the core derives is named ``wit_…``, so it never shadows a source attribute (an
OpenStreetMap ``height``, a ``face`` field): source attributes pass through under their own names.
A source field that itself starts with ``wit_`` and clashes is kept as ``<name>_src``.
"""

#: field holding the stable id on every layer the core writes
WIT_ID = "wit_id"

# -- wit:preparevectors outputs (Polygon layers, source attributes kept) ----------------------
PREPARED_BUILDINGS = "buildings"
PREPARED_ROADS = "roads"  # road polygons: centre lines buffered by their width / 2, or road surfaces as given
PREPARED_DISTRICTS = "districts"
FOREIGN_BUILDINGS = "foreign_buildings"  # tiles: neighbouring tiles' buildings crossing into this one
STUDY_AREA = "study_area"  # the study-area polygon, so later steps need not be told it again
ROAD_WIDTH = "wit_width_m"  # width used for the buffer (NULL for a road surface given as a polygon)
ROAD_WIDTH_SOURCE = "wit_width_src"  # the width field, "<field> × lane width", a class default, "default" or "surface"

#: each step's output as messages name it (an input that lacks its fields names the step that makes them)
PREPARED_BUILDINGS_ROLE = "prepared buildings (wit:preparevectors)"
PREPARED_ROADS_ROLE = "prepared roads (wit:preparevectors)"
PREPARED_DISTRICTS_ROLE = "prepared districts (wit:preparevectors)"
LOD1_ROLE = "LoD1 faces (wit:extrudebuildings)"
TIN_ROLE = "TIN (wit:triangulateterrain)"
TEXCOORD_ROLE = "texture table (wit:wittexture)"

# -- wit:triangulateterrain output (PolygonZ, one triangle per feature) -----------------------
TIN_LAYER = "tin"
TIN_TRIANGLE_ID = "tri_id"
TIN_SURFACE = "surface"  # one of TIN_SURFACES
TIN_SURFACES = ("terrain", "road", "footprint")
TIN_FEATURE_ID = "feature_id"  # wit_id of the road / building the triangle lies in, else NULL

# -- wit:extrudebuildings output (PolygonZ faces of closed LoD1 solids, source attributes kept) --
LOD1_LAYER = "lod1_faces"
FACE_TYPE = "wit_face"  # one of FACE_TYPES
FACE_TYPES = ("ground", "roof", "wall")
FACE_NUMBER = "wit_face_no"  # 0-based order of the face within its building's shell
BASE_Z = "wit_base_z"
HEIGHT = "wit_height"
HEIGHT_SOURCE = "wit_height_src"  # "floors", "field", "expression" or "default"
HEIGHT_RULE = "wit_height_rule"  # what exactly: e.g. "GRO_FLO_CO × 3 m", "height (m)", "default 3 m"
STOREYS_ABOVE = "wit_storeys_above"
STOREYS_BELOW = "wit_storeys_below"

# -- wit:wittexture output: images + a texture-coordinate table --------------------------------
# A folder of images (atlases) and a GeoPackage attribute table (no geometry) TEXCOORD_TABLE with
# one row per textured surface ring. Rings are the exterior rings as stored in the TIN / LoD1
# layers (closing point included), so the writer pairs them without re-deriving geometry.
TEXCOORD_FILE = "texcoords.gpkg"  # in the texture folder
TEXCOORD_TABLE = "texcoords"
TEX_TARGET = "target"  # one of TEX_TARGETS: "roof" or "wall" (LoD1 face), "tin" or "road" (TIN triangle)
TEX_TARGETS = ("roof", "wall", "tin", "road")
TEX_WALL = "wall"  # a wall's generated facade
TEX_FEATURE = "feature"  # wit_id of the building for "roof"/"wall"; tri_id (as text) for "tin"/"road"
TEX_FACE = "face_no"  # FACE_NUMBER of the roof or wall face; NULL for triangles
TEX_IMAGE = "image"  # image path relative to the texture folder
TEX_COORDS = "uv"  # "u1 v1 u2 v2 …", one pair per ring point, closing point included

# Generated facades (walls): images facade_<style>_<variant>.png beside the others, the walls' rows (target
# "wall") in TEXCOORD_TABLE, and one row per building in FACADE_TABLE of FACADE_FILE saying how its wall
# texture was made; the writers carry these fields into the model (CityGML generic attributes, 3D Tiles metadata).
FACADE_FILE = "facades.gpkg"  # in the texture folder
FACADE_IMAGE_PREFIX = "facade_"  # the generated facade images' names: facade_<style>_<variant>.png
FACADE_TABLE = "facades"
FACADES_NONE, FACADES_GENERATED = "none", "generated"
FACADE_CHOICES = (FACADES_NONE, FACADES_GENERATED)  # wit:wittexture's FACADES: walls untextured, or generated
DEFAULT_FACADES = FACADES_GENERATED
FACADE = "wit_facade"  # FACADES_GENERATED: drawn by the plugin from the building's use and storeys, not measured
FACADE_STYLE = "wit_facade_style"  # house, villa, apartment, retail, office, curtain_wall, public, industrial, other
FACADE_RULE = "wit_facade_rule"  # what chose the style, e.g. "BDTYP_CD 02001", "용도 공동주택, 15 storeys"
FACADE_STOREYS = "wit_facade_storeys"  # storeys drawn (one image row each)
FACADE_STOREYS_SOURCE = "wit_facade_storeys_src"  # the layer's floor field, or "height ÷ <typical storey> m"
FACADE_IMAGE = "image"  # the facade image, relative to the texture folder
FACADE_FIELDS = (WIT_ID, FACADE, FACADE_STYLE, FACADE_RULE, FACADE_STOREYS, FACADE_STOREYS_SOURCE, FACADE_IMAGE)
