"""Links of the project's Markdown files as GitHub resolves them: heading anchors and relative links."""
from __future__ import annotations

import re
from pathlib import Path

#: a Markdown link or image, its target up to an optional title: ``[text](target "title")``
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def github_anchors(markdown: str) -> set[str]:
    """The anchors GitHub gives a Markdown file's headings: lower case, punctuation dropped (letters, digits,
    '_', '-' and spaces kept), spaces as '-', a repeated anchor suffixed -1, -2, ...; code blocks skipped."""
    anchors: set[str] = set()
    counts: dict[str, int] = {}
    fenced = False
    for line in markdown.splitlines():
        if line.startswith("```"):
            fenced = not fenced
        heading = re.match(r"#{1,6} +(.*?) *#* *$", line)
        if fenced or not heading:
            continue
        slug = re.sub(r"[^\w\- ]", "", heading.group(1).lower()).replace(" ", "-")
        anchors.add(slug if slug not in counts else f"{slug}-{counts[slug]}")
        counts[slug] = counts.get(slug, 0) + 1
    return anchors


def broken_links(path: Path) -> list[str]:
    """The relative links of the Markdown file ``path`` whose file is missing, or whose ``#anchor`` is no heading
    of the file it names; web addresses are not followed. Links inside code blocks are not links."""
    text = path.read_text(encoding="utf-8")
    prose = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    broken = []
    for target in LINK.findall(prose):
        if re.match(r"[a-z]+:", target):
            continue
        file_part, _, anchor = target.partition("#")
        linked = (path.parent / file_part).resolve() if file_part else path
        if not linked.exists():
            broken.append(target)
        elif anchor and anchor not in github_anchors(linked.read_text(encoding="utf-8")):
            broken.append(target)
    return broken
