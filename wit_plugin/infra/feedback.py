"""Progress, cancel and log reporting for core functions, independent of QGIS.

Core functions take a ``Feedback`` and call ``progress()``, ``check_canceled()`` and ``info()``.
The Processing glue passes an adapter around ``QgsProcessingFeedback``; scripts and tests pass
the silent default or a ``LoggingFeedback``.
"""
from __future__ import annotations

import logging

from .errors import CanceledError


class Feedback:
    """Silent feedback that never cancels; subclass to report somewhere."""

    def progress(self, percent: float) -> None:
        """Report overall progress in percent (0–100)."""

    def is_canceled(self) -> bool:
        return False

    def info(self, message: str) -> None:
        """Report a line of information for the log."""

    def warning(self, message: str) -> None:
        """Report a problem that did not stop the run."""

    def check_canceled(self) -> None:
        """Raise ``CanceledError`` if the user asked to stop."""
        if self.is_canceled():
            raise CanceledError("Cancelled by the user.")

    def scaled(self, start: float, end: float) -> Feedback:
        """A feedback whose 0–100 maps onto ``start``–``end`` of this one (for sub-steps)."""
        return _ScaledFeedback(self, start, end)


class _ScaledFeedback(Feedback):
    def __init__(self, parent: Feedback, start: float, end: float):
        self._parent, self._start, self._span = parent, start, end - start

    def progress(self, percent: float) -> None:
        self._parent.progress(self._start + self._span * min(max(percent, 0.0), 100.0) / 100.0)

    def is_canceled(self) -> bool:
        return self._parent.is_canceled()

    def info(self, message: str) -> None:
        self._parent.info(message)

    def warning(self, message: str) -> None:
        self._parent.warning(message)


class SaidOnce(Feedback):
    """Passes each distinct message on once: several steps of one run read the same input and each says what it
    finds (the DEM reprojected on the fly, a CRS assumed), which the run's log needs to show only once."""

    def __init__(self, parent: Feedback):
        self._parent = parent
        self._said: set[tuple[str, str]] = set()

    def progress(self, percent: float) -> None:
        self._parent.progress(percent)

    def is_canceled(self) -> bool:
        return self._parent.is_canceled()

    def first(self, kind: str, message: str) -> bool:
        """Whether ``message`` of ``kind`` ("info", "warning") is new (it is then noted as said)."""
        new = (kind, message) not in self._said
        self._said.add((kind, message))
        return new

    def info(self, message: str) -> None:
        if self.first("info", message):
            self._parent.info(message)

    def warning(self, message: str) -> None:
        if self.first("warning", message):
            self._parent.warning(message)

    def labelled(self, label: str) -> Feedback:
        """The messages of a step run beside the others, each said as ``label: message`` unless the same message
        was said before, by the run or by another step (a step beside reads the same DEM as the run)."""
        return _Labelled(self, label)


class _Labelled(Feedback):
    def __init__(self, said: SaidOnce, label: str):
        self._said, self._label = said, label

    def is_canceled(self) -> bool:
        return self._said.is_canceled()

    def info(self, message: str) -> None:
        if self._said.first("info", message):
            self._said.info(f"{self._label}: {message}")

    def warning(self, message: str) -> None:
        if self._said.first("warning", message):
            self._said.warning(f"{self._label}: {message}")


class LoggingFeedback(Feedback):
    """Feedback for scripts: messages go to the ``logging`` module."""

    def __init__(self, logger: logging.Logger | None = None):
        self._log = logger or logging.getLogger("wit_plugin")

    def info(self, message: str) -> None:
        self._log.info(message)

    def warning(self, message: str) -> None:
        self._log.warning(message)


SILENT = Feedback()
