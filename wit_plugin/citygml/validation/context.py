"""What the checks of one file share: where issues go, the gml:ids seen so far, the CRS of each geometry."""
from __future__ import annotations

from pathlib import Path

from lxml import etree

from ..reader import RawCounts
from .crs import Frame, frame_of
from .ids import IdStore
from .names import IssueList
from .parts import inherited


class FileContext:
    """The file's path, its issues and raw counts, its ids, its model CRS and the CRSs it defines inline."""

    def __init__(self, path: Path, issues: IssueList, raw: RawCounts):
        self.path, self.issues, self.raw = path, issues, raw
        self.ids = IdStore()
        self.model_crs: str | None = None
        self.inline_metres: dict[str, bool] = {}  # CRSs defined in the file: all axes in metres?
        self.warned: set = set()  # CRS names (and ("swapped", name)) already warned about

    def frame(self, node: etree._Element) -> Frame:
        """The CRS frame of a geometry: its own or inherited srsName, else the model's; unknown ones warned once."""
        name = inherited(node, "srsName") or self.model_crs
        frame = frame_of(name, self.inline_metres)
        if frame.assumed and name not in self.warned:
            self.warned.add(name)
            self.issues.add("crs", None, None, f"{'CRS ' + repr(name) if name else 'CRS'}: {frame.assumed}; the "
                            "geometric tolerances take the coordinates as metres.", "warning")
        return frame

    def model_frame(self) -> Frame:
        """The frame of the model's CRS (of a geometry without an srsName of its own)."""
        return frame_of(self.model_crs, self.inline_metres)

    def warn_swapped(self, frames: list[Frame]) -> None:
        for frame in frames:
            if ("swapped", frame.name) not in self.warned:
                self.warned.add(("swapped", frame.name))
                self.issues.add("crs", None, None, f"Coordinates in {frame.name} give longitude before latitude "
                                "(a latitude beyond ±90° otherwise), unlike the CRS's axis order; read as "
                                "longitude/latitude.", "warning")

    def own_crs_possible(self) -> bool:
        """Whether some geometry may carry its own srsName (an srsName in the bytes read besides the model's)."""
        return self.raw.srs_names > (self.model_crs is not None)
