"""The chain in a Python program of its own (``chain.apart``), as wit:citymodel runs it from QGIS: the same
folder and report as in-process, its messages and progress relayed, Cancel and refusals passed back."""
from __future__ import annotations

import contextlib
import dataclasses
import gc
import os
import re
import sys
import time
import warnings
from pathlib import Path

import pytest

from wit_plugin.buildings.heights import HeightOptions
from wit_plugin.chain import apart
from wit_plugin.chain.citymodel import ChainInputs, ChainOptions, run_city_model
from wit_plugin.chain.rerun import update_city_model
from wit_plugin.cityjson.writer import SequencePart
from wit_plugin.infra.errors import CanceledError, InputError, MissingDependencyError
from wit_plugin.infra.feedback import Feedback
from wit_plugin.prepare.area import StudyArea
from wit_plugin.sample import SampleConfig, generate_sample

SUSEO = (127.1020, 37.4876)


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    return generate_sample(tmp_path_factory.mktemp("sample"), SampleConfig(radius_m=300.0, seed=5,
                                                                             ortho_pixel_size=1.0))


def _inputs(sample, **kwargs) -> ChainInputs:
    base = dict(ortho=[str(sample.ortho_tiles[0].parent)], dem=str(sample.dem), buildings=str(sample.buildings),
                roads=str(sample.roads), districts=str(sample.districts))
    return ChainInputs(**{**base, **kwargs})


def _options(**kwargs) -> ChainOptions:
    return ChainOptions(**{**dict(area=StudyArea.circle(*SUSEO, 150.0), max_edge=15.0), **kwargs})


class _Log(Feedback):
    def __init__(self, cancel_at_step: str | None = None):
        self.infos, self.warnings, self.percents = [], [], []
        self.cancel_at_step, self.canceled = cancel_at_step, False

    def info(self, message: str) -> None:
        self.infos.append(message)
        if self.cancel_at_step and message.startswith("Step ") and f": {self.cancel_at_step}" in message:
            self.canceled = True  # the user's Cancel as that step starts, whatever the machine's speed

    def warning(self, message: str) -> None:
        self.warnings.append(message)

    def progress(self, percent: float) -> None:
        self.percents.append(percent)

    def is_canceled(self) -> bool:
        return self.canceled


def test_the_chain_apart_writes_what_the_chain_writes_here(sample, tmp_path):
    """Byte for byte the same model and metrics, the same report (but its timings), the same messages and the same
    progress (to a tenth of a percent)."""
    here_log, apart_log = _Log(), _Log()
    here = run_city_model(_inputs(sample), _options(), tmp_path / "here", here_log)
    there = apart.run_city_model_apart(_inputs(sample), _options(), tmp_path / "apart", apart_log)
    for name in ("model.gml", "metrics.csv", "metrics_buildings.csv"):
        assert (tmp_path / "apart" / name).read_bytes() == (tmp_path / "here" / name).read_bytes(), name
    same = {"seconds", "wall_seconds"}
    expected = {k: (v.replace(str(tmp_path / "here"), str(tmp_path / "apart")) if isinstance(v, str) else v)
                for k, v in here.as_dict().items() if k not in same}
    assert {k: v for k, v in there.as_dict().items() if k not in same} == expected
    assert list(there.seconds) == list(here.seconds)
    def said(messages, folder):  # (staging folders have random names; steps beside end in any order)
        return sorted(re.sub(r"\.wit-run-[^/]+", ".wit-run", m.replace(str(tmp_path / folder), "OUT"))
                      for m in messages if not m.startswith("Seconds per step"))

    assert said(apart_log.infos, "apart") == said(here_log.infos, "here") and len(here_log.infos) > 40
    assert said(apart_log.warnings, "apart") == said(here_log.warnings, "here")
    shown, last = [], None  # the chain's own progress, a value per change of a tenth of a percent
    for percent in here_log.percents:
        if int(percent * 10) != last:
            shown.append(round(percent, 1))
            last = int(percent * 10)
    assert apart_log.percents == shown and shown[-1] == 100.0 and len(shown) >= 20


def test_a_refusal_in_the_chain_apart_is_the_same_refusal(sample, tmp_path, monkeypatch):
    with pytest.raises(InputError) as here:
        run_city_model(_inputs(sample, dem=str(tmp_path / "missing.tif")), _options(), tmp_path / "here")
    with pytest.raises(InputError) as there:
        apart.run_city_model_apart(_inputs(sample, dem=str(tmp_path / "missing.tif")), _options(), tmp_path / "apart",
                                   _Log())
    assert str(there.value) == str(here.value) and "missing.tif" in str(there.value)
    assert list((tmp_path / "apart").iterdir()) == []
    shadow = tmp_path / "shadow"  # a meshoptimizer that cannot be imported, in the chain's process only
    shadow.mkdir()
    (shadow / "meshoptimizer.py").write_text("raise ImportError('not here')\n")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, (str(shadow), os.environ.get("PYTHONPATH")))))
    with pytest.raises(MissingDependencyError, match="meshoptimizer"):  # the kind of refusal comes back too
        apart.run_city_model_apart(_inputs(sample), _options(tiles3d_web=True), tmp_path / "web", _Log())


def test_cancel_reaches_the_chain_apart_and_nothing_is_left(sample, tmp_path):
    """Cancel while the chain runs: it stops at its next check, removes its staging folder and ends; the steps it
    ran beside end with it."""
    started = time.perf_counter()
    with pytest.raises(CanceledError):
        apart.run_city_model_apart(_inputs(sample), _options(), tmp_path / "city", _Log(cancel_at_step="terrain"))
    assert time.perf_counter() - started < 30
    assert list((tmp_path / "city").iterdir()) == []
    assert _step_programs_running() == []  # (those started ahead and those handed their run)


def _step_programs_running() -> list[str]:
    """The command lines of the chain's step programs (``chain.programs``) running on this machine."""
    running = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        with contextlib.suppress(OSError):
            text = cmdline.read_bytes().replace(b"\0", b" ").decode("utf-8", "replace")
            if "wit_plugin.infra.step_ahead" in text:
                running.append(text)
    return running


def test_update_city_model_runs_apart_unless_a_qgis_expression_needs_this_process(sample, tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(apart.ChainProgram, "run", lambda self, *args: calls.append("apart") or run_city_model(*args))
    update_city_model(_inputs(sample), _options(metrics=False, tiles3d=False), tmp_path / "a", apart=True)
    assert calls == ["apart"]
    with_expression = _options(metrics=False, tiles3d=False,
                               heights=HeightOptions(expression_text='"floors" * 3', expression=lambda row: 9.0))
    assert not apart.runs_apart(with_expression)
    update_city_model(_inputs(sample), with_expression, tmp_path / "b", apart=True)
    assert calls == ["apart"]  # (here: the expression is QGIS's)


def test_the_chain_program_started_ahead_ends_at_once_when_no_run_is_needed():
    """update_city_model starts the program before the fingerprint (its imports meanwhile); an unchanged build
    then needs no run: the program ends cleanly when its standard input closes, nothing left open or running."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ResourceWarning)
        with apart.ChainProgram() as program:
            process = program.ahead.process
            time.sleep(0.5)  # (mid-import)
        gc.collect()
    assert process.returncode == 0
    assert [str(w.message) for w in caught if issubclass(w.category, ResourceWarning)] == []


def test_the_run_goes_to_the_chain_apart_and_back_whole():
    """Every option, nested ones included, reaches the chain's process as it was set."""
    options = ChainOptions(area=StudyArea.from_district_code("역삼동"), max_edge=7.5, triangulator=1,
                           heights=HeightOptions(height_field="HEIGHT", storey_height=3.3, expression_column="h"),
                           outside_ortho="untextured", keep_work=True, tiles3d_web=True, encoding="CP949",
                           cityjson=True, cityjson_part=SequencePart((1.0, 2.0, 3.0), "_s1", "../x"))
    again = apart._options_from(apart._options_values(options))
    assert again == options and isinstance(again.cityjson_part.translate, tuple)
    assert {f.name for f in dataclasses.fields(ChainOptions)} <= set(apart._options_values(options))


def test_the_chain_apart_stops_when_its_parent_is_gone(sample, tmp_path):
    """Its standard input closes with the parent: it cancels itself (no orphan keeps building)."""
    import json
    import subprocess

    from wit_plugin.infra.interpreter import core_env

    request = json.dumps({"inputs": dataclasses.asdict(_inputs(sample)), "options": apart._options_values(_options()),
                          "output": str(tmp_path / "city")})
    child = subprocess.Popen([sys.executable, "-m", apart.MODULE], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, env=core_env())
    child.stdin.write(request.encode() + b"\n")
    child.stdin.flush()
    for line in child.stderr:  # its records, until the terrain step starts (whatever the machine's speed)
        if b": terrain" in line:
            break
    child.stdin.close()
    child.stdin = None  # (closed: communicate only reads)
    _, err = child.communicate(timeout=60)
    assert child.returncode == apart.CANCELED_STATUS, err[-2000:]
    assert not (tmp_path / "city").exists() or list((tmp_path / "city").iterdir()) == []


def test_a_python_that_cannot_import_the_core_is_passed_over(sample, tmp_path, monkeypatch):
    """The chain is started with each interpreter in turn (no check started first); one that cannot import the core
    ends before its first record and the next is tried; when the configured one cannot, the refusal says why."""
    fake = tmp_path / "python3"
    fake.write_text("#!/bin/sh\necho \"ModuleNotFoundError: No module named 'numpy'\" >&2\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setattr(apart.interpreter, "candidate_pythons", lambda: [str(fake), sys.executable])
    with warnings.catch_warnings(record=True) as caught:  # (the passed-over start's pipes were left open: QGIS
        warnings.simplefilter("always", ResourceWarning)  # printed a ResourceWarning for each)
        report = apart.run_city_model_apart(_inputs(sample), _options(metrics=False, tiles3d=False),
                                            tmp_path / "city", _Log())
        gc.collect()
    assert [str(w.message) for w in caught if issubclass(w.category, ResourceWarning)] == []
    assert report.valid and (tmp_path / "city" / "model.gml").is_file()
    monkeypatch.undo()
    monkeypatch.setenv("WIT_WORKER_PYTHON", str(fake))
    with pytest.raises(InputError, match=r"The worker Python .*python3 cannot run the core: .*numpy"):
        apart.run_city_model_apart(_inputs(sample), _options(), tmp_path / "none", _Log())
    assert not (tmp_path / "none").exists() or list((tmp_path / "none").iterdir()) == []
