"""A step run in its own Python process (``python -m wit_plugin.<step>``), as the chain runs the merge, the 3D Tiles
export and the metrics beside its other steps: how the step reports (its messages on stderr, one per line, its
result as JSON on stdout, a refusal as one line and exit status 2) and how the chain reads it back."""
from __future__ import annotations

import logging
import sys
from collections.abc import Callable

from .errors import WitError
from .feedback import Feedback, LoggingFeedback
from .io import jsontext

STEP_INFO, STEP_WARNING = "INFO: ", "WARNING: "


def step_process_feedback() -> Feedback:
    """The feedback of a step's ``__main__``: its messages on stderr as ``INFO: …`` / ``WARNING: …``."""
    logger = logging.getLogger("wit_plugin.step")
    handler = logging.StreamHandler()
    handler.setFormatter(logging.Formatter("%(levelname)s: %(message)s"))
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    logger.propagate = False
    return LoggingFeedback(logger)


def run_step(step: Callable[[Feedback], object]) -> int:
    """Run ``step`` with the step's feedback: its result printed as JSON (exit status 0), or the core's refusal as
    one line on stderr (exit status 2)."""
    try:
        result = step(step_process_feedback())
    except WitError as exc:
        print(str(exc), file=sys.stderr)
        return 2
    print(jsontext.dumps(result))
    return 0


def read_step_line(line: str, feedback: Feedback) -> None:
    """Pass one stderr line of a step's process on to ``feedback`` (the step's, which labels it): an information as
    information, anything else (a warning, or Python's own last words) as a warning."""
    if line.startswith(STEP_INFO):
        feedback.info(line[len(STEP_INFO):])
    else:
        feedback.warning(line.removeprefix(STEP_WARNING))
