"""wit:installdependencies through Processing, with a fake pip: the pip command is in the log, the first
installable requirement wins, a failure names the package, Cancel kills pip and what it started and
leaves no partial folder, a finished install is importable at once; and the GUI's message bar offers the
installer when an algorithm lacks a package."""
from __future__ import annotations

import json
import os
import select
import sys
import textwrap
import threading
from pathlib import Path

import pytest

pytestmark = pytest.mark.qgis_facing

FAKE_PIP = textwrap.dedent('''\
    #!{python}
    """A stand-in for QGIS's Python: "-c" runs the real one; "-m pip" plays pip as $FAKE_PIP_* say."""
    import json, os, subprocess, sys, time
    from pathlib import Path

    if sys.argv[1] != "-m":
        os.execv({python!r}, [{python!r}, *sys.argv[1:]])
    args = sys.argv[3:]
    if args == ["--version"]:
        print("pip 24.0 from /fake (python 3)")
        sys.exit(0)
    log = Path(os.environ["FAKE_PIP_DIR"])
    with open(log / "calls.txt", "a") as calls:
        calls.write(json.dumps(args) + "\\n")
    valued = {{"-c", "--report", "--no-binary", "--target", "--progress-bar"}}
    options, requirements, i = {{}}, [], 1
    while i < len(args):
        if args[i] in valued:
            options[args[i]] = args[i + 1]
            i += 2
            continue
        if not args[i].startswith("-"):
            requirements.append(args[i])
        i += 1
    names = [r.split("=")[0].split(">")[0].split("<")[0] for r in requirements]
    if "--dry-run" in args:
        if any(name in os.environ.get("FAKE_PIP_UNAVAILABLE", "").split(",") for name in names):
            print("ERROR: Could not find a version that satisfies the requirement " + requirements[0])
            sys.exit(1)
        report = {{"install": [{{"metadata": {{"name": name, "version": "1.0"}}}} for name in names]}}
        Path(options["--report"]).write_text(json.dumps(report))
        sys.exit(0)
    target = Path(options["--target"])
    mode = os.environ.get("FAKE_PIP_INSTALL", "ok")
    for requirement in requirements:
        name, version = requirement.split("==")
        print("Collecting " + requirement, flush=True)
        (target / name).mkdir(parents=True, exist_ok=True)
        (target / name / "__init__.py").write_text(f"VERSION = {{version!r}}\\n")
    if mode == "fail":
        print("ERROR: Failed building wheel for " + names[0])
        sys.exit(1)
    if mode == "hang":
        child = subprocess.Popen(["sleep", "3600"])
        (log / "pids.json").write_text(json.dumps([os.getpid(), child.pid]))
        (log / "started").write_text("")
        time.sleep(3600)
    for name, requirement in zip(names, requirements):
        (target / (name + "-1.0.dist-info")).mkdir()
        (target / (name + "-1.0.dist-info") / "METADATA").write_text("Name: " + name + "\\n")
    print("Installing collected packages: " + ", ".join(names))
    print("Successfully installed " + " ".join(requirements))
''')


@pytest.fixture
def fake_pip(tmp_path, monkeypatch):
    """A fake QGIS Python whose pip does what the test says, and a throwaway package folder."""
    from wit_citymodel.processing_provider import installdependencies

    python = tmp_path / "python3"
    python.write_text(FAKE_PIP.format(python=sys.executable))
    python.chmod(0o755)
    calls = tmp_path / "calls"
    calls.mkdir()
    monkeypatch.setenv("FAKE_PIP_DIR", str(calls))
    folder = tmp_path / "profile" / "python" / "wit_citymodel_deps" / "py3"
    monkeypatch.setattr(installdependencies, "profile_packages_folder", lambda: folder)
    before = list(sys.path)
    yield python, folder, calls
    sys.path[:] = before
    sys.modules.pop("witfake", None)


class RecordingFeedback:
    """A QgsProcessingFeedback that keeps its log and cancels once the fake pip has started."""

    def __new__(cls, cancel_when: Path | None = None):
        from qgis.core import QgsProcessingFeedback

        class Recording(QgsProcessingFeedback):
            def __init__(self):
                super().__init__()
                self.log, self.warnings = [], []

            def pushInfo(self, text):  # noqa: N802
                self.log.append(text)
                super().pushInfo(text)

            def pushWarning(self, text):  # noqa: N802
                self.warnings.append(text)
                super().pushWarning(text)

            def isCanceled(self):  # noqa: N802
                return (cancel_when is not None and cancel_when.exists()) or super().isCanceled()

        return Recording()


def run_install(packages, python, feedback):
    import processing

    return processing.run("wit:installdependencies", {"PACKAGES": packages, "PYTHON": str(python)},
                          feedback=feedback)


def package_index(module: str) -> int:
    from wit_citymodel.wit_plugin.infra import installer

    return [p.module for p in installer.PACKAGES].index(module)


def leftovers(folder: Path) -> list[str]:
    parent = folder.parent
    return sorted(p.name for p in parent.iterdir()) if parent.exists() else []


def test_the_first_installable_candidate_wins_and_a_failure_names_the_package(wit_provider, fake_pip, monkeypatch):
    from qgis.core import QgsProcessingException

    python, folder, calls = fake_pip
    monkeypatch.setitem(sys.modules, "triangle", None)  # triangle missing
    monkeypatch.setenv("FAKE_PIP_UNAVAILABLE", "triangle")  # no build of triangle, one of triangle3
    monkeypatch.setenv("FAKE_PIP_INSTALL", "fail")
    feedback = RecordingFeedback()
    with pytest.raises(QgsProcessingException) as error:
        run_install([package_index("triangle")], python, feedback)
    assert "pip failed installing triangle3 (exit code 1); nothing was installed" in str(error.value)
    assert "ERROR: Failed building wheel for triangle3" in str(error.value)
    pip_calls = [json.loads(line) for line in (calls / "calls.txt").read_text().splitlines()]
    assert [call[-1] for call in pip_calls] == ["triangle>=20230923", "triangle3", "triangle3==1.0"]
    assert any(line.startswith(f"Running: {python} -m pip install --no-cache-dir --target ") and
               line.endswith(" --no-deps --no-warn-script-location --progress-bar off triangle3==1.0")
               for line in feedback.log), feedback.log
    assert any("free for non-commercial use only" in line for line in feedback.warnings)
    assert leftovers(folder) == []  # staging and work folders gone, nothing merged


def test_no_installable_candidate_names_the_package_and_each_requirement(wit_provider, fake_pip, monkeypatch):
    from qgis.core import QgsProcessingException

    python, folder, _ = fake_pip
    monkeypatch.setitem(sys.modules, "triangle", None)
    monkeypatch.setenv("FAKE_PIP_UNAVAILABLE", "triangle,triangle3")
    with pytest.raises(QgsProcessingException) as error:
        run_install([package_index("triangle")], python, RecordingFeedback())
    message = str(error.value)
    assert "pip cannot install triangle on this Python (triangle>=20230923, triangle3)" in message
    assert "triangle3: ERROR: Could not find a version that satisfies the requirement triangle3" in message
    assert leftovers(folder) == []


def test_cancel_kills_pip_and_its_children_and_leaves_nothing(wit_provider, fake_pip, monkeypatch):
    from qgis.core import QgsProcessingException

    python, folder, calls = fake_pip
    monkeypatch.setitem(sys.modules, "triangle", None)
    monkeypatch.setenv("FAKE_PIP_INSTALL", "hang")
    feedback = RecordingFeedback(cancel_when=calls / "started")
    with pytest.raises(QgsProcessingException, match="Cancelled: pip was stopped and nothing was installed"):
        run_install([package_index("triangle")], python, feedback)
    pip_pid, child_pid = json.loads((calls / "pids.json").read_text())
    with pytest.raises(ProcessLookupError):
        os.kill(pip_pid, 0)  # killed and reaped
    handle = os.pidfd_open(child_pid)  # the build process pip started: killed with it
    try:
        assert select.select([handle], [], [], 60)[0] == [handle]
    finally:
        os.close(handle)
    assert leftovers(folder) == []  # the staging folder with the half-written package is gone


def test_a_finished_install_is_merged_and_importable_at_once(wit_provider, fake_pip, monkeypatch):
    from wit_citymodel.wit_plugin.infra import installer

    python, folder, _ = fake_pip
    fake = len(installer.PACKAGES)
    try:
        with monkeypatch.context() as patch:  # one more line in the table: a package nobody has
            patch.setattr(installer, "PACKAGES", (*installer.PACKAGES, installer.Package("witfake", ("witfake>=1",))))
            wit_provider.refreshAlgorithms()
            feedback = RecordingFeedback()
            result = run_install([fake], python, feedback)
            assert result == {"FOLDER": str(folder), "INSTALLED": "witfake==1.0"}
            assert sorted(p.name for p in folder.iterdir()) == ["witfake", "witfake-1.0.dist-info"]
            assert leftovers(folder) == ["py3"]
            import witfake

            assert witfake.VERSION == "1.0" and Path(witfake.__file__).parent == folder / "witfake"
            assert any(line.startswith("Installed into ") and line.endswith("witfake==1.0.") for line in feedback.log)
            again = RecordingFeedback()  # present now: pip is not called again
            assert run_install([fake], python, again)["INSTALLED"] == ""
            assert "Every selected package is present already: witfake." in again.log
    finally:
        wit_provider.refreshAlgorithms()


def test_present_packages_are_left_alone_without_pip(wit_provider, fake_pip):
    python, folder, calls = fake_pip
    feedback = RecordingFeedback()
    result = run_install([package_index("pygltflib"), package_index("lxml")], python, feedback)
    assert result["INSTALLED"] == "" and not (calls / "calls.txt").exists()
    assert "Every selected package is present already: pygltflib, lxml." in feedback.log


def test_an_algorithm_lacking_a_package_says_how_to_install_and_the_gui_offers_the_installer(
        qgis_processing, qgis_iface, monkeypatch, tmp_path):
    import processing
    from qgis.core import QgsApplication, QgsProcessingException
    from qgis.PyQt.QtWidgets import QPushButton
    from wit_citymodel import plugin as plugin_module

    opened = []
    monkeypatch.setattr(plugin_module, "open_installer", lambda: opened.append("wit:installdependencies"))
    registry = QgsApplication.processingRegistry()
    if registry.providerById("wit") is not None:
        registry.removeProvider("wit")  # the plugin registers its own, as in QGIS
    plugin = plugin_module.WitCityModelPlugin(qgis_iface)
    plugin.initGui()
    try:
        monkeypatch.setitem(sys.modules, "pyproj", None)
        with pytest.raises(QgsProcessingException) as error:
            processing.run("wit:generatesample", {"OUTPUT": str(tmp_path / "sample")})
        assert "Missing Python packages: pyproj. Run 'Install Python dependencies' " \
               "(wit:installdependencies, group Tools)" in str(error.value)
        assert not (tmp_path / "sample").exists()
        QgsApplication.processEvents()
        items = qgis_iface.messageBar().items()
        assert len(items) == 1 and "pyproj" in items[0].text()
        with pytest.raises(QgsProcessingException):  # a second failure adds no second bar
            processing.run("wit:generatesample", {"OUTPUT": str(tmp_path / "sample")})
        QgsApplication.processEvents()
        assert len(qgis_iface.messageBar().items()) == 1
        button = items[0].findChild(QPushButton)
        assert button.text() == "Install Python dependencies…"
        button.click()
        assert opened == ["wit:installdependencies"] and qgis_iface.messageBar().items() == []
        from wit_citymodel.processing_provider.dependency_notice import NOTICE

        worker = threading.Thread(target=NOTICE.missing.emit, args=(["shapely>=2"],))  # as from a Processing task
        worker.start()
        worker.join()
        QgsApplication.processEvents()
        assert [item.text() for item in qgis_iface.messageBar().items()] == ["Missing Python packages: shapely>=2."]
    finally:
        plugin.unload()
