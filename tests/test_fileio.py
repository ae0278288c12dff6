"""Atomic outputs: nothing under the final name unless the write completed."""
from __future__ import annotations

import pytest

from wit_plugin.errors import InputError
from wit_plugin.fileio import atomic_file, atomic_files, ensure_writable_dir


def test_atomic_file_appears_only_on_success(tmp_path):
    target = tmp_path / "out.txt"
    with pytest.raises(RuntimeError):
        with atomic_file(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    with atomic_file(target) as tmp:
        assert tmp.suffix == ".txt" and tmp.parent == tmp_path
        tmp.write_text("whole")
    assert target.read_text() == "whole"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_atomic_files_replace_files_and_folders_as_a_whole(tmp_path):
    (tmp_path / "tiles").mkdir()
    (tmp_path / "tiles" / "old.tif").write_text("old")
    (tmp_path / "a.shp").write_text("old")
    with atomic_files([tmp_path / "a.shp", tmp_path / "tiles"]) as tmp:
        (tmp / "a.shp").write_text("new")
        (tmp / "a.dbf").write_text("new")
        (tmp / "tiles").mkdir()
        (tmp / "tiles" / "new.tif").write_text("new")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.dbf", "a.shp", "tiles"]
    assert [p.name for p in (tmp_path / "tiles").iterdir()] == ["new.tif"]
    assert (tmp_path / "a.shp").read_text() == "new"


def test_atomic_files_leave_nothing_on_failure(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with atomic_files([tmp_path / "a.shp"]) as tmp:
            (tmp / "a.shp").write_text("half")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_unwritable_output_folder_is_a_clear_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(InputError, match="not writable"):
        ensure_writable_dir(blocker / "sub")
