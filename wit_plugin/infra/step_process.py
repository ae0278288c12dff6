"""A core step in a Python program of its own, and how the program that started it reads it back: one protocol
for the chain's steps beside its others (``python -m wit_plugin.<step>``: the merge, the solids, the metrics, the 3D
Tiles export) and for the whole chain apart from QGIS (``chain.apart``).

The program writes its messages, progress and refusal on standard error as JSON records, one a line after
``RECORD`` (so a message may hold line breaks, and a refusal keeps its kind), and its result as JSON on standard
output; it ends with status 0 (done), ``REFUSED_STATUS`` (its refusal record says why) or ``CANCELED_STATUS``. Any
other line on standard error (Python's own last words, a library's message) is not a record: the reader keeps it
apart (``pass_on`` says which lines were records).
"""
from __future__ import annotations

import json
import sys
import threading
from collections.abc import Callable
from typing import Any

from .errors import CanceledError, InputError, MissingDependencyError, WitError
from .feedback import Feedback
from .io import jsontext

RECORD = "WIT-RECORD "
REFUSED_STATUS = 2
CANCELED_STATUS = 3
_REFUSALS: dict[str, type[WitError]] = {kind.__name__: kind for kind in (InputError, MissingDependencyError, WitError)}


class RecordFeedback(Feedback):
    """The feedback of a program run by the protocol: records on standard error; canceled once ``canceled`` is set
    (by whoever listens to the parent: the chain apart does)."""

    def __init__(self) -> None:
        self.canceled = threading.Event()
        self._shown = -1

    def _record(self, **record: Any) -> None:
        sys.stderr.write(RECORD + json.dumps(record) + "\n")
        sys.stderr.flush()

    def progress(self, percent: float) -> None:
        tenths = int(percent * 10)
        if tenths != self._shown:  # (a line per 0.1 %, not per call)
            self._shown = tenths
            self._record(progress=round(percent, 1))

    def is_canceled(self) -> bool:
        return self.canceled.is_set()

    def info(self, message: str) -> None:
        self._record(info=message)

    def warning(self, message: str) -> None:
        self._record(warning=message)

    def refuse(self, error: WitError) -> None:
        """Why the run stopped (the reader raises the same kind of error with the same message)."""
        self._record(refused=str(error), error=type(error).__name__)


def run_step(step: Callable[[Feedback], object], feedback: RecordFeedback | None = None) -> int:
    """Run ``step`` with ``feedback`` (a new ``RecordFeedback`` if none): its result printed as JSON and status 0,
    or the core's refusal as a record and ``REFUSED_STATUS``, or ``CANCELED_STATUS``."""
    feedback = feedback or RecordFeedback()
    try:
        result = step(feedback)
    except CanceledError:
        return CANCELED_STATUS
    except WitError as exc:
        feedback.refuse(exc)
        return REFUSED_STATUS
    sys.stdout.write(jsontext.dumps(result))
    return 0


def pass_on(line: str, feedback: Feedback, refusals: list[WitError], progress: bool = True) -> bool:
    """Pass one line of a program's standard error on to ``feedback`` if it is a record (its refusal into
    ``refusals``; its progress only with ``progress``); False for any other line."""
    if not line.startswith(RECORD):
        return False
    record = json.loads(line[len(RECORD):])
    if "refused" in record:
        refusals.append(_REFUSALS.get(record.get("error", ""), InputError)(record["refused"]))
    elif "progress" in record:
        if progress:
            feedback.progress(float(record["progress"]))
    elif "warning" in record:
        feedback.warning(record["warning"])
    else:
        feedback.info(record.get("info", ""))
    return True
