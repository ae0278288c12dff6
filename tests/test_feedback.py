"""Core feedback helpers (no QGIS)."""
from __future__ import annotations

from wit_plugin.infra.feedback import Feedback, SaidOnce


class _Log(Feedback):
    def __init__(self):
        self.lines: list[tuple[str, str]] = []

    def info(self, message: str) -> None:
        self.lines.append(("info", message))

    def warning(self, message: str) -> None:
        self.lines.append(("warning", message))


def test_said_once_passes_each_distinct_message_once_in_order():
    log = _Log()
    once = SaidOnce(log)
    for step in (once, once.scaled(0, 50), once.scaled(50, 100)):  # three steps read the same DEM
        step.info("The DEM is reprojected on the fly.")
        step.warning("The DEM has no CRS.")
    once.info("The DEM has no CRS.")  # the same text as information is another message
    once.warning("2 buildings have no height.")
    assert log.lines == [("info", "The DEM is reprojected on the fly."), ("warning", "The DEM has no CRS."),
                         ("info", "The DEM has no CRS."), ("warning", "2 buildings have no height.")]
