"""Atomic outputs: nothing under the final name unless the write completed."""
from __future__ import annotations

import pytest

from wit_plugin.infra.errors import InputError
from wit_plugin.infra.io.fileio import (
    aside_of,
    atomic_file,
    atomic_files,
    copy_images,
    ensure_writable_dir,
    protect,
    publish,
    staging_folder,
)


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


def test_publish_replaces_older_results_whole_and_names_what_it_moved(tmp_path):
    """Files replace files, folders replace folders whole, either replaces the other; a link is replaced, not
    followed; results not published again stay."""
    elsewhere = tmp_path / "elsewhere.txt"
    elsewhere.write_text("kept")
    output = tmp_path / "out"
    (output / "textures").mkdir(parents=True)
    (output / "textures" / "old.jpg").write_text("old")
    (output / "model.gml").write_text("old")
    (output / "was_a_file").write_text("old")
    (output / "was_a_folder").mkdir()
    (output / "link.txt").symlink_to(elsewhere)
    (output / "other.csv").write_text("not published again")
    with staging_folder(output, ".wit-run-") as staging:
        (staging / "textures").mkdir()
        (staging / "textures" / "new.jpg").write_text("new")
        (staging / "model.gml").write_text("new")
        (staging / "was_a_file").mkdir()
        (staging / "was_a_folder").write_text("new")
        (staging / "link.txt").write_text("new")
        names = publish(staging, output)
    assert names == ["link.txt", "model.gml", "textures", "was_a_file", "was_a_folder"]
    assert sorted(p.name for p in output.iterdir()) == sorted([*names, "other.csv"])  # no staging, nothing aside
    assert [p.name for p in (output / "textures").iterdir()] == ["new.jpg"]
    assert (output / "model.gml").read_text() == "new" and (output / "was_a_folder").read_text() == "new"
    assert (output / "was_a_file").is_dir() and not (output / "link.txt").is_symlink()
    assert elsewhere.read_text() == "kept"


def test_a_staging_folder_leaves_nothing_on_failure(tmp_path):
    (tmp_path / "model.gml").write_text("old")
    with pytest.raises(KeyboardInterrupt), staging_folder(tmp_path) as staging:
        (staging / "model.gml").write_text("half")
        raise KeyboardInterrupt
    assert [p.name for p in tmp_path.iterdir()] == ["model.gml"] and (tmp_path / "model.gml").read_text() == "old"


def test_publish_refuses_to_replace_an_input_before_moving_anything(tmp_path):
    (tmp_path / "buildings.shp").write_text("input")
    with protect([tmp_path / "buildings.shp"]), staging_folder(tmp_path) as staging:
        (staging / "a.gml").write_text("new")
        (staging / "buildings.dbf").write_text("new")
        with pytest.raises(InputError, match=r"would overwrite the input .*buildings\.shp"):
            publish(staging, tmp_path)
    assert [p.name for p in tmp_path.iterdir()] == ["buildings.shp"]


def test_publish_clears_what_a_killed_publish_left_aside(tmp_path):
    """Killed before it deleted the folder it replaced, a publish leaves that folder aside: the next publish
    of the name gets rid of it first (a folder cannot be renamed onto it) and leaves nothing of it."""
    aside = aside_of(tmp_path / "textures")
    aside.mkdir()
    (aside / "older.jpg").write_text("older")
    (tmp_path / "textures").mkdir()
    (tmp_path / "textures" / "old.jpg").write_text("old")
    with staging_folder(tmp_path) as staging:
        (staging / "textures").mkdir()
        (staging / "textures" / "new.jpg").write_text("new")
        publish(staging, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["textures"]
    assert [p.name for p in (tmp_path / "textures").iterdir()] == ["new.jpg"]


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


def test_copy_images_replaces_the_folder_whole_or_not_at_all(tmp_path, monkeypatch):
    """A model's texture folder (the CityGML and CityJSON writers copy into it): its own images only, and a copy
    that fails halfway leaves the earlier folder as it was, with nothing of the new one beside it."""
    import shutil

    from wit_plugin.infra.io import fileio

    sources = tmp_path / "textures"
    (sources / "atlas").mkdir(parents=True)
    for name, data in (("ground.png", b"g2"), ("atlas/roofs.jpg", b"r2"), ("facade.png", b"f2")):
        (sources / name).write_bytes(data)
    folder = tmp_path / "out" / "model_textures"
    (folder / "atlas").mkdir(parents=True)
    (folder / "ground.png").write_bytes(b"g1")
    (folder / "stale.png").write_bytes(b"s1")  # an image of the earlier model only
    images = {name: sources / name for name in ("ground.png", "atlas/roofs.jpg", "facade.png")}
    copied = []

    def copy_then_fail(source, target):
        if len(copied) == 2:
            raise OSError("No space left on device")
        copied.append(target)
        return shutil.copyfile(source, target)

    monkeypatch.setattr(fileio.shutil, "copyfile", copy_then_fail)
    with pytest.raises(OSError, match="No space"):
        copy_images(images, folder)
    assert sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*")) == ["atlas", "ground.png", "stale.png"]
    assert (folder / "ground.png").read_bytes() == b"g1" and len(copied) == 2
    assert sorted(p.name for p in folder.parent.iterdir()) == ["model_textures"]  # no staging left
    monkeypatch.undo()
    copy_images(images, folder)
    assert {p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*") if p.is_file()} == {
        "ground.png": b"g2", "atlas/roofs.jpg": b"r2", "facade.png": b"f2"}
    assert sorted(p.name for p in folder.parent.iterdir()) == ["model_textures"]
