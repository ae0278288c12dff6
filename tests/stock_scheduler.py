"""A stock ``dask scheduler`` that cannot import the core, as on a managed cluster.

Managed clusters (Kubernetes, HPC, Coiled) run a scheduler with dask and distributed only; the core
is installed on the workers. This launcher starts ``distributed``'s own scheduler command with the
core made unimportable in its process: run in isolated mode (``python -I``: no ``PYTHONPATH``, no
current folder on ``sys.path``), every ``sys.path`` entry holding a ``wit_plugin`` is removed, and an
import hook refuses ``wit_plugin`` whatever path might still lead to it. The tests ask the running
scheduler to import the core (``Client.run_on_scheduler``) and expect ``ModuleNotFoundError``.

Usage: python -I tests/stock_scheduler.py [dask scheduler options …]
"""
import importlib.abc
import sys
from pathlib import Path

CORE = "wit_plugin"


class NoCore(importlib.abc.MetaPathFinder):
    """Refuses the core and its modules, as a Python without them would."""

    def find_spec(self, name, path=None, target=None):
        if name == CORE or name.startswith(CORE + "."):
            raise ModuleNotFoundError(f"No module named {name!r} (a stock scheduler)", name=name)


def main() -> None:
    sys.path[:] = [p for p in sys.path if not (Path(p or ".") / CORE).exists()]
    sys.meta_path.insert(0, NoCore())
    from distributed.cli.dask_scheduler import main as dask_scheduler

    dask_scheduler()


if __name__ == "__main__":
    main()
