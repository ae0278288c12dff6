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


def test_a_step_beside_says_its_messages_labelled_and_only_the_new_ones():
    """The solids beside the terrain read the same DEM and say so: the run says it once, unlabelled as first said;
    what only the step says comes labelled with the step."""
    log = _Log()
    once = SaidOnce(log)
    once.info("The DEM is reprojected on the fly.")
    extrude = once.labelled("extrude")
    extrude.info("The DEM is reprojected on the fly.")
    extrude.info("Heights: 3 from GRO_FLO_CO.")
    extrude.warning("2 buildings have no height.")
    once.labelled("merge").warning("2 buildings have no height.")
    assert log.lines == [("info", "The DEM is reprojected on the fly."),
                         ("info", "extrude: Heights: 3 from GRO_FLO_CO."),
                         ("warning", "extrude: 2 buildings have no height.")]
