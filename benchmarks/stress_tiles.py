"""Stress test of tiled runs (not in CI, not timed): the 16-tile run and the killed-worker scenario, many times.

A rare failure (a tile failed once with ``TypeError: 'NoneType' object is not subscriptable`` inside
``terrain.triangulate_terrain``; the killed-worker test failed once in CI) needs many runs to show again. Each
repetition must give the reference result exactly — every tile's status, buildings, triangles and
the bytes of its ``model.gml`` — and no failed tile; anything else is printed with the tile's error.

* ``run``: ``run_tiles`` on the 4 × 4 block of whole 1:1,000 sheets of ``bench_tiles.py`` (its
  generated sample), an embedded scheduler and 2 worker processes, a fresh output folder each time.
* ``kill``: the same run on a stock ``dask scheduler`` that cannot import the core
  (``tests/stock_scheduler.py``) and 2 ``dask worker`` processes (``--threads`` threads each; more
  than one runs tiles side by side in one process), started once and reused by every repetition
  (workers carry state from tile to tile, as on a real cluster); during each run a worker running a
  tile is killed (SIGKILL) at a random moment. Dask must run its tile again: the run ends complete.
  Staging folders left in the tiles by the killed attempt are counted (a finished run removes them).

Dask's worker profiler samples the running task's frames every 10 ms and holds them (and what their
locals hold) while it digests them, longer on a loaded machine; ``--profile-interval 1ms`` samples ten
times as often, so that faults of that kind show within fewer runs on an idle machine.

    .venv/bin/python benchmarks/stress_tiles.py [--runs 10] [--kills 10] [--threads 1] [--tiles 16] [--seed 1]
                                                [--profile-interval 10ms]

Prints one line per repetition and a summary; writes out/bench/tiles/stress.json; exit status 1 when
any repetition failed or differed.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "out" / "bench" / "tiles"
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def fingerprint(report) -> dict[str, tuple]:
    """Per tile: status, buildings, triangles and the SHA-256 of its model.gml."""
    out = Path(report.output)
    prints = {}
    for row in report.rows:
        gml = out / row["gml"] if row.get("gml") else None
        digest = hashlib.sha256(gml.read_bytes()).hexdigest()[:16] if gml and gml.is_file() else None
        prints[row["sheet"]] = (row["status"], row.get("buildings"), row.get("triangles"), digest)
    return prints


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    """A stock scheduler (no core) and ``workers`` ``dask worker`` processes with the core, logging to ``logs``."""

    def __init__(self, python: str, workers: int, threads: int, logs: Path):
        from wit_plugin.infra.interpreter import core_env

        logs.mkdir(parents=True, exist_ok=True)
        self.address = f"tcp://127.0.0.1:{free_port()}"
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        scheduler = [python, "-I", str(ROOT / "tests" / "stock_scheduler.py"), "--host", "127.0.0.1", "--port",
                     self.address.rsplit(":", 1)[1], "--no-dashboard"]
        worker = [python, "-m", "distributed.cli.dask_worker", self.address, "--nthreads", str(threads),
                  "--memory-limit", "0", "--no-dashboard"]
        self.processes = [self._start(scheduler, env, logs / "scheduler.log", cwd=logs)]
        self.processes += [self._start(worker, core_env(), logs / f"worker{k}.log") for k in range(workers)]
        from distributed import Client

        with Client(self.address, timeout=60) as client:
            client.wait_for_workers(workers, timeout=120)

    @staticmethod
    def _start(command: list[str], env: dict, log: Path, cwd: Path | None = None) -> subprocess.Popen:
        with open(log, "ab") as sink:
            return subprocess.Popen(command, env=env, cwd=cwd, start_new_session=True, stdout=sink,
                                    stderr=subprocess.STDOUT)

    def stop(self) -> None:
        from wit_plugin.sheetrun.runner import stop_workers

        stop_workers(self.processes)


class Killer(threading.Thread):
    """Waits for a worker to run a tile, then for a random ``delay``, then kills a worker running a tile."""

    def __init__(self, address: str, delay: float):
        super().__init__(daemon=True)
        self.address, self.delay, self.killed = address, delay, []

    def _busy(self, client) -> dict:
        busy = {w: [str(k) for k in keys if str(k).startswith("wit-tile-")] for w, keys in client.processing().items()}
        return {w: keys for w, keys in busy.items() if keys}

    def run(self) -> None:
        from distributed import Client

        with Client(self.address, timeout=30) as client:
            deadline = time.monotonic() + 300
            while not self._busy(client) and time.monotonic() < deadline:
                time.sleep(0.05)
            time.sleep(self.delay)
            while time.monotonic() < deadline:
                busy = self._busy(client)
                if busy:
                    worker, keys = next(iter(busy.items()))
                    pid = next(iter(client.run(os.getpid, workers=[worker]).values()))
                    os.kill(pid, signal.SIGKILL)
                    self.killed = [k.split("-")[2] for k in keys]
                    return
                time.sleep(0.05)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10, help="repetitions of the 16-tile run (embedded scheduler)")
    parser.add_argument("--kills", type=int, default=10, help="repetitions of the killed-worker run (stock scheduler)")
    parser.add_argument("--threads", type=int, default=1, help="threads per worker in the killed-worker runs")
    parser.add_argument("--tiles", type=int, default=16, choices=[1, 4, 16])
    parser.add_argument("--max-edge", type=float, default=5.0)
    parser.add_argument("--seed", type=int, default=1, help="of the kill moments")
    parser.add_argument("--profile-interval", default=None, help="Dask's worker profiler interval (default 10ms)")
    args = parser.parse_args()
    if args.profile_interval:  # the workers of both scenarios inherit this process's environment
        os.environ["DASK_DISTRIBUTED__WORKER__PROFILE__INTERVAL"] = args.profile_interval
    return stress(args)


def stress(args: argparse.Namespace) -> int:
    """The repetitions of ``args``; 1 when any failed or differed."""
    import shapely
    from bench_tiles import blocks

    from wit_plugin.chain import ChainInputs, ChainOptions
    from wit_plugin.prepare.area import StudyArea
    from wit_plugin.sample import SampleConfig, generate_sample
    from wit_plugin.sheetrun.plan import tile_of
    from wit_plugin.sheetrun.runner import run_tiles, worker_python

    folder = OUT / "sample"  # bench_tiles.py's
    if not (folder / "sample_manifest.json").is_file():
        print(f"generating the sample {folder}", flush=True)
        shutil.rmtree(folder, ignore_errors=True)
        generate_sample(folder, SampleConfig(radius_m=1400.0, seed=42, ortho_pixel_size=0.5))
    files = json.loads((folder / "sample_manifest.json").read_text(encoding="utf-8"))["files"]
    inputs = ChainInputs([str(folder / "ortho")], str(folder / files["dem"]), str(folder / files["buildings"]),
                         str(folder / files["roads"]), str(folder / files["districts"]))
    options = ChainOptions(area=None, max_edge=args.max_edge, metrics=False, tiles3d=False)
    area = StudyArea.polygon(shapely.union_all([tile_of(s, "EPSG:5186").polygon for s in blocks(args.tiles)])
                             .buffer(-0.01), "EPSG:5186")
    work = OUT / "stress"
    shutil.rmtree(work, ignore_errors=True)
    rng = random.Random(args.seed)
    results, reference = [], None

    def check(scenario: str, k: int, run, seconds: float, **extra) -> None:
        nonlocal reference
        prints = fingerprint(run)
        failed = {r["sheet"]: r["error"] for r in run.rows if r["status"] == "failed"}
        reference = reference or (prints if not failed else None)
        differ = sorted(s for s in prints if reference and prints[s] != reference.get(s))
        leftovers = sorted(str(p.relative_to(run.output)) for p in Path(run.output).glob(".wit-staging/*"))
        result = {"scenario": scenario, "run": k, "seconds": round(seconds, 1), "done": run.count("done"),
                  "empty": run.count("empty"), "failed": failed, "differ": differ, "leftovers": leftovers,
                  "buildings": run.buildings, **extra}
        results.append(result)
        ok = not failed and not differ and not leftovers
        print(f"{scenario} {k + 1}: {'ok' if ok else 'FAILED'} {seconds:.1f} s, {result['done']} done, "
              f"{result['empty']} empty, {len(failed)} failed, {len(differ)} differ, {len(leftovers)} staging left, "
              f"{run.buildings} buildings" + "".join(f" {k}={v}" for k, v in extra.items()), flush=True)
        for sheet, error in failed.items():
            print(f"  {sheet}: {error}", flush=True)
        for sheet in differ:
            print(f"  {sheet}: {prints[sheet]} != {reference[sheet]}", flush=True)
        for path in leftovers:
            print(f"  left: {path}", flush=True)
        if ok:
            shutil.rmtree(run.output, ignore_errors=True)
        else:
            print(f"  kept for inspection: {run.output}", flush=True)

    for k in range(args.runs):
        start = time.perf_counter()
        run = run_tiles(inputs, options, work / f"run{k}", area, scale=1000, workers=2)
        check("run", k, run, time.perf_counter() - start)
    if args.kills:
        cluster = Cluster(worker_python(), 2, args.threads, work / "logs")
        try:
            for k in range(args.kills):
                killer = Killer(cluster.address, rng.uniform(0.0, 20.0))
                killer.start()
                start = time.perf_counter()
                run = run_tiles(inputs, options, work / f"kill{k}", area, scale=1000, scheduler=cluster.address)
                seconds = time.perf_counter() - start
                killer.join()
                check("kill", k, run, seconds, delay=round(killer.delay, 1), killed=killer.killed)
        finally:
            cluster.stop()
    bad = [r for r in results if r["failed"] or r["differ"] or r["leftovers"]]
    summary = {"runs": args.runs, "kills": args.kills, "threads": args.threads, "tiles": args.tiles,
               "profile_interval": args.profile_interval or "10ms",
               "tile_runs": sum(r["done"] + r["empty"] + len(r["failed"]) for r in results),
               "bad_repetitions": len(bad), "failed_tiles": sum(len(r["failed"]) for r in results),
               "kills_that_hit_a_tile": sum(bool(r.get("killed")) for r in results),
               "seconds": round(sum(r["seconds"] for r in results), 1)}
    print(json.dumps(summary), flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "stress.json").write_text(json.dumps({"summary": summary, "results": results}, indent=1), encoding="utf-8")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
