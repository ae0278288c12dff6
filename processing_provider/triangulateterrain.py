"""wit:triangulateterrain — constrained Delaunay TIN of the study area with DEM heights."""
from qgis.core import (
    QgsProcessingOutputNumber,
    QgsProcessingOutputVectorLayer,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterVectorLayer,
)

from .base import WitAlgorithm
from .qgis_compat import SourceType
from .shared_parameters import MAX_EDGE, TOLERANCE, add_mesh_parameters, add_triangulator_parameter, triangulator


class TriangulateTerrain(WitAlgorithm):
    algorithm_id = "triangulateterrain"
    display_name = "Triangulate terrain (constrained Delaunay)"
    group_name = "Geometry"
    help_text = (
        "Meshes the study area with a constrained Delaunay triangulation (library: Triangle, free for "
        "non-commercial use only, or CDT, MPL-2.0, free for commercial use too; the same checks whichever): building "
        "footprints and road polygons are constraints whose edges appear in the mesh; footprints become "
        "holes (buildings stand on them) or constrained edges. Edges are at most the maximum edge "
        "length (paper: 5 m), and the mesh is refined where the DEM surface departs from the TIN by more "
        "than the vertical tolerance (a rigorous bound clears most triangles; the others are measured exactly "
        "along every edge and at the DEM cell centres inside, and so is the reported maximum). Heights: "
        "bilinear interpolation of the four surrounding DEM cell centres (a DEM in another CRS than the "
        "layers' is reprojected on the fly to theirs, bilinear, on a grid of its own cell size, and the "
        "tolerance is measured against that surface); DEM "
        "NoData (declared, or ≤ −1000 when none is declared) is filled from neighbours, never used. "
        "Messy constraints (duplicates, crossings, slivers) are cleaned first so the triangulator cannot "
        "crash. Output: one PolygonZ triangle per feature (tri_id, surface: terrain/road/footprint, "
        "feature_id), plus counts and the measured maximum vertical error."
    )
    requirements = ("shapely", "pythoncdt", "pyproj")

    DEM = "DEM"
    AREA = "AREA"
    BUILDINGS = "BUILDINGS"
    ROADS = "ROADS"
    FOOTPRINTS = "FOOTPRINTS"
    OUTPUT = "OUTPUT"

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(QgsProcessingParameterRasterLayer(self.DEM, self.tr("DEM")))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.AREA, self.tr("Study area (polygon layer, e.g. study_area of wit:preparevectors)"),
            [SourceType.VectorPolygon]))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.BUILDINGS, self.tr("Building footprints (constraints)"), [SourceType.VectorPolygon],
            optional=True))
        self.addParameter(QgsProcessingParameterVectorLayer(
            self.ROADS, self.tr("Road polygons (constraints)"), [SourceType.VectorPolygon], optional=True))
        add_mesh_parameters(self)
        self.addParameter(QgsProcessingParameterEnum(
            self.FOOTPRINTS, self.tr("Building footprints become"),
            options=[self.tr("Holes (buildings stand on them)"), self.tr("Constrained edges")], defaultValue=0))
        add_triangulator_parameter(self)
        self.add_spatial_index_parameter()
        self.addParameter(QgsProcessingParameterFileDestination(
            self.OUTPUT, self.tr("TIN (GeoPackage)"), self.tr("GeoPackage (*.gpkg)")))
        self.addOutput(QgsProcessingOutputVectorLayer("TIN", self.tr("TIN triangles")))
        self.addOutput(QgsProcessingOutputNumber("TRIANGLES", self.tr("Triangles")))
        self.addOutput(QgsProcessingOutputNumber("MAX_VERTICAL_ERROR", self.tr("Measured maximum vertical error (m)")))
        self.addOutput(QgsProcessingOutputNumber("MAX_EDGE_MEASURED", self.tr("Measured maximum edge length (m)")))

    def execute(self, parameters, context, feedback):
        from ..wit_plugin.infra import step_layers
        from ..wit_plugin.infra.io.layersource import LayerSource
        from ..wit_plugin.terrain.build import TerrainConfig, triangulate_terrain

        def source(name):
            return self.vector_source(parameters, name, context, feedback)

        output = self.parameterAsFileOutput(parameters, self.OUTPUT, context)
        stats = triangulate_terrain(
            self.parameterAsRasterLayer(parameters, self.DEM, context).source(),
            source(self.BUILDINGS), source(self.ROADS), output, source(self.AREA),
            TerrainConfig(
                max_edge=self.parameterAsDouble(parameters, MAX_EDGE, context),
                tolerance=self.parameterAsDouble(parameters, TOLERANCE, context),
                footprints_as_holes=self.parameterAsEnum(parameters, self.FOOTPRINTS, context) == 0,
                spatial_index=self.parameterAsBoolean(parameters, self.SPATIAL_INDEX, context),
                triangulator=triangulator(self, parameters, context, feedback)),
            feedback,
        )
        return {self.OUTPUT: output, "TIN": str(LayerSource(output, step_layers.TIN_LAYER)),
                "TRIANGLES": stats.triangles, "MAX_VERTICAL_ERROR": stats.max_vertical_error,
                "MAX_EDGE_MEASURED": stats.max_edge}
