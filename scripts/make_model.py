"""Build processing_provider/models/wit_citymodel.model3: the whole chain as a graphical model.

The shipped model is generated here with the PyQGIS model API, so it is reproducible and
reviewable (run this, then `git diff` the .model3):

    source scripts/env.sh && .venv/bin/python scripts/make_model.py [OUTPUT.model3]

The model does what wit:citymodel does, step by step in the modeler: georeference the NGII
sheet TIFs → merge them (WIT feather + gain) → prepare the vectors for the study area →
triangulate the terrain → extrude LoD1 buildings → texture them → write CityGML 3.0 →
validate it; and, when the CITYJSON input is ticked (a conditional branch), export the same model as
CityJSON 2.0. Intermediate results go to temporary files; the model outputs are the .gml, the HTML
validation report and the optional .city.json. Child outputs are linked directly (no expressions), so renaming a
child's description in the modeler breaks nothing.
"""
from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

# Qt orders XML attributes by hash: a fixed seed makes the written .model3 byte-for-byte reproducible
os.environ.setdefault("QT_HASH_SEED", "0")

ROOT = Path(__file__).resolve().parents[1]
MODEL_PATH = ROOT / "processing_provider" / "models" / "wit_citymodel.model3"

MODEL_NAME = "citymodelmodel"
MODEL_GROUP = "Chain"
MODEL_GROUP_ID = "chain"
SUSEO = "127.1020,37.4876 [EPSG:4326]"

#: model inputs, in dialog order: name → (description, help)
INPUT_HELP = {
    "ORTHO": "NGII orthoimage map-sheet TIFs (named by sheet number) and/or folders of them (their *.tif).",
    "DEM": "Digital elevation model (raster) covering the study area.",
    "BUILDINGS": "Building footprints (TL_SPBD_BULD, juso.go.kr).",
    "ROADS": "Road lines or polygons (TL_SPRD_MANAGE); optional.",
    "DISTRICTS": "Legal-dong polygons (TL_SCCO_EMD); optional.",
    "CENTER": "Centre of the circular study area (default: Suseo station).",
    "RADIUS": "Radius of the study area in metres.",
    "STOREY_HEIGHT": "Height of one storey in metres (height = floors × storey height).",
    "HEIGHT_FIELD": "Field with the building height in metres, used when the floor count (GRO_FLO_CO) is unknown; "
                    "empty: the height and floor fields of common layers are recognised by name.",
    "HEIGHT_EXPRESSION": "Expression giving the height in metres, when floors and field are unknown.",
    "DEFAULT_HEIGHT": "Height of buildings with no usable height (a warning counts them).",
    "MAX_EDGE": "Maximum edge length of the terrain triangles in metres.",
    "TRIANGULATOR": "Library that triangulates the terrain: Triangle (free for non-commercial use only) or CDT "
                    "(MPL-2.0, free for commercial use too); empty: Triangle where it is installed, else CDT.",
    "FACADES": "Wall textures: generated facades (storey modules drawn from each building's use and storeys, "
               "marked as generated) or none.",
    "SCHEMA_DIR": "Folder with citygml3-all.xsd for validation (empty: the plugin's configured/bundled schemas).",
    "CITYJSON": "Also write the model as CityJSON 2.0 (the CityJSON output; off by default).",
}
#: the conditional branch that runs the CityJSON export only when CITYJSON is ticked
CITYJSON_BRANCH = "CITYJSON_ASKED"


def _bootstrap():
    """QGIS headless with Processing and the ``wit`` provider (the plugin as ``wit_citymodel``)."""
    from qgis.core import QgsApplication

    app = QgsApplication.instance()
    if app is None:
        app = QgsApplication([], False)
        app.initQgis()
    sys.path.insert(0, "/usr/share/qgis/python/plugins")
    from processing.core.Processing import Processing

    Processing.initialize()
    if "wit_citymodel" not in sys.modules:
        spec = importlib.util.spec_from_file_location(
            "wit_citymodel", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
        module = importlib.util.module_from_spec(spec)
        sys.modules["wit_citymodel"] = module
        spec.loader.exec_module(module)
    from wit_citymodel.processing_provider.provider import WitProvider

    registry = QgsApplication.processingRegistry()
    provider = registry.providerById("wit")
    if provider is None:
        provider = WitProvider()
        registry.addProvider(provider)
    return app, provider


def build_model():
    """The model (QgsProcessingModelAlgorithm); needs the ``wit`` provider registered."""
    from qgis.core import (
        QgsApplication,
        QgsProcessing,
        QgsProcessingModelAlgorithm,
        QgsProcessingModelChildAlgorithm,
        QgsProcessingModelChildDependency,
        QgsProcessingModelOutput,
        QgsProcessingModelParameter,
        QgsProcessingParameterBoolean,
        QgsProcessingParameterEnum,
        QgsProcessingParameterExpression,
        QgsProcessingParameterField,
        QgsProcessingParameterFile,
        QgsProcessingParameterMultipleLayers,
        QgsProcessingParameterNumber,
        QgsProcessingParameterPoint,
        QgsProcessingParameterRasterLayer,
        QgsProcessingParameterVectorLayer,
    )
    from qgis.core import (
        QgsProcessingModelChildParameterSource as Source,
    )
    from qgis.PyQt.QtCore import QPointF, QSizeF

    model = QgsProcessingModelAlgorithm(MODEL_NAME, MODEL_GROUP, MODEL_GROUP_ID)
    facades = QgsApplication.processingRegistry().algorithmById("wit:wittexture").parameterDefinition("FACADES")

    # ---- inputs: a column on the left
    definitions = [
        QgsProcessingParameterMultipleLayers("ORTHO", "Orthoimage TIFs or folders", QgsProcessing.TypeFile),
        QgsProcessingParameterRasterLayer("DEM", "DEM"),
        QgsProcessingParameterVectorLayer("BUILDINGS", "Buildings (TL_SPBD_BULD)",
                                          [QgsProcessing.TypeVectorPolygon]),
        QgsProcessingParameterVectorLayer("ROADS", "Roads (TL_SPRD_MANAGE)",
                                          [QgsProcessing.TypeVectorAnyGeometry], optional=True),
        QgsProcessingParameterVectorLayer("DISTRICTS", "Legal dongs (TL_SCCO_EMD)",
                                          [QgsProcessing.TypeVectorPolygon], optional=True),
        # optional with a default, like wit:preparevectors (3.22 does not fill a missing mandatory point)
        QgsProcessingParameterPoint("CENTER", "Centre of the study area", defaultValue=SUSEO, optional=True),
        QgsProcessingParameterNumber("RADIUS", "Radius of the study area (m)", QgsProcessingParameterNumber.Double,
                                     defaultValue=1000.0, minValue=1.0),
        QgsProcessingParameterNumber("STOREY_HEIGHT", "Storey height (m)", QgsProcessingParameterNumber.Double,
                                     defaultValue=3.0, minValue=0.5),
        QgsProcessingParameterField("HEIGHT_FIELD", "Height field (m), when floors are unknown",
                                    parentLayerParameterName="BUILDINGS", optional=True),
        QgsProcessingParameterExpression("HEIGHT_EXPRESSION", "Height expression (m)",
                                         parentLayerParameterName="BUILDINGS", optional=True),
        QgsProcessingParameterNumber("DEFAULT_HEIGHT", "Default height (m)", QgsProcessingParameterNumber.Double,
                                     defaultValue=3.0, minValue=0.1),
        QgsProcessingParameterNumber("MAX_EDGE", "Maximum edge length of the terrain (m)",
                                     QgsProcessingParameterNumber.Double, minValue=0.5,
                                     defaultValue=QgsApplication.processingRegistry()  # the core's default
                                     .algorithmById("wit:triangulateterrain").parameterDefinition("MAX_EDGE")
                                     .defaultValue()),
        # no default: wit:triangulateterrain's own (Triangle where installed, else CDT) on the machine it runs on
        QgsProcessingParameterEnum("TRIANGULATOR", "Triangulator", options=QgsApplication.processingRegistry()
                                   .algorithmById("wit:triangulateterrain").parameterDefinition("TRIANGULATOR")
                                   .options(), optional=True),
        QgsProcessingParameterEnum("FACADES", "Wall textures", options=facades.options(),  # wit:wittexture's own
                                   defaultValue=facades.defaultValue()),
        QgsProcessingParameterFile("SCHEMA_DIR", "Schema folder (with citygml3-all.xsd)",
                                   behavior=QgsProcessingParameterFile.Folder, optional=True),
        QgsProcessingParameterBoolean("CITYJSON", "Write CityJSON 2.0 too", defaultValue=False),
    ]
    for row, definition in enumerate(definitions):
        component = QgsProcessingModelParameter(definition.name())
        component.setDescription(definition.description())
        component.setPosition(QPointF(120, 80 + 90 * row))
        component.setSize(QSizeF(220, 30))
        model.addModelParameter(definition, component)
    model.setParameterOrder([d.name() for d in definitions])

    def param(name):
        return [Source.fromModelParameter(name)]

    def child(child_id, output):
        return [Source.fromChildOutput(child_id, output)]

    def static(value):
        return [Source.fromStaticValue(value)]

    # ---- the chain, left to right (x), zig-zag (y) so the links stay readable
    steps = [
        ("GEOREFERENCE", "wit:georeferencemapsheets", "1 Georeference the NGII map sheets",
         {"INPUT": param("ORTHO")}),
        ("MERGE", "wit:mergerasters", "2 Merge the tiles (WIT feather + gain)",
         {"INPUT": child("GEOREFERENCE", "OUTPUT_LAYERS"), "OVERLAP": static(1), "GAIN": static(True)}),
        ("PREPARE", "wit:preparevectors", "3 Prepare buildings, roads, legal dongs",
         {"BUILDINGS": param("BUILDINGS"), "ROADS": param("ROADS"), "DISTRICTS": param("DISTRICTS"),
          "CENTER": param("CENTER"), "RADIUS": param("RADIUS")}),
        ("TERRAIN", "wit:triangulateterrain", "4 Triangulate the terrain (TIN)",
         {"DEM": param("DEM"), "AREA": child("PREPARE", "AREA_OUT"), "BUILDINGS": child("PREPARE", "BUILDINGS_OUT"),
          "ROADS": child("PREPARE", "ROADS_OUT"), "MAX_EDGE": param("MAX_EDGE"), "TRIANGULATOR": param("TRIANGULATOR"),
          "SPATIAL_INDEX": static(False)}),  # temporary files, read whole by the next steps
        ("EXTRUDE", "wit:extrudebuildings", "5 Extrude LoD1 buildings",
         {"BUILDINGS": child("PREPARE", "BUILDINGS_OUT"), "DEM": param("DEM"), "SPATIAL_INDEX": static(False),
          **{name: param(name) for name in ("STOREY_HEIGHT", "HEIGHT_FIELD", "HEIGHT_EXPRESSION", "DEFAULT_HEIGHT")}}),
        ("TEXTURE", "wit:wittexture", "6 Texture buildings and terrain",
         {"ORTHO": child("MERGE", "OUTPUT"), "LOD1": child("EXTRUDE", "LOD1"), "TIN": child("TERRAIN", "TIN"),
          "FACADES": param("FACADES")}),
        ("CITYGML", "wit:writecitygml", "7 Write CityGML 3.0",
         {"LOD1": child("EXTRUDE", "LOD1"), "TIN": child("TERRAIN", "TIN"), "ROADS": child("PREPARE", "ROADS_OUT"),
          "DISTRICTS": child("PREPARE", "DISTRICTS_OUT"), "TEXTURES": child("TEXTURE", "OUTPUT"),
          "COPY_TEXTURES": static(True)}),
        ("VALIDATE", "wit:validatecitygml", "8 Validate the CityGML",
         {"INPUT": child("CITYGML", "OUTPUT"), "SCHEMA_DIR": param("SCHEMA_DIR")}),
        ("IF_CITYJSON", "native:condition", "9 CityJSON asked for?", {}),
        ("CITYJSON", "wit:exportcityjson", "10 Export CityJSON 2.0",
         {"LOD1": child("EXTRUDE", "LOD1"), "TIN": child("TERRAIN", "TIN"), "ROADS": child("PREPARE", "ROADS_OUT"),
          "DISTRICTS": child("PREPARE", "DISTRICTS_OUT"), "TEXTURES": child("TEXTURE", "OUTPUT"),
          "COPY_TEXTURES": static(True)}),
    ]
    #: children run only on a branch of a condition: child id → (condition child id, branch)
    branches = {"CITYJSON": ("IF_CITYJSON", CITYJSON_BRANCH)}
    #: the conditions' branches (a configuration, not parameters)
    configurations = {"IF_CITYJSON": {"conditions": [{"name": CITYJSON_BRANCH, "expression": "@CITYJSON"}]}}
    #: the model outputs: child id → (child output, model output name, description). QGIS names a
    #: model output "<child id>:<name>" (CITYGML:GML, VALIDATE:REPORT): child ids are upper case
    #: like every wit parameter name
    outputs = {
        "CITYGML": ("OUTPUT", "GML", "CityGML file"),
        "VALIDATE": ("OUTPUT", "REPORT", "Validation report (HTML)"),
        "CITYJSON": ("OUTPUT", "FILE", "CityJSON file (when CITYJSON is ticked)"),
    }
    for column, (child_id, algorithm_id, description, sources) in enumerate(steps):
        step = QgsProcessingModelChildAlgorithm(algorithm_id)
        if child_id in configurations:
            step.setConfiguration(configurations[child_id])
        if step.algorithm() is None:
            raise RuntimeError(f"{algorithm_id} is not registered")
        step.setChildId(child_id)
        step.setDescription(description)
        position = QPointF(460 + 260 * column, 200 + (0 if column % 2 == 0 else 160))
        step.setPosition(position)
        step.setSize(QSizeF(220, 40))
        for name, value in sources.items():
            if step.algorithm().parameterDefinition(name) is None:
                raise RuntimeError(f"{algorithm_id} has no parameter {name}")
            step.addParameterSources(name, value)
        # every other input at the algorithm's default, as the modeler's dialog fills them in
        for definition in step.algorithm().parameterDefinitions():
            if (definition.isDestination() or definition.name() in sources
                    or definition.defaultValue() is None):
                continue
            step.addParameterSources(definition.name(), static(definition.defaultValue()))
        if child_id in outputs:
            child_output, name, label = outputs[child_id]
            output = QgsProcessingModelOutput(name, label)
            output.setChildId(child_id)
            output.setChildOutputName(child_output)
            output.setDescription(label)
            output.setMandatory(child_id not in branches)  # optional: qgis_process 3.22 asks for mandatory ones
            output.setPosition(position + QPointF(0, 120))
            output.setSize(QSizeF(200, 30))
            step.setModelOutputs({name: output})
        if child_id in branches:
            step.setDependencies([QgsProcessingModelChildDependency(*branches[child_id])])
        model.addChildAlgorithm(step)
    model.updateDestinationParameters()

    help_content = {
        "ALG_DESC": (
            "The whole WIT chain as a graphical model (the same steps as wit:citymodel, editable in the "
            "modeler): georeference the NGII map-sheet TIFs, merge them (WIT feather + gain), prepare the "
            "building, road and legal-dong layers for a circular study area, triangulate the terrain, "
            "extrude LoD1 buildings, texture them from the orthoimage (walls: generated facades, marked as "
            "generated), write CityGML 3.0 and validate it; with CITYJSON ticked, export the same model as "
            "CityJSON 2.0 too. Intermediate results are temporary files; the outputs are the .gml (textures "
            "copied beside it), the HTML validation report and, asked for, the .city.json."),
        "ALG_CREATOR": "WIT City Model",
        "ALG_HELP_CREATOR": "scripts/make_model.py",
        "ALG_VERSION": "1",
        "CITYGML:GML": "The CityGML 3.0 file; the texture images are written beside it.",
        "VALIDATE:REPORT": "HTML report of the schema and geometry validation.",
        "CITYJSON:FILE": "The CityJSON 2.0 file (only when CITYJSON is ticked); its textures are copied beside it.",
    }
    help_content.update(INPUT_HELP)
    model.setHelpContent(help_content)
    return model


def main(argv: list[str]) -> int:
    _app, _provider = _bootstrap()
    target = Path(argv[1]) if len(argv) > 1 else MODEL_PATH
    target.parent.mkdir(parents=True, exist_ok=True)
    model = build_model()
    ok, errors = model.validate()
    if not ok:
        print("\n".join(errors), file=sys.stderr)
        return 1
    if not model.toFile(str(target)):
        print(f"could not write {target}", file=sys.stderr)
        return 1
    print(target)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
