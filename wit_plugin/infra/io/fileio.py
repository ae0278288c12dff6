"""Atomic output: write under a temporary name beside the target, rename when complete.

A failed or cancelled run therefore never leaves a half-written file under the final name. A file is
written by ``atomic_file``; results of several files and folders are written into a ``staging_folder``
inside the output folder and moved into place by ``publish`` (``atomic_files`` does both for a caller
that knows its targets' names).

Nothing lost: ``refuse_overlap`` tells, before anything is written, whether an output would
replace or share a file with an input (symbolic and hard links, ``file|layername=`` sources and
the sidecars of shapefiles, rasters and GeoPackages included). ``protect`` registers a run's
inputs so that every atomic write of the run refuses to replace one of them, whoever the caller.
"""
from __future__ import annotations

import contextlib
import contextvars
import os
import shutil
import sqlite3
import tempfile
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path

from ..errors import InputError
from .layersource import LayerSource

#: files that travel with a main file (same stem): what replacing the main file also replaces
SIDECARS = {
    ".shp": (".shx", ".dbf", ".prj", ".cpg", ".qix", ".sbn", ".sbx", ".shp.xml", ".qmd"),
    ".tif": (".tif.aux.xml", ".tif.ovr", ".tif.msk", ".tfw", ".tifw", ".wld", ".aux.xml"),
    ".gpkg": (".gpkg-wal", ".gpkg-shm", ".gpkg-journal"),
}
SIDECARS[".shx"] = SIDECARS[".dbf"] = SIDECARS[".prj"] = SIDECARS[".cpg"] = (".shp", *SIDECARS[".shp"])
SIDECARS[".tiff"] = tuple(s.replace(".tif", ".tiff") for s in SIDECARS[".tif"])
SIDECARS[".vrt"] = (".vrt.aux.xml", ".vrt.ovr")

_PROTECTED: contextvars.ContextVar[tuple[Path, ...]] = contextvars.ContextVar("wit_protected_inputs", default=())


def source_file(source: str | os.PathLike | LayerSource) -> Path:
    """The file of a data source: ``file.gpkg|layername=x`` → ``file.gpkg``."""
    return LayerSource.parse(source).file


def file_family(path: str | os.PathLike) -> list[Path]:
    """``path`` and the sidecar files that belong to it (shapefile parts, raster and SQLite sidecars)."""
    path = source_file(path)
    suffix = path.suffix.lower()
    stem = path.with_suffix("")
    family = [path]
    for extra in SIDECARS.get(suffix, ()):
        for spelling in (extra, extra.upper()):
            family.append(Path(f"{stem}{spelling}"))
    return family


def sidecar(path: str | os.PathLike, suffix: str) -> Path | None:
    """The file beside ``path`` with ``suffix`` (either case), if there is one."""
    path = Path(path)
    return next((p for p in (path.with_suffix(suffix), path.with_suffix(suffix.upper())) if p.exists()), None)


def vector_file_problem(source: str | os.PathLike | LayerSource) -> str | None:
    """What is wrong with a vector source file that GDAL would only call unreadable; None if nothing is seen.

    ``source`` may be ``file|layername=x``; sources that are not files (databases, memory) pass.
    """
    text, layer_source = str(source), LayerSource.parse(source)
    path = layer_source.file
    if not path.suffix or "://" in text or text.startswith(("memory", "dbname=", "PG:")):
        return None
    if not path.exists():
        return f"{path} does not exist."
    if path.is_dir():
        return None
    if path.stat().st_size == 0:
        return f"{path} is empty (0 bytes)."
    suffix = path.suffix.lower()
    if suffix == ".shp":
        if path.stat().st_size < 100:
            return f"{path} is truncated: a shapefile's header alone has 100 bytes."
        parts = {ext: sidecar(path, ext) for ext in (".shx", ".dbf")}
        missing = [ext for ext, found in parts.items() if found is None]
        if missing:
            return (f"{path.name} has no {' and no '.join(missing)} beside it in {path.parent}: a shapefile needs "
                    "its .shp, .shx and .dbf files together (copy all the files of the layer).")
        empty = [found.name for found in parts.values() if found is not None and found.stat().st_size == 0]
        if empty:
            return f"{', '.join(empty)} beside {path.name} is empty (0 bytes): copy the layer's files again."
    elif suffix in (".gpkg", ".sqlite"):
        with open(path, "rb") as fh:
            if fh.read(16) != b"SQLite format 3\x00":
                return f"{path} is not a GeoPackage (no SQLite header): the file is damaged or misnamed."
        layer = layer_source.layer
        names = _gpkg_layers(path) if layer and suffix == ".gpkg" else None
        if names is not None and layer not in names:
            return f"{path} has no layer '{layer}'; it has: {', '.join(names) or 'none'}."
    return None


def _gpkg_layers(path: Path) -> list[str] | None:
    """The layer (table) names a GeoPackage lists, read without writing anything beside it; None if unreadable."""
    try:
        with contextlib.closing(sqlite3.connect(f"{path.resolve().as_uri()}?immutable=1", uri=True)) as db:
            return [row[0] for row in db.execute("SELECT table_name FROM gpkg_contents ORDER BY table_name")]
    except sqlite3.Error:
        return None


def _real(path: Path) -> str:
    return os.path.normcase(os.path.realpath(path))


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether two paths name the same file or folder (links resolved; hard links by inode)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return _real(Path(a)) == _real(Path(b))


def _inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` is ``folder`` or lies (at any depth) inside it, links resolved."""
    real, base = _real(path), _real(folder)
    return real == base or real.startswith(base.rstrip(os.sep) + os.sep)


def overlap(output: str | os.PathLike, source: str | os.PathLike, folder: bool = False) -> Path | None:
    """The file through which writing ``output`` would touch the input ``source``, else None.

    A file output clashes when it or one of its sidecars is the input or one of the input's
    (e.g. ``out.dbf`` beside an input ``out.shp``), or an existing file in an input folder; a
    folder output (written into as a whole) clashes when it is the input or holds it at any depth.
    """
    inputs = [p for p in file_family(source) if p == source_file(source) or p.exists()]
    if folder:
        return next((p for p in inputs if _inside(p, source_file(output))), None)
    if source_file(source).is_dir():
        return next((p for p in file_family(output) if p.exists() and _inside(p, source_file(source))), None)
    for written in file_family(output):
        for existing in inputs:
            if same_file(written, existing) or _inside(existing, written):
                return existing
    return None


def refuse_overlap(outputs: Iterable[tuple[str | os.PathLike, bool]],
                   inputs: Iterable[str | os.PathLike | None]) -> None:
    """Raise ``InputError`` when an output (path, is a folder) would replace or share a file with an input
    (inputs not given, None or "", are left out)."""
    given = [i for i in inputs if i]
    for output, folder in outputs:
        if not output:
            continue
        for source in given:
            clash = overlap(output, source, folder)
            if clash is not None:
                raise InputError(overlap_message(str(output), str(source_file(source)), str(clash), folder))


def overlap_message(output: str, source: str, clash: str, folder: bool = False) -> str:
    """The one message for an output that would destroy an input (or a folder output that holds one)."""
    if folder:
        return (f"The output folder {output} holds the input {source}: choose an output folder that holds "
                "none of the inputs. Nothing was written.")
    via = "" if same_file(clash, source) else f" (through {clash})"
    return (f"The output {output} would overwrite the input {source}{via}; choose another output "
            "name or folder. Nothing was written.")


@contextlib.contextmanager
def protect(inputs: Iterable[str | os.PathLike]) -> Iterator[None]:
    """While the block runs, atomic writes refuse to replace any of ``inputs`` (or their sidecars)."""
    token = _PROTECTED.set(_PROTECTED.get() + tuple(source_file(i) for i in inputs if i))
    try:
        yield
    finally:
        _PROTECTED.reset(token)


def _check_protected(target: Path, folder: bool = False) -> None:
    refuse_overlap([(target, folder)], _PROTECTED.get())


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
    _check_protected(target)
    ensure_writable_dir(target.parent)
    fd, tmp_name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.stem}.", suffix=f".tmp{target.suffix}")
    os.close(fd)
    os.unlink(tmp_name)  # drivers want to create the file themselves
    tmp = Path(tmp_name)
    try:
        yield tmp
        _check_protected(target)
        os.replace(tmp, target)
    finally:
        if tmp.exists():
            tmp.unlink()


@contextlib.contextmanager
def staging_folder(output: str | os.PathLike, prefix: str = ".wit-tmp-") -> Iterator[Path]:
    """A new empty folder inside ``output`` (which must exist), removed with what is left in it when the block
    ends however it ends: results written there reach ``output`` only through ``publish``. Inside ``output`` so
    that publishing is a rename on the same file system."""
    folder = Path(tempfile.mkdtemp(prefix=prefix, dir=output))
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def aside_of(target: Path) -> Path:
    """Where ``publish`` keeps the folder ``target`` it replaces until the new one is in place."""
    return target.parent / f".wit-old-{target.name}"


def publish(staging: Path, output: Path) -> list[str]:
    """Move every result in ``staging`` (a ``staging_folder`` of ``output``) into ``output``, replacing older
    results of the same names whole; their names, sorted.

    Every result is checked against the run's protected inputs (``protect``) before the first one moves. A
    file replaces its namesake in one rename; a folder (or a file replacing a folder) by ``swap_folder``, its
    predecessor waiting in ``aside_of(target)`` until then, so a reader finds the old folder or the new one,
    and one killed midway is put back by the next ``publish`` of that name."""
    items = sorted(staging.iterdir())
    for item in items:
        _check_protected(output / item.name, folder=item.is_dir())
    for item in items:
        target = output / item.name
        restore_folder(target, aside_of(target))
        if item.is_dir() or (target.is_dir() and not target.is_symlink()):
            swap_folder(item, target, aside_of(target))
        else:
            os.replace(item, target)
    return [item.name for item in items]


@contextlib.contextmanager
def atomic_files(targets: Sequence[str | os.PathLike]) -> Iterator[Path]:
    """Yield a temporary folder; on success move every file in it into the targets' folder (``publish``).

    For multi-file outputs (a shapefile and its sidecars, an image set): the caller writes
    into the folder under the final file names; nothing appears in the destination on failure.
    A sub-folder written there replaces the destination's folder of that name as a whole. A
    destination folder this call had to create is removed again on failure (when still empty).
    """
    dest = Path(targets[0]).parent
    for target in targets:
        _check_protected(Path(target))
    created = not dest.exists()
    dest = ensure_writable_dir(dest)
    try:
        with staging_folder(dest) as tmp_dir:
            yield tmp_dir
            publish(tmp_dir, dest)
    except BaseException:
        if created:  # a folder made for this run only would be a partial output
            with contextlib.suppress(OSError):
                dest.rmdir()
        raise


def copy_images(images: Mapping[str, str | os.PathLike], folder: Path) -> None:
    """Copy each image (name relative to ``folder`` → its source) into ``folder``, which they replace whole: a
    model's texture folder holds its own images only, and a copy that fails or is cancelled halfway leaves the
    folder as it was (``atomic_files``)."""
    with atomic_files([folder]) as staged:
        for name, source in images.items():
            target = staged / folder.name / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)


def swap_folder(new: Path | None, target: Path, old: Path) -> None:
    """Put the folder ``new`` (None: nothing) in ``target``'s place: the previous ``target`` moves to ``old``
    first and is deleted last, so a reader finds the whole old folder or the whole new one. A failed second
    rename puts the old folder back; killed between the two, ``old`` stays and ``target`` is missing:
    ``restore_folder`` (run first by whoever swaps there next) puts it back."""
    if target.exists() or target.is_symlink():
        old.parent.mkdir(parents=True, exist_ok=True)
        os.replace(target, old)
    try:
        if new is not None:
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(new, target)
    except BaseException:
        restore_folder(target, old)
        raise
    _remove(old)


def restore_folder(target: Path, old: Path) -> None:
    """After a ``swap_folder`` that was killed: ``old`` back in ``target``'s place if that is empty, else deleted."""
    if not (old.exists() or old.is_symlink()):
        return
    if target.exists() or target.is_symlink():
        _remove(old)
    else:
        os.replace(old, target)


def _remove(path: Path) -> None:
    """Delete ``path`` whatever it is (a folder with its contents, a file, a link); nothing if it is gone."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)
