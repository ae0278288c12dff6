"""Load a CityJSON file with QGIS's "CityJSON Loader" plugin, headless, and print what QGIS made of it (JSON).

The plugin is not part of this project: fetch its public repository (cityjson/cityjson-qgis-plugin) beside the
project and give its folder. It is copied into a fresh QGIS profile (``<profile>/python/plugins/cityjson_loader``)
and run through its own Processing algorithm (``cityjsonloader:loadcityjson``, one layer per city object type),
as a user runs it; then the layers it added to the project are listed: name, CRS, features, fields, and the
first feature's attributes.

    source scripts/env.sh && /usr/bin/python3 scripts/cityjson_loader.py LOADER_FOLDER out/demo/model/model.city.json

``tests/test_alg_cityjson.py`` runs it when ``WIT_CITYJSON_LOADER`` names the plugin's folder.
"""
from __future__ import annotations

import json
import shutil
import sys
import tempfile
from pathlib import Path


def load(loader: Path, cityjson: Path) -> dict:
    from qgis.core import Qgis, QgsApplication, QgsProcessingFeedback, QgsProject

    profile = Path(tempfile.mkdtemp(prefix="wit-cityjson-loader-"))
    plugins = profile / "python" / "plugins"
    shutil.copytree(loader, plugins / "cityjson_loader", ignore=shutil.ignore_patterns(".git", "test", "tests"))
    app = QgsApplication([], False, str(profile))
    app.initQgis()
    try:
        sys.path[:0] = [str(plugins), "/usr/share/qgis/python/plugins"]
        import processing
        from cityjson_loader.processing.provider import Provider
        from processing.core.Processing import Processing

        Processing.initialize()
        provider = Provider()  # kept: the registry does not keep the Python object alive
        QgsApplication.processingRegistry().addProvider(provider)
        log: list[str] = []

        class Log(QgsProcessingFeedback):
            def pushInfo(self, info):  # noqa: N802
                log.append(info)

        results = processing.run("cityjsonloader:loadcityjson", {"INPUT": str(cityjson),
                                                                 "DIVIDE_BY_OBJECT_TYPE": True,
                                                                 "LOD_AS": 0},  # its default, "NONE", is no index
                                 feedback=Log())
        layers = {}
        for layer in QgsProject.instance().mapLayers().values():
            first = next(layer.getFeatures(), None)
            layers[layer.name()] = {
                "crs": layer.crs().authid(), "features": layer.featureCount(),
                "fields": [field.name() for field in layer.fields()],
                "first": {field.name(): str(first[field.name()]) for field in layer.fields()} if first else {},
                "geometry": first.geometry().wkbType() if first and first.hasGeometry() else None}
        return {"qgis": Qgis.QGIS_VERSION, "results": {k: str(v) for k, v in results.items()},
                "log": log,
                "layers": layers}
    finally:
        QgsProject.instance().clear()
        app.exitQgis()
        shutil.rmtree(profile, ignore_errors=True)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    print(json.dumps(load(Path(sys.argv[1]), Path(sys.argv[2])), ensure_ascii=False, indent=1))
