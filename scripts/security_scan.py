"""The security scan plugins.qgis.org runs on every uploaded version, run on what the plugin ZIP ships.

    python scripts/security_scan.py [ZIP]    (no ZIP: the ZIP ``make package`` would build, in a temporary folder)

Each finding is one line; exit 1 when there is one. Run as the site runs its blocking checks
(qgis/QGIS-Plugins-Website, ``qgis-app/plugins/security_scanner.py`` with its default rules):

* **Bandit**, recursively on the extracted ZIP, with every test the site enables: all of Bandit's but the
  info-level B404, B410 and B411 it leaves disabled; at every severity and confidence, because with its
  rules configured the site passes no severity filter (``-ll``, medium and high, is its fallback without
  rules) and any finding of an enabled test blocks the version.
* **detect-secrets** ``scan --all-files`` with every plugin but ``IPPublicDetector`` (disabled there),
  ``metadata.txt`` excluded as the site excludes it.

A finding is silenced only where it stands, with its reason on the same line: ``# nosec B603  # why``
(Bandit reads the test ids up to the second ``#``) or ``pragma: allowlist secret: why`` (detect-secrets).
A ``# nosec`` without a test id, or either marker without a reason, is itself a finding.
"""
from __future__ import annotations

import json
import re
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

#: the tests the site's default rules leave disabled (info level)
SITE_DISABLED_TESTS = ("B404", "B410", "B411")
SITE_DISABLED_SECRET_PLUGINS = ("IPPublicDetector",)
SITE_EXCLUDED_FILES = (r"metadata\.txt", r"\.secrets\.baseline")
#: a Bandit silencer with its test ids and a reason
NOSEC = re.compile(r"#\s*nosec\b(?P<rest>.*)$")
NOSEC_EXPLAINED = re.compile(r"#\s*nosec\s+B\d{3}(\s*,\s*B\d{3})*\s+#\s*\S.*$")
ALLOWLIST = re.compile(r"pragma:\s*(allow|white)list[ -](nextline[ -])?secret(?P<rest>.*)$")


@dataclass(frozen=True)
class Finding:
    tool: str
    path: str
    line: int
    code: str
    message: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: [{self.tool} {self.code}] {self.message}"


def bandit_command() -> list[str]:
    return [sys.executable, "-m", "bandit", "-r", ".", "-f", "json", "--quiet", "--skip", ",".join(SITE_DISABLED_TESTS)]


def secrets_command() -> list[str]:
    command = [sys.executable, "-m", "detect_secrets", "scan", "--all-files"]
    for pattern in SITE_EXCLUDED_FILES:
        command += ["--exclude-files", pattern]
    for plugin in SITE_DISABLED_SECRET_PLUGINS:
        command += ["--disable-plugin", plugin]
    return [*command, "."]


def _run_together(commands: dict[str, list[str]], folder: Path) -> dict[str, dict]:
    """Each tool's JSON report; the tools run side by side (detect-secrets takes the longer)."""
    with tempfile.TemporaryDirectory(prefix="wit-scan-logs-") as logs:
        started = {}
        for name, command in commands.items():
            out, err = (open(Path(logs) / f"{name}.{kind}", "w+", encoding="utf-8") for kind in ("out", "err"))
            process = subprocess.Popen(command, cwd=folder, stdout=out, stderr=err)  # nosec B603  # our own tools
            started[name] = (process, out, err)
        reports = {}
        for name, (process, out, err) in started.items():
            with out, err:
                code = process.wait(timeout=900)
                out.seek(0)
                err.seek(0)
                text = out.read()
                if not text.strip().startswith("{"):
                    raise RuntimeError(f"{name} failed (exit {code}): {err.read().strip()[-2000:]}")
                reports[name] = json.loads(text)
    return reports


def bandit_findings(report: dict) -> list[Finding]:
    if report.get("errors"):
        raise RuntimeError(f"bandit could not read: {report['errors']}")
    return [Finding("bandit", r["filename"].removeprefix("./"), r["line_number"],
                    f"{r['test_id']}/{r['issue_severity']}", r["issue_text"]) for r in report["results"]]


def secrets_findings(report: dict) -> list[Finding]:
    return [Finding("detect-secrets", path, secret["line_number"], secret["type"].replace(" ", ""),
                    f"potential {secret['type']}")
            for path, found in sorted(report["results"].items()) for secret in found]


def silencers(folder: Path) -> list[Finding]:
    """Silencers that do not say what they silence and why."""
    findings = []
    for path in sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix in (".py", ".xsd", ".xml", ".md")):
        relative = str(path.relative_to(folder))
        for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            if path.suffix == ".py" and NOSEC.search(line) and not NOSEC_EXPLAINED.search(line):
                findings.append(Finding("silencer", relative, number, "nosec",
                                        "'# nosec' needs its test ids and a reason: # nosec B603  # why"))
            allowed = ALLOWLIST.search(line)
            if allowed and not re.match(r"\s*[:\-–]\s*\w", allowed.group("rest")):
                findings.append(Finding("silencer", relative, number, "allowlist",
                                        "'pragma: allowlist secret' needs a reason: pragma: allowlist secret: why"))
    return findings


def scan_folder(folder: Path) -> list[Finding]:
    reports = _run_together({"bandit": bandit_command(), "detect-secrets": secrets_command()}, folder)
    return silencers(folder) + bandit_findings(reports["bandit"]) + secrets_findings(reports["detect-secrets"])


def scan_zip(path: Path) -> list[Finding]:
    """Every finding in what the ZIP at ``path`` ships."""
    with tempfile.TemporaryDirectory(prefix="wit-scan-") as tmp:
        with zipfile.ZipFile(path) as archive:
            archive.extractall(tmp)
        return scan_folder(Path(tmp))


def main(argv: list[str]) -> int:
    if argv:
        findings, what = scan_zip(Path(argv[0])), argv[0]
    else:
        import plugin_zip  # scripts/plugin_zip.py: the ZIP make package builds

        with tempfile.TemporaryDirectory(prefix="wit-zip-") as tmp:
            target = Path(tmp) / "plugin.zip"
            plugin_zip.build(target, {})
            findings, what = scan_zip(target), "the plugin ZIP"
    for finding in findings:
        print(finding)
    print(f"security scan of {what} (Bandit as plugins.qgis.org runs it, detect-secrets): "
          f"{len(findings)} finding(s)", file=sys.stderr)
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
