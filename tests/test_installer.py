"""The installer core (wit_plugin.infra.installer) without QGIS: the package table, the folder on sys.path, the
merge of a finished install, and the Linux rules that keep a bundled C library out of QGIS."""
from __future__ import annotations

import os
import sys

import pytest

from wit_plugin.infra import installer
from wit_plugin.infra.errors import WitError


def by_module(name: str) -> installer.Package:
    return next(p for p in installer.PACKAGES if p.module == name)


def test_one_table_names_every_package_the_algorithms_need():
    from wit_citymodel.processing_provider.provider import ALGORITHMS

    needed = {module for algorithm in ALGORITHMS for module in algorithm.requirements}
    assert needed <= {p.module for p in installer.PACKAGES}
    assert by_module("triangle").candidates == ("triangle>=20230923", "triangle3")
    assert "non-commercial" in by_module("triangle").licence
    assert by_module("shapely").needs_system_geos and by_module("shapely").linux_package == "python3-shapely"


def test_the_folder_is_per_python_version_inside_the_profile(tmp_path):
    folder = installer.packages_folder(tmp_path)
    assert folder == tmp_path / "python" / "wit_citymodel_deps" / f"py{sys.version_info[0]}.{sys.version_info[1]}"


def test_activate_puts_the_folder_before_site_packages_once_and_on_the_core_processes_path(tmp_path, monkeypatch):
    from wit_plugin.infra import interpreter

    monkeypatch.setattr(sys, "path", ["/usr/lib/python3.11", "/usr/lib/python3/dist-packages", "/x/site-packages"])
    monkeypatch.setattr(interpreter, "PACKAGE_FOLDERS", [])
    monkeypatch.setattr(installer, "PACKAGE_FOLDERS", interpreter.PACKAGE_FOLDERS)
    monkeypatch.setenv("PYTHONPATH", "/y")
    installer.activate(tmp_path / "deps")
    installer.activate(tmp_path / "deps")
    assert sys.path == ["/usr/lib/python3.11", str(tmp_path / "deps"), "/usr/lib/python3/dist-packages",
                        "/x/site-packages"]
    assert interpreter.core_env()["PYTHONPATH"].split(os.pathsep) == [str(interpreter.CORE_ROOT),
                                                                       str(tmp_path / "deps"), "/y"]


def test_merge_replaces_a_package_and_its_old_metadata_and_merges_plain_folders(tmp_path):
    folder, staging, replaced = tmp_path / "deps", tmp_path / "staging", tmp_path / "replaced"
    for path, text in {"shapely/__init__.py": "old", "shapely/old_only.py": "", "shapely-2.0.1.dist-info/METADATA": "",
                       "bin/dask": "old", "keep/__init__.py": "kept"}.items():
        (folder / path).parent.mkdir(parents=True, exist_ok=True)
        (folder / path).write_text(text)
    new = {"shapely/__init__.py": "new", "Shapely-2.1.2.dist-info/METADATA": "", "bin/dask-worker": "new"}
    for path, text in new.items():
        (staging / path).parent.mkdir(parents=True, exist_ok=True)
        (staging / path).write_text(text)
    installer._merge(staging, folder, replaced)
    assert (folder / "shapely" / "__init__.py").read_text() == "new"
    assert not (folder / "shapely" / "old_only.py").exists()  # a package is replaced whole
    assert not (folder / "shapely-2.0.1.dist-info").exists() and (folder / "Shapely-2.1.2.dist-info").is_dir()
    assert (folder / "bin" / "dask").read_text() == "old" and (folder / "bin" / "dask-worker").read_text() == "new"
    assert (folder / "keep" / "__init__.py").read_text() == "kept"


@pytest.mark.parametrize("version, major", [("1.8.5-2+b1", 1), ("2.0.6-1", 2), ("1:2.2.1-1", 2), ("(none)", 0)])
def test_debian_versions_are_read_by_their_upstream_major(version, major):
    assert installer._major(version) == major


@pytest.fixture
def linux_without_tools(monkeypatch):
    """A Debian-family Linux whose PATH has apt but no geos-config and no compiler."""
    monkeypatch.setattr(sys, "platform", "linux")
    tools = {"apt-get": "/usr/bin/apt-get", "apt-cache": "/usr/bin/apt-cache"}
    monkeypatch.setattr(installer.shutil, "which", lambda name: tools.get(name))
    monkeypatch.setattr(installer, "_pip_problem", lambda python, tr: (None, [], None))
    candidates = {}
    monkeypatch.setattr(installer, "_apt_candidate", lambda package: candidates.get(package))
    return candidates


def test_shapely_on_debian_sid_takes_the_platform_package(linux_without_tools):
    linux_without_tools["python3-shapely"] = "2.0.6-1"
    with pytest.raises(WitError) as error:
        installer._check_safety([by_module("shapely"), by_module("triangle")], sys.executable, "3.13.1-CAPI-1.19", str)
    message = str(error.value)
    assert "Run: sudo apt install python3-shapely\n" in message
    assert message.startswith("Nothing was installed.") and "shapely: a wheel from PyPI bundles" in message


def test_shapely_on_debian_12_without_build_tools_names_them(linux_without_tools, monkeypatch):
    linux_without_tools["python3-shapely"] = "1.8.5-2+b1"  # shapely 1: not what the plugin needs
    monkeypatch.setattr(installer, "_quiet", lambda command: None)
    with pytest.raises(WitError) as error:
        installer._check_safety([by_module("shapely")], sys.executable, "3.11.1-CAPI-1.17.1", str)
    assert "Run: sudo apt install libgeos-dev gcc python3-dev\n" in str(error.value)


def test_shapely_with_build_tools_and_qgis_geos_is_built_from_source(monkeypatch, tmp_path):
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setattr(installer, "_apt_candidate", lambda package: "1.8.5-2+b1")
    monkeypatch.setattr(installer.shutil, "which", lambda name: f"/usr/bin/{name}")
    (tmp_path / "Python.h").write_text("")
    answers = {"--version": "3.11.1\n", "-c": f"{tmp_path}\n"}
    monkeypatch.setattr(installer, "_quiet", lambda command: answers[command[1]])
    monkeypatch.setattr(installer, "_pip_problem", lambda python, tr: (None, [], None))
    assert installer._check_safety([by_module("shapely"), by_module("pygltflib")], "python3",
                                   "3.11.1-CAPI-1.17.1", str) == (["shapely"], None)
    answers["--version"] = "3.12.0\n"  # development files of another GEOS than QGIS runs
    with pytest.raises(WitError, match="version 3.12.0, but QGIS runs GEOS 3.11.1"):
        installer._check_safety([by_module("shapely")], "python3", "3.11.1-CAPI-1.17.1", str)


def test_pyproj_wheel_is_refused_on_linux_and_pip_problems_join_the_command(linux_without_tools, monkeypatch):
    linux_without_tools["python3-pyproj"] = "3.4.1-1+b1"
    monkeypatch.setattr(installer, "_pip_problem",
                        lambda python, tr: ("QGIS's Python has no pip.", ["python3-pip"], None))
    with pytest.raises(WitError) as error:
        installer._check_safety([by_module("pyproj"), by_module("triangle")], sys.executable, None, str)
    assert "Run: sudo apt install python3-pyproj python3-pip\n" in str(error.value)


def test_no_rule_but_pip_on_windows_and_macos(monkeypatch):
    monkeypatch.setattr(sys, "platform", "win32")
    monkeypatch.setattr(installer, "_pip_problem", lambda python, tr: (None, [], None))
    assert installer._check_safety(list(installer.PACKAGES), sys.executable, "3.11.1", str) == ([], None)


def test_pip_runs_in_this_very_python_not_another_of_the_same_version(tmp_path, monkeypatch):
    """Inside qgis_process sys.executable was a pyenv shim of another Python 3.11: it must not be taken."""
    from wit_plugin.infra import interpreter

    other = tmp_path / "python3"
    other.write_text(f"#!/bin/sh\nprintf '{sys.version_info[0]}.{sys.version_info[1]}\\n/opt/elsewhere\\n'\n")
    other.chmod(0o755)
    monkeypatch.setattr(interpreter, "_candidates", lambda: [str(other), sys.executable])
    assert interpreter.this_python() == sys.executable
    monkeypatch.setattr(interpreter, "_candidates", lambda: [str(other)])
    with pytest.raises(WitError, match=f"No interpreter of QGIS's Python .*{other}: Python "):
        interpreter.this_python()
    assert interpreter.this_python(str(other)) == str(other)  # given explicitly: the version must match only


def test_the_python_of_this_installation_is_tried_before_a_shim_that_qgis_process_calls_sys_executable(
        tmp_path, monkeypatch):
    """Inside qgis_process sys.executable was a pyenv shim: tried first, it cost the chain a failed start (0.3 s)
    each run. A virtual environment's own python (sys.executable inside sys.prefix) still comes first."""
    from wit_plugin.infra import interpreter

    prefix, shims, venv = tmp_path / "usr", tmp_path / "pyenv" / "shims", tmp_path / "venv"
    for folder in (prefix / "bin", shims, venv / "bin"):
        folder.mkdir(parents=True)
    for python in (prefix / "bin" / "python3", shims / "python3", venv / "bin" / "python"):
        python.write_text("#!/bin/sh\n")
        python.chmod(0o755)
    monkeypatch.setenv("PATH", str(shims))
    monkeypatch.setattr(sys, "exec_prefix", str(prefix))
    monkeypatch.setattr(sys, "prefix", str(prefix))
    monkeypatch.setattr(sys, "executable", str(shims / "python3"))
    assert interpreter._candidates() == [str(prefix / "bin" / "python3"), str(shims / "python3")]
    monkeypatch.setattr(sys, "prefix", str(venv))  # a virtual environment: its python, then its base's
    monkeypatch.setattr(sys, "executable", str(venv / "bin" / "python"))
    assert interpreter._candidates() == [str(venv / "bin" / "python"), str(prefix / "bin" / "python3"),
                                         str(shims / "python3")]


def test_the_cores_processes_run_their_numeric_libraries_on_one_thread_unless_told_otherwise(monkeypatch):
    """A step beside the next ones and the Dask workers are processes, one per core: OpenBLAS's own threads
    spun on every core in the 3D Tiles export (its CPU time 1.3 × its wall time) and slowed the steps beside it."""
    import subprocess

    from wit_plugin.infra import interpreter

    for name in interpreter.SINGLE_THREADED:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("OMP_NUM_THREADS", "4")  # the user's choice stays
    env = interpreter.core_env()
    assert (env["OPENBLAS_NUM_THREADS"], env["MKL_NUM_THREADS"], env["OMP_NUM_THREADS"]) == ("1", "1", "4")
    threads = ("import os, numpy; a = numpy.ones((300, 300)); a @ a; "
               "print(len(os.listdir('/proc/self/task')))")  # the process's threads once BLAS has run
    child = subprocess.run([sys.executable, "-c", threads], env=dict(env, OMP_NUM_THREADS="1"), capture_output=True,
                           text=True, check=True)
    assert child.stdout.strip() == "1"
