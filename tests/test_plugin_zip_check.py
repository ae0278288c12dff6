"""The repository's rules on a plugin ZIP (scripts/plugin_zip_check.py): a good small ZIP passes, and each
way of breaking one rule is found, by that rule alone, in one line; the maintainer's fields and the URLs.

Core test: builds ZIPs in memory, no QGIS; the URL check asks a server on 127.0.0.1 only.
"""
from __future__ import annotations

import http.server
import sys
import threading
import zipfile

import pytest
from conftest import ROOT

sys.path.insert(0, str(ROOT / "scripts"))
import plugin_zip
import plugin_zip_check as check

CARD = """[general]
name=Good Plugin
qgisMinimumVersion=3.22
qgisMaximumVersion=4.99
description=Does one thing.
about=Does one thing, well.
version=1.2.0
author=Kim Minji
email=minji.kim@citymodel-maintainers.kr
homepage=https://citymodel-maintainers.kr/plugin
tracker=https://citymodel-maintainers.kr/plugin/issues
repository=https://citymodel-maintainers.kr/plugin/code
icon=icon.svg
experimental=True
"""
GOOD = {"good/__init__.py": "def classFactory(iface):\n    return None\n", "good/metadata.txt": CARD,
        "good/LICENSE": "GPL-2.0-or-later\n", "good/icon.svg": "<svg/>", "good/core/__init__.py": ""}


def make_zip(path, files: dict[str, str | bytes], modes: dict[str, int] | None = None):
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in files.items():
            info = zipfile.ZipInfo(name)
            info.external_attr = (modes or {}).get(name, 0o644) << 16
            archive.writestr(info, data)
    return path


def with_card(old: str, new: str) -> dict[str, str]:
    assert old in CARD
    return {**GOOD, "good/metadata.txt": CARD.replace(old, new)}


def test_a_good_zip_passes(tmp_path):
    assert check.check_zip(make_zip(tmp_path / "good.zip", GOOD)) == []


BROKEN = {
    "paths": {**GOOD, "good/../evil.py": ""},
    "forbidden": {**GOOD, "good/core/__pycache__/x.cpython-311.pyc": b"\0"},
    "top-folder": {**GOOD, "other/readme.txt": "a second top folder"},
    "file-analysis": {**GOOD, "good/.env": "hidden", "good/tools/run.sh": "#!/bin/sh\n"},
    "required": {k: v for k, v in GOOD.items() if k != "good/LICENSE"},
    "metadata": {**GOOD, "good/metadata.txt": CARD.replace("[general]", "[plugin]")},
}


@pytest.mark.parametrize("rule", sorted(BROKEN))
def test_each_broken_layout_is_found_by_its_rule(tmp_path, rule):
    problems = check.check_zip(make_zip(tmp_path / "bad.zip", BROKEN[rule]))
    assert problems and {p.rule for p in problems} == {rule}, problems
    assert all("\n" not in str(p) for p in problems)


CARD_BREAKS = {
    "author": ("author=Kim Minji", "author=Kim Minji / WIT"),
    "deprecated": ("experimental=True", "experimental=True\nsupportsQt6=True"),
    "version": ("version=1.2.0", "version=Version 1.2.0"),
    "boolean": ("experimental=True", "experimental=maybe"),
    "icon": ("icon=icon.svg", "icon=icons/missing.png"),
    "email": ("email=minji.kim@citymodel-maintainers.kr", "email=minji.kim at citymodel"),
    "url": ("tracker=https://citymodel-maintainers.kr/plugin/issues", "tracker=http://bugs"),
    "placeholder": ("repository=https://citymodel-maintainers.kr/plugin/code",
                    "repository=https://github.com/your-name/plugin"),
    "length": ("author=Kim Minji", "author=" + "Kim" * 90),
}


@pytest.mark.parametrize("rule", sorted(CARD_BREAKS))
def test_each_broken_card_field_is_found_by_its_rule(tmp_path, rule):
    problems = check.check_zip(make_zip(tmp_path / "bad.zip", with_card(*CARD_BREAKS[rule])))
    assert [p.rule for p in problems] == [rule], problems


def test_a_percent_sign_fails_as_the_site_reads_the_card(tmp_path):
    """The site reads the card with interpolation: a bare % in a value stops the upload."""
    problems = check.check_zip(make_zip(tmp_path / "bad.zip", with_card("Does one thing.", "Does 100% of it.")))
    assert [p.rule for p in problems] == ["metadata"] and "%" in problems[0].message


def test_missing_maintainer_fields_are_named_one_by_one(tmp_path):
    card = "".join(line + "\n" for line in CARD.splitlines()
                   if not line.startswith(("email=", "tracker=", "repository=", "homepage=")))
    problems = check.check_zip(make_zip(tmp_path / "bare.zip", {**GOOD, "good/metadata.txt": card}))
    assert [p.missing for p in problems] == ["email", "tracker", "repository", "homepage"]


def test_an_executable_python_file_is_flagged(tmp_path):
    problems = check.check_zip(make_zip(tmp_path / "x.zip", GOOD, {"good/__init__.py": 0o755}))
    assert [(p.rule, p.message) for p in problems] == [("file-analysis", "good/__init__.py: an executable "
                                                        "Python file is flagged")]


def test_a_damaged_member_fails_the_crc_check(tmp_path):
    path = make_zip(tmp_path / "damaged.zip", {**GOOD, "good/core/data.txt": "A" * 4000})
    data = bytearray(path.read_bytes())
    data[data.index(b"good/core/data.txt") + len("good/core/data.txt") + 2] ^= 0xFF  # inside its compressed data
    path.write_bytes(bytes(data))
    problems = check.check_zip(path)
    assert [p.rule for p in problems] == ["zip"] and "good/core/data.txt" in problems[0].message


def test_too_big_and_not_a_zip(tmp_path, monkeypatch):
    path = make_zip(tmp_path / "good.zip", GOOD)
    monkeypatch.setattr(check, "MAX_BYTES", path.stat().st_size - 1)
    assert [p.rule for p in check.check_zip(path)] == ["size"]
    (tmp_path / "text.zip").write_text("not a zip")
    assert [p.rule for p in check.check_zip(tmp_path / "text.zip")] == ["zip"]


@pytest.mark.parametrize("value, placeholder", [
    ("you@example.com", True), ("https://example.org/x", True), ("https://github.com/YOUR-NAME/plugin", True),
    ("https://github.com/wit/plugin/issues/TODO", True), ("https://tracker.invalid/", True),
    ("minji.kim@citymodel-maintainers.kr", False), ("https://github.com/qgis/QGIS/issues", False),
])
def test_placeholders(value, placeholder):
    assert (check.placeholder(value) is not None) == placeholder


@pytest.fixture()
def local_site():
    """A web server on 127.0.0.1 that knows /issues and /code only."""
    class Handler(http.server.BaseHTTPRequestHandler):
        def do_HEAD(self):
            self.send_response(200 if self.path in ("/issues", "/code") else 404)
            self.end_headers()

        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def test_online_the_urls_must_answer(tmp_path, local_site):
    files = with_card("tracker=https://citymodel-maintainers.kr/plugin/issues", f"tracker={local_site}/issues")
    files["good/metadata.txt"] = (files["good/metadata.txt"]
                                  .replace("repository=https://citymodel-maintainers.kr/plugin/code",
                                           f"repository={local_site}/code")
                                  .replace("homepage=https://citymodel-maintainers.kr/plugin",
                                           f"homepage={local_site}/gone"))
    path = make_zip(tmp_path / "online.zip", files)
    assert check.check_zip(path) == []  # offline: the URLs are only read
    problems = check.check_zip(path, online=True)
    assert [str(p) for p in problems] == [f"[url] homepage={local_site}/gone answers HTTP 404"]
    assert check.unreachable("http://127.0.0.1:9/").startswith("no answer")


def test_the_maintainer_fields_go_after_the_author_or_replace_a_line():
    card = "[general]\nname=x\nauthor=Kim\nhomepage=https://old.kr/\nicon=i.svg\n"
    fields = {"email": "kim@citymodel-maintainers.kr", "homepage": "https://new.kr/", "tracker": "https://t.kr/"}
    assert plugin_zip.card_with(card, fields) == ("[general]\nname=x\nauthor=Kim\nemail=kim@citymodel-maintainers.kr\n"
                                                  "tracker=https://t.kr/\nhomepage=https://new.kr/\nicon=i.svg\n")


def test_maintainer_fields_from_the_settings_file_and_the_environment(tmp_path):
    settings = tmp_path / "maintainer.ini"
    settings.write_text("[maintainer]\nemail = kim@citymodel-maintainers.kr\ntracker = https://t.kr/issues\n")
    environ = {"WIT_PLUGIN_MAINTAINER_FILE": str(settings), "WIT_PLUGIN_TRACKER": "https://other.kr/issues"}
    assert plugin_zip.maintainer_fields(environ) == {"email": "kim@citymodel-maintainers.kr",
                                                     "tracker": "https://other.kr/issues"}
    settings.write_text("[maintainer]\nmail = kim@citymodel-maintainers.kr\n")
    with pytest.raises(plugin_zip.SettingsError, match="unknown: mail"):
        plugin_zip.maintainer_fields(environ)
    with pytest.raises(plugin_zip.SettingsError, match="no such file"):
        plugin_zip.maintainer_fields({"WIT_PLUGIN_MAINTAINER_FILE": str(tmp_path / "none.ini")})
