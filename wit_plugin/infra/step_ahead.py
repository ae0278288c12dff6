"""``python -m wit_plugin.infra.step_ahead MODULE [IMPORT...]``: a core step's program started ahead of its run.

A step in a program of its own (``python -m MODULE ARGS``) spends its first 0.2 s or so importing numpy, GDAL,
shapely and its own modules. The chain starts the programs of its steps beside (``chain.programs``) before its
first step, which keeps one core busy while the other has nothing to do: their imports run then, not when the
steps start, with both cores busy. This program imports ``MODULE.__main__`` and the ``IMPORT`` modules the step
needs later, says ``ready`` on its standard output, then waits for its arguments: a JSON list, the first line of
its standard input, read unbuffered (what follows, such as the metrics' go-ahead, stays for the step). It then
runs the step as ``python -m MODULE ARGS`` would; when its standard input ends first (the run stopped, or never
needed the step), it ends.
"""
from __future__ import annotations

import importlib
import json
import os
import sys

READY = "ready"


def main(argv: list[str]) -> int:
    module, *imports = argv
    for name in imports:
        importlib.import_module(name)
    step = importlib.import_module(f"{module}.__main__")
    sys.stdout.write(READY + "\n")
    sys.stdout.flush()
    line = _first_line()
    return step.main(json.loads(line)) if line is not None else 0


def _first_line() -> bytes | None:
    """The first line of standard input, read a byte at a time so that nothing after it is consumed; None if the
    input ends first."""
    received = bytearray()
    while not received.endswith(b"\n"):
        byte = os.read(0, 1)
        if not byte:
            return None
        received += byte
    return bytes(received)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
