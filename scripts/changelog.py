"""metadata.txt's changelog= made from CHANGELOG.md (the one place the changes are written).

    python scripts/changelog.py          rewrite metadata.txt's changelog= from CHANGELOG.md
    python scripts/changelog.py --check  exit 1 when metadata.txt's changelog= differs (make package, tests)
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CARD = ROOT / "metadata.txt"
CHANGES = ROOT / "CHANGELOG.md"
INDENT = "    "


def changelog_lines(markdown: str) -> list[str]:
    """Each version (a "## " heading) and its items ("- " lines), in order; the preamble left out."""
    lines = []
    for line in markdown.splitlines():
        if line.startswith("## "):
            lines.append(line[3:].strip())
        elif line.startswith("- ") and lines:
            lines.append(line.strip())
    return lines


def with_changelog(card: str, lines: list[str]) -> str:
    """``card`` (metadata.txt's text) with its changelog= value replaced by ``lines``, one per line."""
    block = "changelog=\n" + "".join(f"{INDENT}{line}\n" for line in lines)
    # the value runs over the indented continuation lines that follow the key
    pattern = re.compile(r"^changelog=.*\n(?:[ \t]+\S.*\n)*", re.MULTILINE)
    if not pattern.search(card):
        raise SystemExit(f"{CARD}: no changelog= line")
    return pattern.sub(lambda _: block, card, count=1)


def main(argv: list[str]) -> int:
    card = CARD.read_text(encoding="utf-8")
    expected = with_changelog(card, changelog_lines(CHANGES.read_text(encoding="utf-8")))
    if "--check" in argv:
        if card != expected:
            print(f"{CARD.name}'s changelog= differs from {CHANGES.name}: run python scripts/changelog.py")
            return 1
        return 0
    CARD.write_text(expected, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
