"""The programs of the chain's steps beside, started ahead (wit_plugin.chain.programs, wit_plugin.infra.step_ahead):
imported before their run, handed it as ``python -m`` would run it, never handed one they cannot run, and never
left running."""
from __future__ import annotations

import os
import sys
import time

import pytest
from conftest import RecordingFeedback

from wit_plugin.chain.citymodel import _Clock
from wit_plugin.chain.programs import BESIDE_NICENESS, StepPrograms
from wit_plugin.infra.errors import InputError

STEP = '''
import json, os, sys, time
from pathlib import Path
Path(os.environ["WIT_TEST_MARKS"], "imported").write_text(repr(time.time()))
from wit_plugin.infra.step_process import RecordFeedback


def main(argv):
    started = time.time()
    Path(os.environ["WIT_TEST_MARKS"], "ran").write_text(" ".join(argv))
    RecordFeedback().info("working on " + " | ".join(argv))
    told = sys.stdin.readline()
    print(json.dumps({"argv": argv, "started": started, "told": told, "niceness": os.getpriority(os.PRIO_PROCESS, 0),
                      "modules": sorted(m for m in ("colorsys", "this_is_no_module") if m in sys.modules)}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
'''


@pytest.fixture
def steps(tmp_path, monkeypatch):
    """A package of fake steps on the programs' path: ``fakestep`` (above), ``brokenstep`` (cannot be imported)."""
    for name, code in (("fakestep", STEP), ("brokenstep", "raise ImportError('no module named geos_of_qgis')\n")):
        (tmp_path / "pkg" / name).mkdir(parents=True)
        (tmp_path / "pkg" / name / "__init__.py").write_text("")
        (tmp_path / "pkg" / name / "__main__.py").write_text(code)
    marks = tmp_path / "marks"
    marks.mkdir()
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(tmp_path / "pkg"),
                                                                     os.environ.get("PYTHONPATH")])))
    monkeypatch.setenv("WIT_TEST_MARKS", str(marks))
    monkeypatch.setenv("WIT_WORKER_PYTHON", sys.executable)
    return marks


def _unchecked() -> str:
    raise AssertionError("the checked Python was asked for")


def test_a_step_started_ahead_is_imported_before_its_run_and_runs_as_python_dash_m_would(steps):
    """Imported (with the modules it asks for) before the chain hands it its arguments; then run with exactly those
    arguments (spaces kept), the line told after them still on its standard input, at the lower priority of a step
    beside; its messages and its result reach the chain as any step's beside do."""
    with StepPrograms({"fakestep": ("colorsys",)}, _unchecked) as programs:
        time.sleep(1.5)  # (the chain's first step)
        assert (steps / "imported").is_file()
        log = RecordingFeedback()
        clock = _Clock(log, programs)
        handed = time.time()
        with clock.beside("merge", [programs.interpreter(), "-m", "fakestep", "a b", "--flag", ""]) as merging:
            merging.tell()
            result = merging.wait()
    assert float((steps / "imported").read_text()) < handed
    assert log.infos == ["Step 4/12: merge (in a second process, beside the next steps)",
                         "merge: working on a b | --flag | "]
    assert not log.warnings and result == {
        "argv": ["a b", "--flag", ""], "started": pytest.approx(handed, abs=5), "told": "go\n",
        "niceness": min(os.getpriority(os.PRIO_PROCESS, 0) + BESIDE_NICENESS, 19), "modules": ["colorsys"]}


def test_a_program_that_cannot_import_its_step_is_never_handed_a_run(steps):
    """Its step is refused up front by the checked Python's words (``interpreter``), or started afresh in it; the
    program itself is gone."""
    def checked() -> str:
        raise InputError("No Python imports the plugin's dependencies for a separate process (… geos_of_qgis).")

    with StepPrograms({"brokenstep": (), "fakestep": ()}, checked) as programs:
        broken = programs._ahead["brokenstep"][0]
        broken.wait(timeout=30)
        with pytest.raises(InputError, match="geos_of_qgis"):
            programs.interpreter()
    with StepPrograms({"brokenstep": ()}, lambda: sys.executable) as programs:
        process, tell_end = programs.start([programs.python, "-m", "brokenstep", "x"])
        os.close(tell_end)
        out, err = process.communicate(timeout=30)
        assert process.returncode != 0 and "geos_of_qgis" in err and "-m" in " ".join(process.args)
        assert "wit_plugin.infra.step_ahead" not in process.args  # started afresh in the checked Python


def test_programs_not_handed_a_run_end_with_the_block(steps):
    """A run that stops (or needs no metrics) leaves no program behind, whether it was still importing or waiting
    for its run (then it ends at once, status 0); none of them ran its step."""
    for pause in (0.0, 1.5):
        with StepPrograms({"fakestep": (), "brokenstep": ()}, _unchecked) as programs:
            time.sleep(pause)
            waiting, broken = (programs._ahead[name][0] for name in ("fakestep", "brokenstep"))
        assert waiting.returncode == 0 and broken.returncode == 1
    assert not (steps / "ran").exists()
