"""The colour store's tables and columns, and the cells the quadtree makes (see the package docstring)."""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..infra.errors import InputError

DEFAULT_TABLE = "color_cells"


DEFAULT_TOLERANCE = 12.0


DEFAULT_BLOCK_SIZE = 256


METRICS = ("rms", "max")


FORMAT = "wit-colorstore"


FORMAT_VERSION = 1


CORNERS = ("lb", "rb", "rt", "lt")


LATTICE_COLUMNS = ("c0", "r0", "c1", "r1")


COLOR_COLUMNS = tuple(f"{corner}_{band}" for corner in CORNERS for band in "rgb")


CELL_COLUMNS = ("level", *LATTICE_COLUMNS, *COLOR_COLUMNS)


_QUERY_COLUMNS = CELL_COLUMNS  # what queries fetch


_TABLE_NAME = re.compile(r"^(?:[A-Za-z_][A-Za-z0-9_]*\.)?[A-Za-z_][A-Za-z0-9_]*$")


@dataclass
class _Cells:
    """Leaf cells of one block: level, lattice bounds (c0, r0, c1, r1) and corner colours."""

    level: np.ndarray  # (n,) int
    lattice: np.ndarray  # (n, 4) int64
    colors: np.ndarray  # (n, 12) uint8, in COLOR_COLUMNS order
    over: int = 0  # cells at max depth still over the tolerance


def _check_table_name(table: str, schema_allowed: bool) -> None:
    if not _TABLE_NAME.match(table) or (not schema_allowed and "." in table):
        raise InputError(f"Table name {table!r} is invalid: use letters, digits and underscores"
                         f"{' (optionally schema.table)' if schema_allowed else ''}, not starting with a digit.")
