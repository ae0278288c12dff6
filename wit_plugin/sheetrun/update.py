"""A run into an existing output is an update: which tiles are kept, built again, added or removed, and
how a tile built again takes its place.

Each tile folder holds its record (``build.json``: the fingerprint of what it was built from and its index
row), written into the folder before the folder is moved into place: a tile's files and its record always
move together. A tile is kept when its record has the fingerprint the run computes and its files are all
there; otherwise it is built again, with the reason (the settings and inputs that changed; or that it had
failed, or had no record). The index follows the records: at the start of a run its rows are the kept
tiles' records and, for the tiles to build, ``pending`` with why (their old files stay until replaced, but
are never called done); each tile built then replaces its folder whole (``commit_tile``) before its row
says so. A run killed between the two finds the folder's record and the index rewritten from it.
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path

from ..chain.fingerprint import Fingerprint, read_record
from ..chain.rerun import FILES_MISSING, NO_RECORD, rebuild_reason
from ..infra.io.fileio import restore_folder, swap_folder
from .index import DONE, EMPTY, FAILED, PENDING, update_row
from .plan import Tile
from .worker import STAGED, STAGING_DIR, TILES_DIR, tile_folder

FAILED_BEFORE = "failed before"
NEW = "new tile"  # (reasons hold no comma: a tile's reasons are joined by ", ")


@dataclass
class UpdatePlan:
    """What a run does with each tile; ``rows``: the index's rows at its start (by sheet)."""

    kept: list[str] = field(default_factory=list)
    build: dict[str, str] = field(default_factory=dict)  # sheet → why (the added ones: NEW)
    removed: list[str] = field(default_factory=list)
    rows: dict[str, dict] = field(default_factory=dict)

    @property
    def added(self) -> list[str]:
        return [sheet for sheet, reason in self.build.items() if reason == NEW]

    @property
    def rebuilt(self) -> dict[str, str]:
        return {sheet: reason for sheet, reason in self.build.items() if reason != NEW}


def old_folder(output: Path, sheet: str) -> Path:
    """Where a tile's previous folder waits while the new one takes its place."""
    return output / STAGING_DIR / f"old-{sheet}"


def plan_update(output: Path, tiles: list[Tile], fingerprints: dict[str, Fingerprint], previous: dict[str, dict],
                force: bool = False) -> UpdatePlan:
    """Compare each tile's record in ``output`` with its fingerprint (``previous``: the index's rows before the
    run; ``force``: build every tile)."""
    plan = UpdatePlan()
    for tile in tiles:
        sheet = tile.sheet
        restore_folder(tile_folder(output, sheet), old_folder(output, sheet))  # a replacement killed midway
        folder = tile_folder(output, sheet)
        record = read_record(folder)
        row = previous.get(sheet) or {}
        reason = rebuild_reason(fingerprints[sheet], record, folder, force) if record else _first_reason(row, folder)
        if record and not reason:  # (no record: there is always a reason)
            plan.kept.append(sheet)
            plan.rows[sheet] = record["row"]
            continue
        plan.build[sheet] = reason
        plan.rows[sheet] = {**(record["row"] if record else row), "status": PENDING, "reason": reason}
    planned = {t.sheet for t in tiles}
    plan.removed = sorted(s for s in set(previous) | _tile_folders(output) if s not in planned)
    return plan


def _first_reason(row: dict, folder: Path) -> str:
    """Why a tile without a record is built: its index ``row`` (if any) and its ``folder`` tell."""
    if row.get("status") == FAILED:
        return FAILED_BEFORE  # (why: the index's error)
    if folder.exists():
        return NO_RECORD  # made by an earlier version, or not finished
    return FILES_MISSING if row.get("status") in (DONE, EMPTY) else NEW


def _tile_folders(output: Path) -> set[str]:
    """The tile folders a run made in ``output`` (those with a record)."""
    return {p.parent.name for p in (output / TILES_DIR).glob("*/build.json")}


def commit_tile(output: Path, sheet: str, row: dict) -> dict:
    """Put the tile a worker built (``row[STAGED]``; none: it failed, and its old files go) in its place, then
    its row in the index; the row as recorded."""
    row = dict(row)
    staged = row.pop(STAGED, None)
    swap_folder(output / staged if staged else None, tile_folder(output, sheet), old_folder(output, sheet))
    update_row(output, sheet, row)
    return row


def remove_tiles(output: Path, sheets: list[str]) -> None:
    """The folders of tiles that left the run (their rows are gone from the index already)."""
    for sheet in sheets:
        shutil.rmtree(tile_folder(output, sheet), ignore_errors=True)
        shutil.rmtree(old_folder(output, sheet), ignore_errors=True)
