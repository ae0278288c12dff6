"""Atomic outputs: nothing under the final name unless the write completed."""
from __future__ import annotations

import pytest

from wit_plugin.infra.errors import InputError
from wit_plugin.infra.io.fileio import atomic_file, atomic_files, ensure_writable_dir


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
    with pytest.raises(RuntimeError):  # a folder made for the run goes too; the existing one stays
        with atomic_files([tmp_path / "new" / "a.shp"]) as tmp:
            (tmp / "a.shp").write_text("half")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_unwritable_output_folder_is_a_clear_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(InputError, match="not writable"):
        ensure_writable_dir(blocker / "sub")


def test_core_steps_refuse_an_output_over_their_input(tmp_path):
    """Scripts that call the core directly get the same refusal, before anything is read or written."""
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.prepare.vectors import PrepareConfig, prepare_vectors
    from wit_plugin.terrain.build import triangulate_terrain as triangulate

    source = tmp_path / "buildings.shp"
    source.write_bytes(b"not read")
    (tmp_path / "buildings.dbf").write_bytes(b"not read either")
    with pytest.raises(InputError, match=r"would overwrite the input .*buildings\.shp \(through .*buildings\.dbf\)"):
        prepare_vectors(str(source), None, None, StudyArea.circle(127.1, 37.5, 100), tmp_path / "buildings.dbf",
                        PrepareConfig())
    with pytest.raises(InputError, match=r"output .*buildings\.shp would overwrite the input"):
        prepare_vectors(str(source), None, None, StudyArea.circle(127.1, 37.5, 100), tmp_path / "p.gpkg",
                        PrepareConfig(stats_csv=str(source)))
    with pytest.raises(InputError, match=r"would overwrite the input .*dem\.tif"):
        triangulate(str(tmp_path / "dem.tif"), None, None, tmp_path / "dem.tif", str(source))
    assert source.read_bytes() == b"not read" and sorted(p.name for p in tmp_path.iterdir()) == [
        "buildings.dbf", "buildings.shp"]
