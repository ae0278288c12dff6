"""Exceptions raised by the core. The QGIS glue turns them into QgsProcessingException."""


class WitError(Exception):
    """A problem the user can act on (bad input, missing dependency, unwritable output)."""


class InputError(WitError):
    """An input file, layer or parameter is invalid."""


class MissingDependencyError(WitError):
    """An optional Python package the algorithm needs is not installed."""


class CanceledError(WitError):
    """The user cancelled the run; outputs were not written."""
