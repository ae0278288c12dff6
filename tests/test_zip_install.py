"""A new user's path, headless: the plugin from `make package`'s ZIP in a fresh QGIS profile, with no
virtual environment anywhere on the path; the algorithms first say what is missing, wit:installdependencies
installs it into the profile (doing what its message says when it names a system command), then
wit:generatesample and wit:citymodel run through qgis_process.

Marked ``zip_install`` (and ``slow``) so that another QGIS (the QGIS 3.44 chroot) runs it unchanged:
``pytest -m zip_install``. On Debian 12 (QGIS 3.22) it builds shapely 2 against the system GEOS; on Debian
testing/sid the message names python3-shapely, which the test installs as it says. Where QGIS's Python has no
pip (the chroot: Debian's QGIS does not pull python3-pip), pip must run from its own wheel, fetched from the
package index, and no system package may be asked for it."""
from __future__ import annotations

import json
import os
import re
import subprocess
import zipfile

import pytest
from conftest import ROOT

pytestmark = [pytest.mark.slow, pytest.mark.zip_install, pytest.mark.qgis_facing]


def clean_env(profile) -> dict:
    """The machine's environment without the project's .venv: QGIS's own Python and the profile only."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    return dict(env, QGIS_CUSTOM_CONFIG_PATH=str(profile), QT_QPA_PLATFORM="offscreen", PYTHONNOUSERSITE="1")


def qgis_process(env, *args, timeout=3600) -> subprocess.CompletedProcess:
    return subprocess.run(["qgis_process.bin", *args], capture_output=True, text=True, env=env, timeout=timeout)


def output(run: subprocess.CompletedProcess) -> dict:
    """qgis_process --json's answer: "results" and the "log"."""
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-4000:]
    return json.loads(run.stdout[run.stdout.index("{"):])


def results(run: subprocess.CompletedProcess) -> dict:
    return output(run)["results"]


def has_pip(env) -> bool:
    return subprocess.run(["/usr/bin/python3", "-m", "pip", "--version"], capture_output=True, env=env).returncode == 0


def do_what_the_message_says(message: str) -> bool:
    """Run the system command the installer names ("Run: sudo apt install …"); False when it names none."""
    found = re.search(r"Run: sudo apt install ([a-z0-9.+\- ]+)", message)
    if not found:
        return False
    root = [] if os.geteuid() == 0 else ["sudo"]
    subprocess.run([*root, "apt-get", "-o", "DPkg::Lock::Timeout=600", "install", "-y", "-qq",
                    *found.group(1).split()], check=True, env=dict(os.environ, DEBIAN_FRONTEND="noninteractive"),
                   capture_output=True)
    return True


MISSING = "Run 'Install Python dependencies' (wit:installdependencies, group Tools)"
SAMPLE = ("--RADIUS=300", "--SEED=5", "--ORTHO_PIXEL_SIZE=2")


def chain_arguments(sample: dict) -> list[str]:
    """wit:citymodel's inputs on the sample wit:generatesample wrote."""
    return [f"--ORTHO_INPUT={sample['ORTHO_FOLDER']}", f"--DEM={sample['DEM']}", f"--BUILDINGS={sample['BUILDINGS']}",
            f"--ROADS={sample['ROADS']}", f"--DISTRICTS={sample['DISTRICTS']}", "--RADIUS=300", "--MAX_EDGE=20"]


def test_zip_in_a_fresh_profile_installs_its_dependencies_then_runs_the_chain(tmp_path):
    out = subprocess.run(["bash", str(ROOT / "scripts" / "package.sh")], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout.strip().splitlines()[-1]
    profile = tmp_path / "profile"
    plugins = profile / "profiles" / "default" / "python" / "plugins"
    plugins.mkdir(parents=True)
    zipfile.ZipFile(ROOT / out).extractall(plugins)
    env = clean_env(profile)
    enable = qgis_process(env, "plugins", "enable", "wit_citymodel", timeout=300)
    assert enable.returncode == 0, enable.stderr

    # A fresh profile lacks what the chain needs (no platform packages pygltflib or a triangulator; Debian 12's
    # shapely is 1.x): the help says so and the algorithms refuse, writing nothing. Where the platform's shapely
    # is 2 (Debian testing/sid) the sample generator already runs and the chain is what refuses.
    help_before = qgis_process(env, "help", "wit:citymodel", timeout=300)
    assert MISSING in help_before.stdout
    sample_before = qgis_process(env, "--json", "run", "wit:generatesample", *SAMPLE, f"--OUTPUT={tmp_path / 'early'}",
                                 timeout=600)
    if sample_before.returncode != 0:
        assert MISSING in sample_before.stdout + sample_before.stderr
        assert not (tmp_path / "early").exists()
    else:
        chain_before = qgis_process(env, "run", "wit:citymodel", *chain_arguments(results(sample_before)),
                                    f"--OUTPUT={tmp_path / 'nothing'}", timeout=600)
        assert chain_before.returncode != 0
        assert MISSING in chain_before.stdout + chain_before.stderr
        assert not (tmp_path / "nothing").exists()

    pip_before = has_pip(env)
    install = qgis_process(env, "--json", "run", "wit:installdependencies")
    if not pip_before:  # pip comes from its wheel: no system package is named for it
        assert "python3-pip" not in install.stdout + install.stderr
    if install.returncode != 0 and do_what_the_message_says(install.stdout + install.stderr):
        install = qgis_process(env, "--json", "run", "wit:installdependencies")
    answer = output(install)
    folder = profile / "profiles" / "default" / "python" / "wit_citymodel_deps"
    assert answer["results"]["FOLDER"].startswith(str(folder))
    assert [p.name for p in folder.iterdir()] == [os.path.basename(answer["results"]["FOLDER"])]  # no work folder
    commands = [line[len("Running: "):] for line in answer["log"]["info"] if line.startswith("Running: ")]
    # QGIS's Python runs pip: its own, else pip's wheel in the work folder beside the package folder
    pip = "-m pip" if pip_before else rf"{re.escape(str(folder))}/\.install-\w+/pip-[\d.]+-py3-none-any\.whl/pip"
    assert commands and re.match(rf"/usr/bin/python3 {pip} install --no-cache-dir", commands[-1]), commands[-1]
    assert has_pip(env) == pip_before  # nothing installed outside the profile
    assert all("--dry-run" in command for command in commands[:-1]) and "--target" in commands[-1]
    assert answer["results"]["INSTALLED"]  # a fresh profile lacks at least the triangulator

    again = results(qgis_process(env, "--json", "run", "wit:installdependencies"))
    assert again["INSTALLED"] == ""  # everything present now: pip is not run again

    sample = results(qgis_process(env, "--json", "run", "wit:generatesample", *SAMPLE,
                                  f"--OUTPUT={tmp_path / 'sample'}"))
    assert sample["BUILDINGS_WRITTEN"] > 50 and sample["TILES_WRITTEN"] >= 1
    model = results(qgis_process(env, "--json", "run", "wit:citymodel", *chain_arguments(sample),
                                 f"--OUTPUT={tmp_path / 'model'}"))
    assert model["VALID"] is True and model["ERROR_COUNT"] == 0
    assert model["BUILDINGS_WRITTEN"] > 50 and os.path.getsize(model["GML"]) > 100_000
