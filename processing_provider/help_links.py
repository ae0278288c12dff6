"""Where each algorithm's Help button leads: a section of the README shipped inside the plugin.

The project has no website; the README in the plugin folder is the manual. Anchors are formed the way
GitHub forms them from the heading text (tests/test_provider.py checks each against README.md).
"""
from __future__ import annotations

from pathlib import Path

from qgis.PyQt.QtCore import QUrl

README = Path(__file__).resolve().parents[1] / "README.md"

#: the README section of an algorithm that has its own; the others are described in the table
SECTIONS = {
    "generatesample": "sample-data-witgeneratesample",
    "export3dtiles": "see-the-city-3d-tiles-and-the-offline-web-viewer",
    "citymodeltiles": "a-district-or-a-city-in-tiles-witcitymodeltiles-dask-distributed",
    "installdependencies": "installing-the-dependencies",
}
ALGORITHMS_TABLE = "algorithms-provider-wit"


def help_url(algorithm_id: str) -> str:
    """The local README's section for ``algorithm_id`` (without the ``wit:`` prefix), as a file URL."""
    url = QUrl.fromLocalFile(str(README))
    url.setFragment(SECTIONS.get(algorithm_id, ALGORITHMS_TABLE))
    return url.toString()
