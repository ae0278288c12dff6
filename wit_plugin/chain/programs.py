"""The programs of the steps the chain runs beside its own (the merge, the solids, the metrics, the 3D Tiles export),
started ahead of them.

Each such step runs in a Python program of its own, so that the second core works (threads would share the GIL).
Started when its step starts, each program first spent about 0.25 CPU-s importing numpy, GDAL, shapely and its
own modules while both cores were busy; meanwhile, during the chain's first step (the vectors, about a second),
the second core had nothing to do. So ``StepPrograms`` starts them all before that step
(``infra.step_ahead``: each imports, says it is ready and waits) and hands each its arguments when its step comes.
A program that could not import its step, or one not asked for, is never handed a run: the step then starts as
before, in the Python ``interpreter.core_python`` checks, which names what each Python lacks; the ones not handed
a run end with the chain's block (their standard input closes).
"""
from __future__ import annotations

import contextlib
import json
import os
import subprocess
from collections.abc import Callable

from ..infra.interpreter import candidate_pythons, core_env
from ..infra.step_ahead import READY

AHEAD_MODULE = "wit_plugin.infra.step_ahead"
BESIDE_NICENESS = 10
"""How much less CPU priority a step beside gets than the chain (Windows: below normal): the chain's own steps are
the path every later step waits for. The metrics and the 3D Tiles export, given the core the chain leaves idle, end
about with it (the chain's wall time fell from about 28 to 25 s on two cores); the merge and the solids end within
the terrain step when it runs at full speed (3.5 CPU-s beside its 3.5 s on the 1 km sample; the chain 20.1 -> 19.1 s
in three alternating runs), and when they do not, the chain waits for them idle: they get the CPU all the same."""

Started = tuple[subprocess.Popen, int]  # a step's program and the end of its standard input the chain writes to


def start_command(command: list[str]) -> Started:
    """``command`` (a core step in its own Python) started at a lower priority, its standard input a pipe whose
    end the chain holds (not inherited by the chain's other children)."""
    told, tell_end = os.pipe()
    try:
        process = subprocess.Popen(command, env=core_env(), stdin=told,  # nosec B603  # our step, no shell
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                   creationflags=getattr(subprocess, "BELOW_NORMAL_PRIORITY_CLASS", 0))
    except BaseException:
        os.close(tell_end)
        raise
    finally:
        os.close(told)
    _yield_to_the_chain(process.pid)
    return process, tell_end


def _yield_to_the_chain(pid: int) -> None:
    """Lower the priority of the step beside ``pid`` (on Windows its start did: ``BELOW_NORMAL_PRIORITY_CLASS``)."""
    if hasattr(os, "setpriority"):
        with contextlib.suppress(OSError):  # (it ended already)
            os.setpriority(os.PRIO_PROCESS, pid, os.getpriority(os.PRIO_PROCESS, 0) + BESIDE_NICENESS)


class StepPrograms:
    """The steps' programs started ahead (``modules``: each step's module and the other modules it needs), in the
    first Python ``core_python`` would try; ``checked_python`` gives the Python a step starts in when its program
    cannot take the run. Use as a context manager: leaving it ends the programs not handed a run."""

    def __init__(self, modules: dict[str, tuple[str, ...]], checked_python: Callable[[], str]):
        pythons = candidate_pythons()
        self.python = pythons[0] if pythons else ""  # (none: the steps start in the checked one, which says why)
        self._checked_python = checked_python
        self._checked: str | None = None
        self._ahead: dict[str, Started] = {}
        if self.python:
            for module, imports in modules.items():
                self._ahead[module] = start_command([self.python, "-m", AHEAD_MODULE, module, *imports])

    def __enter__(self) -> StepPrograms:
        return self

    def __exit__(self, *exc_info: object) -> None:
        for process, tell_end in self._ahead.values():
            with contextlib.suppress(OSError):
                os.close(tell_end)  # (it ends at once, or when its imports are done)
            try:
                process.communicate(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.communicate()
        self._ahead.clear()

    def interpreter(self) -> str:
        """The Python the steps' commands name: the programs' own; the checked one when there is none, or when one of
        them ended before its run (it could not import its step: the check names what is missing, up front)."""
        if not self.python or any(process.poll() is not None for process, _ in self._ahead.values()):
            return self._checked_interpreter()
        return self.python

    def start(self, command: list[str]) -> Started:
        """``command`` (``[python, "-m", module, *arguments]``, ``python`` the one ``interpreter`` named) in its
        program started ahead when that program is ready for it, else started now (in the checked Python)."""
        if not self.python or command[0] != self.python:
            return start_command(command)  # (named by the check already)
        module = command[2] if command[1:2] == ["-m"] and len(command) > 2 else None
        ahead = self._ahead.pop(module, None) if module else None
        if ahead is not None:
            process, tell_end = ahead
            if process.stdout.readline().strip() == READY:  # type: ignore[union-attr]  # (its imports done)
                with contextlib.suppress(OSError):  # (it ended since: waiting for it says how)
                    os.write(tell_end, json.dumps(command[3:]).encode("utf-8") + b"\n")
                return process, tell_end
            os.close(tell_end)
            process.communicate()
        return start_command([self._checked_interpreter(), *command[1:]])

    def _checked_interpreter(self) -> str:
        if self._checked is None:
            self._checked = self._checked_python()
        return self._checked
