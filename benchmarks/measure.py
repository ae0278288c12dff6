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
        proc = subprocess.run(["/usr/bin/time", "-f", "%e %U %S %M", "-o", stats.name, *cmd], check=False,
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


def through_qgis(algorithm: str, parameters: dict[str, str]) -> dict:
    """The algorithm through qgis_process, with QGIS's start-up measured just before and subtracted."""
    startup = qgis_startup()
    run = qgis_process(algorithm, parameters)
    return {**run.as_dict(), "startup": startup.as_dict(),
            "seconds_without_startup": round(run.seconds - startup.seconds, 2),
            "cpu_without_startup": round(run.cpu_seconds - startup.cpu_seconds, 2)}


def table_line(head: str, core_seconds: float, qgis: dict | None, reference: str, reference_seconds: float) -> str:
    """One case for the printed table: its core figures (``head``), qgis_process's, the reference and
    the wall times as multiples of the reference's (qgis_process's without its start-up)."""
    parts = [head]
    ratios = f"core {core_seconds / reference_seconds:4.1f}×"
    if qgis:
        parts.append(f"qgis_process {qgis['seconds']:5.1f} s, {qgis['seconds_without_startup']:5.1f} s without "
                     f"start-up (CPU {qgis['cpu_without_startup']:5.1f}), peak {qgis['peak_rss_mb']:4d} MB"
                     + ("" if qgis.get("same_bytes", True) else ", OUTPUT DIFFERS"))
        ratios += f", qgis_process {qgis['seconds_without_startup'] / reference_seconds:4.1f}×"
    return " | ".join([*parts, f"{reference}: {ratios}"])
