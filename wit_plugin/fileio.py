"""Atomic output: write under a temporary name beside the target, rename when complete.

A failed or cancelled run therefore never leaves a half-written file under the final name.
"""
from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterator

from .errors import InputError


def ensure_writable_dir(folder: str | os.PathLike) -> Path:
    """Create ``folder`` if needed and check that files can be created in it."""
    path = Path(folder)
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path, prefix=".wit-write-test-"):
            pass
    except OSError as exc:
        raise InputError(f"Output folder {path} is not writable: {exc.strerror or exc}") from exc
    return path


@contextlib.contextmanager
def atomic_file(target: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; move it onto ``target`` on success.

    The temporary name keeps the target's extension so that format drivers chosen by
    extension (GDAL, OGR) still pick the right one.
    """
    target = Path(target)
    ensure_writable_dir(target.parent)
    fd, tmp_name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.stem}.", suffix=f".tmp{target.suffix}")
    os.close(fd)
    os.unlink(tmp_name)  # drivers want to create the file themselves
    tmp = Path(tmp_name)
    try:
        yield tmp
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()


@contextlib.contextmanager
def atomic_files(targets: list[str | os.PathLike]) -> Iterator[Path]:
    """Yield a temporary folder; on success move every file in it into the targets' folder.

    For multi-file outputs (a shapefile and its sidecars, an image set): the caller writes
    into the folder under the final file names; nothing appears in the destination on failure.
    A sub-folder written there replaces the destination's folder of that name as a whole.
    """
    dest = ensure_writable_dir(Path(targets[0]).parent)
    tmp_dir = Path(tempfile.mkdtemp(dir=dest, prefix=".wit-tmp-"))
    try:
        yield tmp_dir
        for item in list(tmp_dir.iterdir()):
            target = dest / item.name
            if item.is_dir() and target.is_dir():
                os.replace(target, tmp_dir / f".old-{item.name}")  # removed with tmp_dir below
            os.replace(item, target)
    finally:
        shutil.rmtree(tmp_dir, ignore_errors=True)
