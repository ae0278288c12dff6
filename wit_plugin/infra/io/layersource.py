"""A vector layer's source: its file and which of the file's layers, in one type for the core and the glue.

Between the steps and from QGIS a source travels in QGIS's own text form, ``file.gpkg|layername=x``
(or ``|layerid=n``, as QGIS writes sources it opened); ``LayerSource.parse`` reads that form and
``str()`` writes it, so no other module splits or joins it by hand.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class LayerSource:
    """A file and, in a file of several layers, the layer by name or by index (none: its only layer)."""

    path: str
    layer: str | None = None
    index: int | None = None

    @classmethod
    def parse(cls, source: str | os.PathLike | LayerSource) -> LayerSource:
        """``file.gpkg|layername=x`` or ``file.gpkg|layerid=n`` (other options ignored), or a bare file."""
        if isinstance(source, LayerSource):
            return source
        path, _, options_text = str(source).partition("|")
        name, index = None, None
        for option in options_text.split("|"):
            key, _, value = option.partition("=")
            if key == "layername" and value:
                name = value
            elif key == "layerid" and value.strip().isdigit():
                index = int(value)
        return cls(path, name, index)

    @property
    def file(self) -> Path:
        return Path(self.path)

    def __str__(self) -> str:
        """The QGIS form: ``file|layername=x`` (a name wins over an index), ``file|layerid=n`` or ``file``."""
        if self.layer:
            return f"{self.path}|layername={self.layer}"
        if self.index is not None:
            return f"{self.path}|layerid={self.index}"
        return self.path
