"""Installs the plugin's missing Python packages for QGIS's own Python, into a folder of the user's QGIS
profile that the plugin puts on ``sys.path`` when it loads: no root, nothing written outside the profile.

* pip runs in QGIS's Python (``interpreter.this_python``: inside QGIS on Windows and macOS
  ``sys.executable`` is QGIS itself, never started again). Where that Python has no pip, or one older than
  22.2, pip runs from its own wheel, fetched from the package index pip would use into the work folder
  (``pip_bootstrap``); only when that index cannot be reached does the message name a system package.
* A dry run per package (``pip install --dry-run --report``) resolves against what QGIS's Python already
  has, so numpy, lxml, pyproj… stay QGIS's own (numpy is pinned to the running one: GDAL's bindings are
  built against it); it also picks the first requirement that installs (``triangle``, else
  ``triangle3``: the same module, with builds for newer Pythons). Then ``pip install --target
  <staging> --no-deps`` installs exactly what was resolved; the staging folder is merged into the
  profile folder only when pip succeeded and every module imports from it. Cancel kills pip (and its
  build processes) and deletes the staging folder.
* On Linux a wheel that bundles a C library QGIS itself loads (GEOS in shapely, PROJ in pyproj,
  libxml2 in lxml) crashes QGIS (``deps.geos_mismatch``). shapely is then taken from the platform
  when it offers shapely 2 (Debian testing/sid's ``python3-shapely``), else built from source against
  the system GEOS when ``geos-config``, a C compiler and the Python headers are there; otherwise the
  message names the one command that works.

Messages go through ``tr`` (the glue's translation; scripts/i18n.py collects them from this file).
"""
from __future__ import annotations

import importlib
import json
import os
import queue
import re
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import uuid
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, cast

from . import deps, pip_bootstrap
from .errors import CanceledError, WitError
from .feedback import SILENT, Feedback
from .interpreter import PACKAGE_FOLDERS, this_python

#: the profile folder's name, below ``<profile>/python``
FOLDER_NAME = "wit_citymodel_deps"


def _same(text: str) -> str:
    return text


def translatable(text: str) -> str:
    """Mark a literal for scripts/i18n.py; it is translated where it is shown, through ``tr``."""
    return text


TRIANGLE_LICENCE = translatable("triangle (J. R. Shewchuk's Triangle) is free for non-commercial use only; "
                                "commercial use needs a licence from its author.")


@dataclass(frozen=True)
class Package:
    """One package the plugin may install: one line of ``PACKAGES``."""

    #: the import name the core needs (``deps.missing`` checks it)
    module: str
    #: pip requirements, tried in order: the first that installs on this Python wins
    candidates: tuple[str, ...]
    #: installed unless the user deselects it
    default: bool = True
    #: shown before it is installed, when its licence restricts use
    licence: str | None = None
    #: Debian's package, for a module whose Linux wheel bundles a C library that QGIS loads itself
    linux_package: str | None = None
    #: shapely: on Linux, the platform's or one built against the system GEOS
    needs_system_geos: bool = False


#: every package ``wit:installdependencies`` offers
PACKAGES: tuple[Package, ...] = (
    Package("shapely", ("shapely>=2,<3",), linux_package="python3-shapely", needs_system_geos=True),
    # the terrain's triangulators (wit_plugin.terrain.triangulators): CDT (MPL-2.0) by default, Triangle when asked for
    Package("pythoncdt", ("pythoncdt>=2.0.2,<3",)),
    Package("triangle", ("triangle>=20230923", "triangle3"), default=False, licence=TRIANGLE_LICENCE),
    Package("pyproj", ("pyproj",), linux_package="python3-pyproj"),
    Package("lxml", ("lxml",), linux_package="python3-lxml"),
    Package("pygltflib", ("pygltflib>=1.16,<2",)),
    Package("distributed", ("dask[distributed]>=2024.8",)),
)


class InstallError(WitError):
    """A package could not be installed (the message says which and what to do)."""


@dataclass
class Result:
    folder: Path
    #: "name==version" of every distribution installed now
    installed: list[str] = field(default_factory=list)
    #: modules that were present already
    present: list[str] = field(default_factory=list)
    #: modules this process had already imported in another version: QGIS must restart to use the new one
    restart: list[str] = field(default_factory=list)


def packages_folder(profile_dir: str | Path) -> Path:
    """``<profile>/python/wit_citymodel_deps/py3.X``: compiled packages belong to one Python version."""
    return Path(profile_dir) / "python" / FOLDER_NAME / f"py{sys.version_info[0]}.{sys.version_info[1]}"


def activate(folder: Path) -> None:
    """Put ``folder`` on ``sys.path`` before the site-packages, so that what was installed there wins over
    an older copy of the system (Debian 12's shapely 1.8), and on the path of the processes the core starts;
    make imports see what was added since."""
    entry = str(folder)
    if entry not in sys.path:
        site = [i for i, path in enumerate(sys.path) if Path(path).name in ("site-packages", "dist-packages")]
        sys.path.insert(site[0] if site else len(sys.path), entry)
    if entry not in PACKAGE_FOLDERS:
        PACKAGE_FOLDERS.append(entry)  # the core's own processes (workers, the 3D Tiles export) get it too
    sys.path_importer_cache.pop(entry, None)
    importlib.invalidate_caches()


def install(selected: Sequence[Package], folder: Path, *, python: str | None = None, host_geos: str | None = None,
            feedback: Feedback = SILENT, tr: Callable[[str], str] = _same) -> Result:
    """Install the missing ones among ``selected`` into ``folder`` (see the module docstring).

    ``python``: the interpreter to run pip with (default: this Python's own); ``host_geos``: the GEOS
    version QGIS runs (``Qgis.geosVersion()``), which shapely must use on Linux."""
    result = Result(folder)
    clashing = [p for p in selected if p.needs_system_geos and host_geos and not deps.missing([p.module])
                and deps.geos_mismatch(host_geos)]  # a shapely wheel found elsewhere: one of our own must win
    absent = [p for p in selected if deps.missing([p.module])] + clashing
    result.present = [p.module for p in selected if p not in absent]
    if not absent:
        feedback.info(tr("Every selected package is present already: {names}.").format(
            names=", ".join(result.present) or "-"))
        feedback.progress(100)
        return result
    feedback.info(tr("Missing: {names}.").format(names=", ".join(p.module for p in absent)))
    try:
        interpreter = this_python(python)
    except WitError as exc:
        raise InstallError(str(exc)) from exc
    from_source, pip_wheel = _check_safety(absent, interpreter, host_geos, tr)
    for package in absent:
        if package.licence:
            feedback.warning(tr(package.licence))
    loaded = {p.module for p in absent if sys.modules.get(p.module) is not None}
    with _workspace(folder) as work:
        pip_command = _pip_from_wheel(pip_wheel, work, feedback, tr) if pip_wheel else ["-m", "pip"]
        pip = _Pip(interpreter, folder, work, from_source, feedback, tr, pip_command)
        pins = pip.resolve(absent, reinstall=clashing)
        pip.install(pins)
        pip.verify(absent, host_geos)
        feedback.progress(97)
        _merge(work / "staging", folder, work / "replaced")
    activate(folder)
    result.installed = pins
    result.restart = sorted(loaded)
    feedback.info(tr("Installed into {folder}: {packages}.").format(folder=folder, packages=", ".join(pins)))
    feedback.progress(100)
    return result


def _pip_problem(python: str, tr) -> tuple[str | None, list[str], pip_bootstrap.PipWheel | None]:
    """Nothing when ``python`` has a pip that can install (22.2 or later); else pip's wheel to run instead, from
    the index pip would use; else, when that index cannot be reached, why, with the Debian packages that fix it."""
    answer = _quiet([python, "-m", "pip", "--version"])
    found = re.match(r"pip (\d+)\.(\d+)", answer or "")
    if found and tuple(map(int, found.groups())) >= pip_bootstrap.MINIMUM_PIP:
        return None, [], None
    try:
        return None, [], pip_bootstrap.find_pip(pip_bootstrap.pip_settings())
    except pip_bootstrap.PipBootstrapError as exc:
        unreachable = str(exc)
    if found:
        return tr("QGIS's Python ({python}) has pip {version}; installing needs pip 22.2 or later, and pip's own "
                  "wheel could not be fetched from the package index ({reason}): {command}").format(
            python=python, version=".".join(found.groups()), reason=unreachable,
            command=f'"{python}" -m pip install --user --upgrade pip'), [], None
    if _apt_available():
        return tr("QGIS's Python ({python}) has no pip, and pip's own wheel could not be fetched from the package "
                  "index ({reason}).").format(python=python, reason=unreachable), ["python3-pip"], None
    return tr("QGIS's Python ({python}) has no pip, and pip's own wheel could not be fetched from the package "
              "index ({reason}): {command}").format(python=python, reason=unreachable,
                                                    command=f'"{python}" -m ensurepip --upgrade'), [], None


def _pip_from_wheel(wheel: pip_bootstrap.PipWheel, work: Path, feedback: Feedback, tr) -> list[str]:
    """The arguments that run pip from its wheel, downloaded into ``work`` (deleted with it)."""
    feedback.info(tr("QGIS's Python has no pip that can install: pip {version} runs from its own wheel, "
                     "downloaded from {url}.").format(version=wheel.version_text, url=wheel.url))
    try:
        return [str(pip_bootstrap.download(wheel, work, feedback) / "pip")]
    except pip_bootstrap.PipBootstrapError as exc:
        raise _refusal([tr("pip's own wheel could not be downloaded ({reason}).").format(reason=exc)],
                       ["python3-pip"] if _apt_available() else [], tr) from exc


def _refusal(problems: list[str], apt: list[str], tr) -> InstallError:
    """The one message when nothing was installed: what is wrong, the one command that fixes it, what next."""
    command = tr("Run: {command}").format(command="sudo apt install " + " ".join(dict.fromkeys(apt))) if apt else ""
    return InstallError("\n".join([tr("Nothing was installed."), *problems, command,
                                   tr("Then run 'Install Python dependencies' again.")]).replace("\n\n", "\n"))


def _check_safety(absent: Sequence[Package], python: str, host_geos: str | None,
                  tr) -> tuple[list[str], pip_bootstrap.PipWheel | None]:
    """The packages to build from source (on Linux, shapely against the system GEOS), and pip's wheel to run
    where ``python`` has no usable pip. Raises, before anything is installed, when no pip can be had or a
    package cannot come from a wheel here, with the one command that fixes all of it."""
    from_source, problems, apt, wheel = [], [], [], None
    for package in absent if sys.platform.startswith("linux") else ():
        if not package.linux_package:
            continue
        platform = _apt_candidate(package.linux_package)
        if platform is not None and (not package.needs_system_geos or _major(platform) >= 2):
            problems.append(tr("{module}: a wheel from PyPI bundles a C library that QGIS loads itself and would "
                               "crash QGIS; the platform's package {package} is the safe one.").format(
                module=package.module, package=package.linux_package))
            apt.append(package.linux_package)
        elif package.needs_system_geos:
            problem, needed = _geos_build_problem(python, host_geos, tr)
            if problem is None:
                from_source.append(package.module)
            else:
                problems.append(problem)
                apt += needed
        else:
            problems.append(tr("{module}: a wheel from PyPI bundles a C library that QGIS loads itself and would "
                               "crash QGIS; install your distribution's package ({package}).").format(
                module=package.module, package=package.linux_package))
    if len(problems) < len(absent):  # something for pip to do
        problem, needed, wheel = _pip_problem(python, tr)
        if problem:
            problems.append(problem)
            apt += needed
    if problems:
        raise _refusal(problems, apt, tr)
    return from_source, wheel


def _geos_build_problem(python: str, host_geos: str | None, tr) -> tuple[str | None, list[str]]:
    """Why shapely cannot be built here against QGIS's GEOS, with the Debian packages that fix it;
    (None, []) if it can."""
    ours = (host_geos or "").split("-")[0]
    needed = []
    geos_config = shutil.which("geos-config")
    system_geos = (_quiet([geos_config, "--version"]) or "").strip() if geos_config else ""
    if not system_geos:
        needed.append("libgeos-dev")
    elif ours and system_geos != ours:
        return tr("shapely: the system GEOS development files are version {system}, but QGIS runs GEOS {qgis}; "
                  "a shapely built against them would crash QGIS. Install the GEOS development files of "
                  "QGIS's GEOS.").format(system=system_geos, qgis=ours), []
    if not any(shutil.which(c) for c in (os.environ.get("CC") or "cc", "gcc")):
        needed.append("gcc")
    include = _quiet([python, "-c", "import sysconfig; print(sysconfig.get_paths()['include'])"])
    if not include or not (Path(include.strip()) / "Python.h").is_file():
        needed.append("python3-dev")
    if not needed:
        return None, []
    return tr("shapely: a shapely wheel bundles its own GEOS, which crashes QGIS on Linux; it must be built against "
              "the system GEOS, which needs the GEOS development files, a C compiler and the Python headers "
              "({packages}).").format(packages=", ".join(needed)), needed if _apt_available() else []


class _Pip:
    """pip runs for one installation: dry runs, the install into staging, the check of the result."""

    def __init__(self, python: str, folder: Path, work: Path, from_source: list[str], feedback: Feedback, tr,
                 pip_command: Sequence[str] = ("-m", "pip")):
        self.python, self.folder, self.work, self.pip_command = python, folder, work, list(pip_command)
        self.from_source, self.feedback, self.tr = from_source, feedback, tr
        (work / "tmp").mkdir()
        self.staging = work / "staging"
        self.constraints = work / "constraints.txt"
        numpy = sys.modules.get("numpy")
        self.constraints.write_text(f"numpy=={numpy.__version__}\n" if numpy else "", encoding="utf-8")
        temp = str(work / "tmp")  # pip's build folders, deleted with the work folder even when pip is killed
        self.env = dict(os.environ, TMPDIR=temp, TEMP=temp, TMP=temp, PIP_NO_INPUT="1",
                        PIP_DISABLE_PIP_VERSION_CHECK="1", PYTHONIOENCODING="utf-8",
                        PYTHONPATH=os.pathsep.join(p for p in (str(folder), os.environ.get("PYTHONPATH")) if p))

    def _base(self, from_source: bool = True) -> list[str]:
        command = [self.python, *self.pip_command, "install", "--no-cache-dir"]
        return command + (["--no-binary", ",".join(self.from_source)] if from_source and self.from_source else [])

    def resolve(self, absent: Sequence[Package], reinstall: Sequence[Package] = ()) -> list[str]:
        """The exact "name==version" to install: one dry run per package (the first candidate that
        resolves; ``reinstall`` ones even though an unusable copy is installed), merged; numpy always stays
        QGIS's own."""
        pins: dict[str, str] = {}
        for index, package in enumerate(absent):
            feedback = self.feedback.scaled(30 * index / len(absent), 30 * (index + 1) / len(absent))
            plan, errors = None, []
            for requirement in package.candidates:
                plan, error = self._dry_run([requirement], feedback, package in reinstall)
                if plan is not None:
                    break
                errors.append(f"{requirement}: {error}")
            if plan is None:
                raise InstallError(self.tr("pip cannot install {module} on this Python ({requirements}):")
                                   .format(module=package.module, requirements=", ".join(package.candidates))
                                   + "\n" + "\n".join(errors))
            for name, version in plan.items():
                if pins.setdefault(name, version) != version:
                    raise InstallError(self.tr("pip wants {name} in two versions ({first}, {second}); install the "
                                               "packages one at a time.").format(name=name, first=pins[name],
                                                                                 second=version))
        pins.pop("numpy", None)
        return [f"{name}=={version}" for name, version in sorted(pins.items())]

    def _dry_run(self, requirements: list[str], feedback: Feedback,
                 reinstall: bool = False) -> tuple[dict[str, str] | None, str]:
        """What pip would install for ``requirements``. Versions and dependencies are read from wheels
        where there are some (a source build, which shapely's metadata needs, would run twice), from the
        sources otherwise."""
        report = self.work / "report.json"
        built = any(_normalise(r).startswith(tuple(self.from_source)) for r in requirements)
        for from_source in (False, True) if built else (False,):
            report.unlink(missing_ok=True)
            command = self._base(from_source) + [
                "--dry-run", "--quiet", "--report", str(report), "-c", str(self.constraints),
                *(["--ignore-installed"] if reinstall else []), *requirements]
            code, lines = self._run(command, feedback, progress=None)
            if code == 0 and report.is_file():
                break
        else:
            return None, _pip_error(lines)
        planned = json.loads(report.read_text(encoding="utf-8"))["install"]
        feedback.progress(100)
        return {_normalise(item["metadata"]["name"]): item["metadata"]["version"] for item in planned}, ""

    def install(self, pins: list[str]) -> None:
        command = self._base() + ["--target", str(self.staging), "--no-deps", "--no-warn-script-location",
                                  "--progress-bar", "off", *pins]
        steps = len(pins) * 2 + 1  # collected, built or unpacked, then installed
        done = [0]

        def progress(line: str) -> None:
            if line.startswith(("Collecting ", "Processing ", "Building wheel", "Installing collected")):
                done[0] += 1
                self.feedback.progress(30 + 60 * min(done[0], steps) / steps)

        code, lines = self._run(command, self.feedback, progress)
        if code != 0:
            failed = re.search(r"(?:wheel for|wheels for|requirement) ([A-Za-z0-9_.\-]+)", _pip_error(lines))
            raise InstallError(self.tr("pip failed installing {package} (exit code {code}); nothing was installed:")
                               .format(package=failed.group(1) if failed else ", ".join(pins), code=code)
                               + "\n" + _pip_error(lines))

    def verify(self, absent: Sequence[Package], host_geos: str | None) -> None:
        """Every module imports from the staging folder, in a separate Python (never inside QGIS), and a
        shapely on Linux runs QGIS's GEOS."""
        code = ("import importlib, json, sys\nfound = {}\n"
                f"for name in {[p.module for p in absent]!r}:\n"
                "    module = importlib.import_module(name)\n"
                "    found[name] = '.'.join(map(str, module.geos_version)) if name == 'shapely' else ''\n"
                "print(json.dumps(found))")
        env = dict(self.env, PYTHONPATH=os.pathsep.join((str(self.staging), self.env["PYTHONPATH"])))
        run = subprocess.run([self.python, "-c", code], env=env,  # nosec B603  # QGIS's Python, our code, no shell
                             capture_output=True, text=True, encoding="utf-8", errors="replace", timeout=600)
        if run.returncode != 0:
            raise InstallError(self.tr("The installed packages do not import; nothing was installed:")
                               + "\n" + _pip_error(run.stderr.splitlines()))
        geos = json.loads(run.stdout.strip().splitlines()[-1]).get("shapely")
        ours = (host_geos or "").split("-")[0]
        if geos and ours and sys.platform.startswith("linux") and geos != ours:
            raise InstallError(self.tr("The shapely built here uses GEOS {built}, QGIS uses GEOS {qgis}; it would "
                                       "crash QGIS, so nothing was installed.").format(built=geos, qgis=ours))

    def _run(self, command: list[str], feedback: Feedback, progress) -> tuple[int, list[str]]:
        """Run pip with its command in the log; kill it (and what it started) on cancel."""
        feedback.info(self.tr("Running: {command}").format(command=_shell(command)))
        posix = os.name == "posix"
        process = subprocess.Popen(command, stdout=subprocess.PIPE,  # nosec B603  # pip's arguments, no shell
                                   stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                   env=self.env, text=True, encoding="utf-8", errors="replace",
                                   start_new_session=posix,
                                   creationflags=getattr(subprocess, "CREATE_NEW_PROCESS_GROUP", 0))  # (Windows only)
        stdout = cast("IO[str]", process.stdout)  # stdout=PIPE: never None
        lines: list[str] = []
        output: queue.Queue = queue.Queue()

        def read() -> None:
            for line in stdout:
                output.put(line)
            output.put(None)

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        with stdout:
            while True:
                if feedback.is_canceled():
                    _kill(process)
                    reader.join(timeout=10)  # the pipe ends with pip: nothing reads a closed pipe
                    raise CanceledError("Cancelled: pip was stopped.")
                try:
                    line = output.get(timeout=0.2)
                except queue.Empty:
                    continue
                if line is None:
                    break
                line = line.rstrip()
                if line and not _noise(line):
                    lines.append(line)
                    feedback.info(line)
                    if progress:
                        progress(line)
        return process.wait(), lines


@contextmanager
def _workspace(folder: Path):
    """A work folder beside ``folder`` (same file system: the merge is renames), always deleted."""
    folder.parent.mkdir(parents=True, exist_ok=True)
    work = folder.parent / f".install-{uuid.uuid4().hex[:12]}"
    work.mkdir()
    try:
        yield work
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _merge(staging: Path, folder: Path, replaced: Path) -> None:
    """Move what pip put in ``staging`` into ``folder``: packages and their metadata replace older ones of
    the same name (an older version's .dist-info goes too), plain folders such as ``bin`` are merged."""
    folder.mkdir(parents=True, exist_ok=True)
    replaced.mkdir(exist_ok=True)
    for entry in sorted(staging.iterdir()):
        target = folder / entry.name
        if entry.name.endswith(".dist-info"):
            project = _normalise(entry.name[: -len(".dist-info")].rsplit("-", 1)[0])
            for old in folder.glob("*.dist-info"):
                if _normalise(old.name[: -len(".dist-info")].rsplit("-", 1)[0]) == project:
                    old.replace(replaced / f"{uuid.uuid4().hex}-{old.name}")
        if target.is_dir() and entry.is_dir() and not (entry / "__init__.py").exists() \
                and not entry.name.endswith(".dist-info"):
            _merge(entry, target, replaced)
            continue
        if target.exists() or target.is_symlink():
            target.replace(replaced / f"{uuid.uuid4().hex}-{entry.name}")
        entry.replace(target)


def _kill(process: subprocess.Popen) -> None:
    """Stop pip and every process it started (builds run in children)."""
    if os.name == "posix":
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    else:
        taskkill = Path(os.environ.get("SystemRoot", r"C:\Windows"), "System32", "taskkill.exe")
        subprocess.run([str(taskkill), "/F", "/T", "/PID", str(process.pid)],  # nosec B603  # Windows' own, no shell
                       capture_output=True)
        process.kill()
    process.wait()


def _quiet(command: list[str]) -> str | None:
    """A command's standard output, or None when it cannot run or fails."""
    try:
        run = subprocess.run(command, capture_output=True, text=True,  # nosec B603  # a tool's version, no shell
                             timeout=120, env=dict(os.environ, LC_ALL="C"))
    except (OSError, subprocess.TimeoutExpired):
        return None
    return run.stdout if run.returncode == 0 else None


def _apt_available() -> bool:
    return shutil.which("apt-get") is not None


def _apt_candidate(package: str) -> str | None:
    """The version of a Debian package that ``apt install`` would install, or None."""
    if not shutil.which("apt-cache"):
        return None
    found = re.search(r"Candidate: (\S+)", _quiet(["apt-cache", "policy", package]) or "")
    return found.group(1) if found and found.group(1) != "(none)" else None


def _major(debian_version: str) -> int:
    """The upstream major version of a Debian version such as "1:2.0.6-1"."""
    found = re.match(r"(?:\d+:)?(\d+)", debian_version)
    return int(found.group(1)) if found else 0


def _normalise(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _noise(line: str) -> bool:
    """pip's notices that say nothing about this installation."""
    return (line.startswith("WARNING: Location ") or line.startswith("WARNING: Running pip as the 'root' user")
            or (line.startswith("[notice]") and "pip" in line))


def _pip_error(lines: list[str]) -> str:
    """The lines of pip's output that say what went wrong (its ERROR lines, else its last lines)."""
    errors = [line for line in lines if line.startswith("ERROR")]
    return "\n".join(errors or lines[-8:]) or "(no output)"


def _shell(command: list[str]) -> str:
    return subprocess.list2cmdline(command) if os.name == "nt" else shlex.join(command)
