"""Shared by the per-step benchmarks: a command's wall and CPU seconds and peak RSS, and the same
algorithm run the way users run it, through ``qgis_process`` (``scripts/qgis-process``).

A ``qgis_process`` run includes QGIS's start-up (loading the providers and plugins, ~1.5 s of
CPU); ``qgis_startup`` measures it in the same run with a trivial algorithm, so a benchmark can
print the algorithm's own share beside the core-only figure.
"""
from __future__ import annotations

import os
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Measured:
    seconds: float
    cpu_seconds: float  # user + system, children included
    peak_mb: float
    stdout: str

    def as_dict(self) -> dict:
        return {"seconds": round(self.seconds, 2), "cpu_seconds": round(self.cpu_seconds, 2),
                "peak_rss_mb": round(self.peak_mb)}


def run(cmd: list[str], env: dict[str, str] | None = None) -> Measured:
    """Run ``cmd`` under ``/usr/bin/time``; raise with its output if it fails."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as stats:
        proc = subprocess.run(["/usr/bin/time", "-f", "%e %U %S %M", "-o", stats.name, *cmd],
                              capture_output=True, text=True, env={**os.environ, **(env or {})})
        if proc.returncode:
            raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
        wall, user, system, rss_kb = stats.read().split()[-4:]
    return Measured(float(wall), float(user) + float(system), int(rss_kb) / 1024, proc.stdout)


def qgis_process(algorithm: str, parameters: dict[str, str]) -> Measured:
    """``scripts/qgis-process run algorithm --NAME=value …``: what a batch user runs."""
    return run([str(ROOT / "scripts" / "qgis-process"), "run", algorithm,
                *(f"--{name}={value}" for name, value in parameters.items())])


def qgis_startup() -> Measured:
    """A trivial algorithm through qgis_process: QGIS's start-up, to subtract from the runs above."""
    with tempfile.TemporaryDirectory() as tmp:
        return qgis_process("native:extenttolayer", {"INPUT": "0,1,0,1 [EPSG:5186]", "OUTPUT": f"{tmp}/extent.gpkg"})
