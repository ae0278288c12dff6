"""The chain in a Python program of its own, for ``wit:citymodel`` inside QGIS.

QGIS runs Python embedded, from the shared library ``libpython3.x.so``; Debian's ``python3`` program is built
without position-independent code and ran the same Python work (loops, formatting) about 30 % faster on this
project's machine (0.47 vs 0.63 s, 0.52 vs 0.68 s, six alternating runs). Most of the chain's own steps are
such work (the CityGML writer, the texture table, the checks of the validation), so wit:citymodel runs the chain
in a separate Python process, the one that runs the steps beside (``interpreter.core_python``): the same
folder and the same report as in QGIS's process, its messages and progress relayed as they come, Cancel
passed on (the run then stops at its next check and removes what it staged, as in-process).

The parent sends the run as JSON on the child's standard input (a line), then ``cancel`` on a line if the
user cancels; the child reports as every core step in a program of its own does (``infra.step_process``: its
messages, progress and refusal as records on standard error, its report as JSON on standard output). A height
expression is QGIS's own: a run with one stays in QGIS's process (``runs_apart``).
"""
from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from ..buildings.heights import HeightOptions
from ..cityjson.writer import SequencePart
from ..infra import interpreter
from ..infra.errors import CanceledError, InputError, WitError
from ..infra.feedback import Feedback
from ..infra.step_process import CANCELED_STATUS, RecordFeedback, pass_on, run_step
from ..prepare.area import StudyArea
from .citymodel import STEP_PROCESS_MODULES, ChainInputs, ChainOptions, ChainReport, run_city_model

MODULE = "wit_plugin.chain.apart"
CANCEL = b"cancel\n"
CANCEL_GRACE = 60.0  # seconds the run gets to stop at its next check and clean up before it is killed
CHAIN_MODULES = (*STEP_PROCESS_MODULES, "lxml")


def runs_apart(options: ChainOptions) -> bool:
    """Whether the run can go to a process of its own: not with a QGIS height expression, nor a tile's own step 1
    (a function of the tile runner)."""
    return options.heights.expression is None and options.part_layers is None


def run_city_model_apart(inputs: ChainInputs, options: ChainOptions, output_dir: str | os.PathLike,
                         feedback: Feedback) -> ChainReport:
    """``run_city_model`` in a Python program of its own (see the module docstring)."""
    with ChainProgram() as program:
        return program.run(inputs, options, output_dir, feedback)


class ChainProgram:
    """The chain's program started ahead, so that its imports (about 0.4 s) overlap the caller's work before the
    run (``rerun``: the inputs' fingerprint); ``run`` gives it the run, leaving the block without one ends it.

    The interpreters ``interpreter.core_python`` would try are tried by starting the chain itself, not a check
    first (that cost about half a second per run): one that cannot import the core ends before its first record,
    and the next is tried; when none can, ``core_python`` says why for each.
    """

    def __init__(self) -> None:
        self.pythons = interpreter.candidate_pythons()
        self.ahead = _ChainProcess(self.pythons[0]) if self.pythons else None

    def __enter__(self) -> ChainProgram:
        return self

    def __exit__(self, *exc_info: object) -> None:
        if self.ahead is not None:  # (not given a run: its standard input closes, it ends without one)
            self.ahead.end()

    def run(self, inputs: ChainInputs, options: ChainOptions, output_dir: str | os.PathLike,
            feedback: Feedback) -> ChainReport:
        request = json.dumps({"inputs": dataclasses.asdict(inputs), "options": _options_values(options),
                              "output": str(output_dir)}).encode("utf-8") + b"\n"
        for python in self.pythons:
            run, self.ahead = self.ahead or _ChainProcess(python), None
            run.send(request)
            if run.relay(feedback):
                return run.outcome()
        interpreter.core_python(None, CHAIN_MODULES, MODULE)  # (raises: naming what each Python lacks)
        raise InputError("No Python runs the chain.")  # (a Python that imports it ended early: it is not one)


class _ChainProcess:
    """One start of the chain's program: its run sent, its records relayed, its end read."""

    def __init__(self, python: str):
        self.process = subprocess.Popen([python, "-m", MODULE], env=interpreter.core_env(),  # nosec B603  # ours
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self.lines: queue.Queue[bytes | None] = queue.Queue()
        self.out = b""
        self.refusals: list[WitError] = []
        self.last_words: list[str] = []
        self.records = 0
        self._readers = [threading.Thread(target=_lines, args=(self.process.stderr, self.lines), daemon=True),
                         threading.Thread(target=self._read_out, daemon=True)]
        for reader in self._readers:
            reader.start()

    def send(self, request: bytes) -> None:
        with contextlib.suppress(OSError):  # (it ended already: its status says why)
            self.process.stdin.write(request)  # type: ignore[union-attr]
            self.process.stdin.flush()  # type: ignore[union-attr]

    def end(self) -> None:
        """End a start not given a run (it ends at once when its standard input closes; killed if not)."""
        with contextlib.suppress(OSError):
            self.process.stdin.close()  # type: ignore[union-attr]
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
        self._finish()

    def _read_out(self) -> None:
        self.out = self.process.stdout.read()  # type: ignore[union-attr]

    def relay(self, feedback: Feedback) -> bool:
        """Relay until it ends; False if it could not start the chain (an import failed before any record)."""
        try:
            self._relay(feedback)
        finally:
            self._finish()
        return not (self.process.returncode and not self.records
                    and any("ImportError" in line or "ModuleNotFoundError" in line for line in self.last_words))

    def _finish(self) -> None:
        """Killed if still running, its output read to the end, its pipes closed."""
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        for reader in self._readers:
            reader.join()
        for pipe in (self.process.stdin, self.process.stdout, self.process.stderr):
            with contextlib.suppress(OSError):
                pipe.close()  # type: ignore[union-attr]

    def _relay(self, feedback: Feedback) -> None:
        """Pass the records on to ``feedback`` until the program ends (a refusal into ``refusals``), and the user's
        Cancel on to it (killed if it has not stopped ``CANCEL_GRACE`` seconds later); its other lines (Python's
        own last words, a library's messages) go to ``last_words``."""
        canceled_at: float | None = None
        while True:
            try:
                raw = self.lines.get(timeout=0.1)
            except queue.Empty:
                raw = b""
            if raw is None:
                break
            line = raw.decode("utf-8", "replace").rstrip("\n")
            if pass_on(line, feedback, self.refusals):
                self.records += 1
            elif line.strip():
                self.last_words.append(line)
            if canceled_at is None and feedback.is_canceled():
                canceled_at = time.monotonic()
                with contextlib.suppress(OSError):
                    self.process.stdin.write(CANCEL)  # type: ignore[union-attr]
                    self.process.stdin.flush()  # type: ignore[union-attr]
            elif canceled_at is not None and time.monotonic() - canceled_at > CANCEL_GRACE:
                self.process.kill()
        self.process.wait()

    def outcome(self) -> ChainReport:
        status = self.process.returncode
        if status == 0:
            return ChainReport(**json.loads(self.out.decode("utf-8")))
        if status == CANCELED_STATUS:
            raise CanceledError("Cancelled by the user.")
        if self.refusals:
            raise self.refusals[-1]
        how = f"signal {-status}" if status < 0 else f"status {status}"
        raise WitError(f"The chain's process ended with {how}: " + " | ".join(self.last_words[-5:] or ["no message"]))


def _lines(stream: Any, lines: queue.Queue) -> None:
    for raw in iter(stream.readline, b""):
        lines.put(raw)
    lines.put(None)


def _options_values(options: ChainOptions) -> dict[str, Any]:
    values = {f.name: getattr(options, f.name) for f in dataclasses.fields(options)}
    values["area"] = dataclasses.asdict(options.area)
    values["heights"] = {k: v for k, v in dataclasses.asdict(options.heights).items() if k != "expression"}
    values["cityjson_part"] = dataclasses.asdict(options.cityjson_part) if options.cityjson_part else None
    values["part_layers"] = None
    return values


def _options_from(values: dict[str, Any]) -> ChainOptions:
    part = values["cityjson_part"]
    return ChainOptions(**{**values, "area": StudyArea(**values["area"]), "heights": HeightOptions(**values["heights"]),
                           "cityjson_part": SequencePart(**{**part, "translate": tuple(part["translate"])})
                           if part else None})


class _ChainFeedback(RecordFeedback):
    """The chain program's feedback: canceled once the parent says so on standard input."""

    def listen(self, pending: bytes) -> None:
        """Wait for the parent's Cancel (or its end: then stop too, nobody waits for the result)."""
        while CANCEL not in pending:
            chunk = os.read(0, 4096)  # (the raw descriptor: no buffer lock held when the program ends)
            if not chunk:
                break
            pending += chunk
        self.canceled.set()


def _request() -> tuple[dict[str, Any] | None, bytes]:
    """The run the parent sent (its first line on standard input) and what came after it; None if its standard
    input closed first (it started the program ahead, then needed no run)."""
    received = b""
    while b"\n" not in received:
        chunk = os.read(0, 1 << 16)
        if not chunk:
            return None, b""
        received += chunk
    line, _, rest = received.partition(b"\n")
    return json.loads(line), rest


def main() -> int:
    request, rest = _request()
    if request is None:
        return 0
    feedback = _ChainFeedback()
    threading.Thread(target=feedback.listen, args=(rest,), daemon=True).start()
    interpreter.THIS_PROGRAM_IS_OURS = True
    return run_step(lambda fb: run_city_model(ChainInputs(**request["inputs"]), _options_from(request["options"]),
                                              Path(request["output"]), fb).as_dict(), feedback)


if __name__ == "__main__":
    sys.exit(main())
