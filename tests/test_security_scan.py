"""The security scan of plugins.qgis.org as make lint runs it (scripts/security_scan.py): on a tiny plugin, a
finding of Bandit (any severity of a test the site enables) or detect-secrets fails, a silencer with its test id
and reason holds, a bare one is itself a finding, and the site's disabled test stays quiet. (That the plugin's
own ZIP scans clean is make lint's verdict, and make package's.)

Core test: Bandit and detect-secrets on files written here, no QGIS.
"""
from __future__ import annotations

import sys

from conftest import ROOT

sys.path.insert(0, str(ROOT / "scripts"))
import security_scan

RISKY = '''import subprocess

def run(command):
    subprocess.run(command)
'''
TOKEN = 'ACCESS = "ghp_' + "A1b2C3d4E5f6G7h8I9j0K1l2M3n4O5p6Q7r8" + '"\n'  # split: no secret in this file


def write(folder, files: dict[str, str]):
    for name, text in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text, encoding="utf-8")
    return folder


def codes(findings) -> list[tuple[str, str, int]]:
    return sorted((f.code, f.path, f.line) for f in findings)


def test_findings_fail_and_explained_silencers_hold(tmp_path):
    plugin = write(tmp_path / "p", {"plugin/run.py": RISKY, "plugin/keys.py": TOKEN,
                                    "plugin/metadata.txt": "[general]\ncommitSha1=" + "a3" * 20 + "\n"})
    found = codes(security_scan.scan_folder(plugin))
    # B603 is a low-severity test the site enables; B404 (import subprocess) it leaves disabled; metadata.txt
    # is not scanned for secrets
    assert found == [("B603/LOW", "plugin/run.py", 4), ("Base64HighEntropyString", "plugin/keys.py", 1),
                     ("GitHubToken", "plugin/keys.py", 1)]

    write(plugin, {"plugin/run.py": RISKY.replace("run(command)\n", "run(command)  # nosec B603  # a list, no shell\n"),
                   "plugin/keys.py": TOKEN.rstrip("\n") + "  # pragma: allowlist secret: a test key\n"})
    assert security_scan.scan_folder(plugin) == []

    write(plugin, {"plugin/run.py": RISKY.replace("run(command)\n", "run(command)  # nosec\n"),
                   "plugin/keys.py": TOKEN.rstrip("\n") + "  # pragma: allowlist secret\n"})
    assert codes(security_scan.scan_folder(plugin)) == [("allowlist", "plugin/keys.py", 1),
                                                        ("nosec", "plugin/run.py", 4)]

