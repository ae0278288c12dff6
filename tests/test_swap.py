"""Replacing a folder whole (``io.fileio.swap_folder``): a reader finds the old folder or the new one, never a mix —
after a failure (put back at once) or a real kill between the two renames (put back by ``restore_folder``)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from wit_plugin.infra.io.fileio import restore_folder, swap_folder

ROOT = Path(__file__).resolve().parents[1]


def _folders(tmp_path: Path) -> tuple[Path, Path, Path]:
    target, new, old = tmp_path / "tiles" / "a", tmp_path / "staging" / "new-a", tmp_path / "staging" / "old-a"
    for folder, text in ((target, "old"), (new, "new")):
        folder.mkdir(parents=True)
        (folder / "model.gml").write_text(text)
        (folder / "build.json").write_text(text)
    return target, new, old


def _contents(folder: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in folder.iterdir()}


def test_a_swap_puts_the_new_folder_in_place_and_removes_the_old(tmp_path):
    target, new, old = _folders(tmp_path)
    swap_folder(new, target, old)
    assert _contents(target) == {"model.gml": "new", "build.json": "new"} and not new.exists() and not old.exists()
    swap_folder(None, target, old)  # a tile that failed: nothing of the old build stays
    assert not target.exists() and not old.exists()


def test_a_swap_that_fails_between_its_renames_puts_the_old_folder_back(tmp_path, monkeypatch):
    target, new, old = _folders(tmp_path)
    replace = os.replace

    def second_fails(source, destination):
        if Path(source) == new:
            raise OSError("disk gone")
        replace(source, destination)

    monkeypatch.setattr(os, "replace", second_fails)
    with pytest.raises(OSError, match="disk gone"):
        swap_folder(new, target, old)
    assert _contents(target) == {"model.gml": "old", "build.json": "old"} and not old.exists()


def test_a_swap_killed_between_its_renames_is_put_back_by_the_next_one(tmp_path):
    """A real SIGKILL of the process after the first rename: the old folder waits aside, none is in place; the
    next swap (or ``restore_folder``, which the runner calls first) puts it back."""
    target, new, old = _folders(tmp_path)
    code = ("import os, signal, sys\nfrom pathlib import Path\n"
            "from wit_plugin.infra.io import fileio\nreplace = os.replace\n"
            "def killed(source, destination):\n"
            "    if Path(source) == Path(sys.argv[1]):\n        os.kill(os.getpid(), signal.SIGKILL)\n"
            "    replace(source, destination)\n"
            "os.replace = killed\n"
            "fileio.swap_folder(Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3]))\n")
    result = subprocess.run([sys.executable, "-c", code, str(new), str(target), str(old)], cwd=ROOT,
                            env=dict(os.environ, PYTHONPATH=str(ROOT)), check=False)
    assert result.returncode == -signal.SIGKILL
    assert not target.exists() and _contents(old) == {"model.gml": "old", "build.json": "old"}
    restore_folder(target, old)
    assert _contents(target) == {"model.gml": "old", "build.json": "old"} and not old.exists()
    restore_folder(target, old)  # nothing to do twice
    assert _contents(target) == {"model.gml": "old", "build.json": "old"}
