"""pip for a Python without one (wit_plugin.infra.pip_bootstrap, and the installer using it): the index pip's
configuration names, the newest wheel that suits, a checked and cancellable download, and a whole install by a
Python that has no pip, from a local index holding a pip wheel and a small package.

Core test: no QGIS, no network (local indexes: file: and a server on 127.0.0.1).
"""
from __future__ import annotations

import functools
import hashlib
import http.server
import os
import subprocess
import sys
import threading
import zipfile
from pathlib import Path

import pytest

from wit_plugin.infra import installer, pip_bootstrap
from wit_plugin.infra.errors import CanceledError
from wit_plugin.infra.feedback import Feedback


def write_config(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")


@pytest.fixture
def pip_home(tmp_path):
    """An environment whose only pip configuration files are under tmp_path (and the machine's /etc/pip.conf)."""
    return {"HOME": str(tmp_path / "home"), "XDG_CONFIG_DIRS": str(tmp_path / "xdg"),
            "XDG_CONFIG_HOME": str(tmp_path / "home" / ".config")}


def test_the_index_is_the_one_pip_would_use(tmp_path, pip_home):
    write_config(tmp_path / "xdg" / "pip" / "pip.conf",
                 "[global]\nindex-url = https://global.index/simple\nextra-index-url = https://extra.index/simple\n"
                 "[install]\nindex-url = https://install.index/simple\n")
    write_config(tmp_path / "home" / ".config" / "pip" / "pip.conf",
                 "[global]\nindex_url = https://user.index/simple\ncert = /etc/user-ca.pem\n")
    settings = pip_bootstrap.pip_settings(pip_home, "linux")
    # the user's file wins over the global one, but [install] over any [global]; the extra index is kept
    assert settings == pip_bootstrap.PipSettings(("https://install.index/simple", "https://extra.index/simple"),
                                                 "/etc/user-ca.pem")
    assert pip_bootstrap.pip_settings({**pip_home, "PIP_INDEX_URL": "https://env.index/simple"}, "linux").indexes[0] \
        == "https://env.index/simple"
    assert pip_bootstrap.pip_settings({**pip_home, "PIP_CONFIG_FILE": os.devnull}, "linux").indexes == (
        pip_bootstrap.PYPI,)  # pip reads no file at all
    assert pip_bootstrap.pip_settings({**pip_home, "PIP_NO_INDEX": "1"}, "linux").indexes == ()


PAGE = """<html><body>
<a href="https://files.example/pip-21.3.1-py3-none-any.whl#sha256={h}">too old for --dry-run --report</a>
<a href="https://files.example/pip-24.0-py3-none-any.whl#sha256={h}" data-yanked="">yanked</a>
<a href="https://files.example/pip-25.1-py3-none-any.whl#sha256={h}" data-requires-python="&gt;=3.99">future</a>
<a href="https://files.example/pip-25.0b1-py3-none-any.whl#sha256={h}">pre-release</a>
<a href="https://files.example/pip-25.2.tar.gz#sha256={h}">source</a>
<a href="../../packages/pip-24.2-py3-none-any.whl#sha256={h}" data-requires-python="&gt;=3.8">the one</a>
<a href="https://files.example/pip-23.3-py3-none-any.whl#sha256={h}">older</a>
</body></html>"""


def test_the_newest_wheel_that_suits_this_python_wins():
    digest = "ab" * 32
    wheel = pip_bootstrap.newest_wheel(PAGE.format(h=digest), "https://index.example/simple/pip/")
    assert wheel == pip_bootstrap.PipWheel("https://index.example/packages/pip-24.2-py3-none-any.whl", (24, 2),
                                           digest)
    assert pip_bootstrap.newest_wheel("<a href='pip-9.0.tar.gz'>x</a>", "https://i.example/pip/") is None


@pytest.mark.parametrize("requires, fits", [(">=3.8", True), (">=3.99", False), ("!=3.{m}.*", False),
                                            ("==3.{m}.*", True), (">=3.8,<4", True), ("~=3.{m}", True),
                                            ("weird", False), (None, True)])
def test_requires_python(requires, fits):
    assert pip_bootstrap.python_fits(requires and requires.format(m=sys.version_info[1])) is fits


def venv_pip_wheel(folder: Path) -> Path:
    """A pip wheel made of the pip this test runs with (what pip needs to run from a wheel: its package)."""
    import pip

    source = Path(pip.__file__).parent
    wheel = folder / f"pip-{pip.__version__}-py3-none-any.whl"
    with zipfile.ZipFile(wheel, "w") as archive:
        for path in sorted(source.rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                archive.write(path, Path("pip") / path.relative_to(source))
    return wheel


def small_package_wheel(folder: Path) -> Path:
    """``witfake`` 1.0, a pure-Python wheel, for pip to install."""
    wheel = folder / "witfake-1.0-py3-none-any.whl"
    files = {"witfake/__init__.py": "VALUE = 42\n",
             "witfake-1.0.dist-info/METADATA": "Metadata-Version: 2.1\nName: witfake\nVersion: 1.0\n",
             "witfake-1.0.dist-info/WHEEL": "Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: true\n"
                                           "Tag: py3-none-any\n"}
    record = "".join(f"{name},sha256={_b64(data)},{len(data)}\n" for name, data in files.items())
    with zipfile.ZipFile(wheel, "w") as archive:
        for name, data in files.items():
            archive.writestr(name, data)
        archive.writestr("witfake-1.0.dist-info/RECORD", record + "witfake-1.0.dist-info/RECORD,,\n")
    return wheel


def _b64(text: str) -> str:
    import base64

    return base64.urlsafe_b64encode(hashlib.sha256(text.encode()).digest()).rstrip(b"=").decode()


def simple_index(root: Path, wheels: dict[str, Path], digest: str | None = None) -> Path:
    """A PEP 503 index under ``root``: one page per project, each wheel linked with its sha256."""
    for project, wheel in wheels.items():
        page = root / project
        page.mkdir(parents=True)
        target = page / wheel.name
        target.write_bytes(wheel.read_bytes())
        sha = digest or hashlib.sha256(target.read_bytes()).hexdigest()
        (page / "index.html").write_text(f'<a href="{wheel.name}#sha256={sha}">{wheel.name}</a>\n')
    return root


class Cancelling(Feedback):
    def __init__(self):
        super().__init__()
        self.asked = 0

    def is_canceled(self) -> bool:
        self.asked += 1
        return self.asked > 1  # after the first chunk


def test_a_wheel_is_found_downloaded_checked_and_runs(tmp_path):
    index = simple_index(tmp_path / "index", {"pip": venv_pip_wheel(tmp_path)})
    wheel = pip_bootstrap.find_pip(pip_bootstrap.PipSettings(("file:///nowhere/simple", index.as_uri())))
    work = tmp_path / "work"
    work.mkdir()
    path = pip_bootstrap.download(wheel, work)
    assert [p.name for p in work.iterdir()] == [wheel.filename]
    run = subprocess.run([sys.executable, str(path / "pip"), "--version"], capture_output=True, text=True)
    assert run.stdout.startswith(f"pip {wheel.version_text} from {path}")

    (tmp_path / "empty").mkdir()
    tampered = simple_index(tmp_path / "tampered", {"pip": venv_pip_wheel(tmp_path)}, digest="0" * 64)
    with pytest.raises(pip_bootstrap.PipBootstrapError, match="does not match the index's sha256"):
        pip_bootstrap.download(pip_bootstrap.find_pip(pip_bootstrap.PipSettings((tampered.as_uri(),))),
                               tmp_path / "empty")
    with pytest.raises(CanceledError):
        pip_bootstrap.download(wheel, tmp_path / "empty", Cancelling())
    assert list((tmp_path / "empty").iterdir()) == []  # neither leaves a file


@pytest.fixture
def served(tmp_path):
    """tmp_path/index on an HTTP server on 127.0.0.1."""
    root = tmp_path / "index"
    root.mkdir()
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(root))
    handler.log_message = lambda *args: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield root, f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()


def test_an_unreachable_index_is_named_and_an_http_index_works(tmp_path, served):
    with pytest.raises(pip_bootstrap.PipBootstrapError, match=r"http://127.0.0.1:9/simple/pip/: .*refused"):
        pip_bootstrap.find_pip(pip_bootstrap.PipSettings(("http://127.0.0.1:9/simple",)))
    root, url = served
    simple_index(root, {"pip": venv_pip_wheel(tmp_path)})
    wheel = pip_bootstrap.find_pip(pip_bootstrap.PipSettings((url,)))
    assert wheel.url.startswith(url) and wheel.sha256
    (tmp_path / "work").mkdir()
    assert pip_bootstrap.download(wheel, tmp_path / "work").stat().st_size > 1_000_000


def test_a_python_without_pip_installs_through_pip_from_its_wheel(tmp_path, monkeypatch):
    """The whole installer with QGIS's Python standing in as a venv without pip, offline."""
    python = tmp_path / "nopip" / "bin" / "python"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(tmp_path / "nopip")], check=True)
    monkeypatch.delenv("PYTHONPATH", raising=False)  # the test run's path holds the .venv's pip
    assert subprocess.run([str(python), "-m", "pip", "--version"], capture_output=True).returncode != 0
    index = simple_index(tmp_path / "index", {"pip": venv_pip_wheel(tmp_path),
                                              "witfake": small_package_wheel(tmp_path)})
    for variable in [v for v in os.environ if v.startswith("PIP_")]:
        monkeypatch.delenv(variable)
    monkeypatch.setenv("PIP_CONFIG_FILE", os.devnull)  # the machine's pip settings stay out of it
    monkeypatch.setenv("PIP_INDEX_URL", index.as_uri())
    log = []

    class Recording(Feedback):
        def info(self, text):
            log.append(text)

    folder = tmp_path / "profile" / "python" / installer.FOLDER_NAME / "py3"
    package = installer.Package("witfake", ("witfake",))
    result = installer.install([package], folder, python=str(python), feedback=Recording())
    assert result.installed == ["witfake==1.0"]
    assert (folder / "witfake" / "__init__.py").read_text() == "VALUE = 42\n"
    assert [p.name for p in folder.parent.iterdir()] == ["py3"]  # the work folder and pip's wheel are gone
    commands = [line[len("Running: "):] for line in log if line.startswith("Running: ")]
    wheel_pip = f"{folder.parent}/.install-"
    assert commands and all(c.startswith(f"{python} {wheel_pip}") and "-py3-none-any.whl/pip install" in c
                            for c in commands)
    assert any("runs from its own wheel" in line for line in log)
