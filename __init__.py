"""WIT City Model QGIS plugin entry point."""


def classFactory(iface):  # noqa: N802 (QGIS API name)
    """Called by QGIS when the plugin is loaded: the packages that wit:installdependencies put in the
    profile become importable first, then the plugin loads."""
    from qgis.core import QgsApplication

    from .wit_plugin.infra.installer import activate, packages_folder

    activate(packages_folder(QgsApplication.qgisSettingsDirPath()))
    from .plugin import WitCityModelPlugin

    return WitCityModelPlugin(iface)
