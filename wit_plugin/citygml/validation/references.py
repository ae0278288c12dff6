"""gml:ids (unique in the file) and ``#id`` references (each pointing to a gml:id of the file)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..namespaces import HREF
from .context import FileContext
from .ids import hashes
from .names import A, qname
from .parts import BY_ID, Elements, Part, Query, ring_point_counts

_IDS = Query("*/@gml:id")
_HREFS = Query("*/@xlink:href")
_WITH_HREF = Query("*[@xlink:href]")


class ReferenceChecks:
    """Every gml:id stored with its ring's point count; references resolved now or, to later ids, at the end."""

    def __init__(self, ctx: FileContext):
        self.ctx, self.issues, self.ids = ctx, ctx.issues, ctx.ids
        self.forward_refs: dict[str, tuple[int | None, str]] = {}  # to ids not seen yet: resolved at the end

    def add_ids(self, part: Part, elements: Elements, counts: np.ndarray) -> None:
        """Store every gml:id with its ring's point count; report the ids used before."""
        ids = _IDS(part)
        if not ids:
            return
        keys = hashes(ids)
        points = np.zeros(len(ids), dtype=np.uint32)
        ring_ids, ring_points = ring_point_counts(elements, counts, exact=self.ctx.raw.any_dimension_not_3)
        if ring_ids:
            ring_keys = hashes(ring_ids)
            order = np.argsort(ring_keys)
            at = np.minimum(np.searchsorted(ring_keys[order], keys), len(order) - 1)
            hit = ring_keys[order][at] == keys
            points[hit] = ring_points[order][at[hit]]
        duplicate = self.ids.add(keys, points)
        if duplicate.any():
            self._report_duplicates(part, [ids[i] for i in np.flatnonzero(duplicate)])

    def resolve(self, refs: list[str], lines: np.ndarray, hows: list[str]) -> None:
        """``#id`` references read from the bytes (without '#'): those to no id seen so far wait for the end."""
        found = self.ids.find(hashes(refs))[0]
        for k in np.flatnonzero(~found).tolist():
            self._forward(refs[k], int(lines[k]), hows[k])

    def _forward(self, ref: str, line: int | None, how: str) -> None:
        """A reference to an id not seen yet: kept with its earliest line."""
        known = self.forward_refs.get(ref)
        if known is None or (line is not None and (known[0] is None or line < known[0])):
            self.forward_refs[ref] = (line, how)

    def _report_duplicates(self, part: Part, duplicates: list[str]) -> None:
        """Name each later occurrence (its line) of an id met before."""
        extra: dict[str, int] = {}
        for gid in duplicates:
            extra[gid] = extra.get(gid, 0) + 1
        found = []
        for gid, k in extra.items():
            nodes = [node for child in part.parent[:part.n] for node in BY_ID(child, v=gid)]
            found += [(node.sourceline or 0, gid) for node in nodes[len(nodes) - k:]]
        for line, gid in sorted(found):
            self.issues.add("duplicate-id", line or None, gid, f"gml:id '{gid}' is used more than once; every gml:id "
                            "in a file must be unique.")

    def check(self, part: Part, elements: Elements) -> RingRefs:
        """``#id`` references resolved against the ids seen so far; the others wait, with their line, for the end.

        Returns the part's app:ring references looked up, for the texture check.
        """
        hrefs = [h[1:] for h in _HREFS(part) if h.startswith("#")] if self.ctx.raw.hrefs else []
        targets = [(node.text or "").strip() for node in elements[A["target"]]]
        rings = [(node.text or "").strip() for node in elements[A["ring"]]]
        target_refs = [t[1:] for t in targets if t.startswith("#")]
        ring_refs = [t[1:] for t in rings if t.startswith("#")]
        refs = hrefs + target_refs + ring_refs
        found, points = self.ids.find(hashes(refs))
        ring_ids = [t.lstrip("#") for t in rings]
        if len(ring_refs) == len(rings):
            ring_lookup = RingRefs(ring_ids, found[len(refs) - len(rings):], points[len(refs) - len(rings):])
        else:
            ring_lookup = RingRefs(ring_ids, *self.ids.find(hashes(ring_ids)))
        if found.all():
            return ring_lookup
        missing = {refs[i] for i in np.flatnonzero(~found)}
        located = [(node.sourceline or 0, node.get(HREF)[1:], f"xlink:href of {qname(node.tag)}")
                   for node in (_WITH_HREF(part) if hrefs else []) if node.get(HREF).startswith("#")]
        located += [(node.sourceline or 0, text[1:], qname(node.tag)) for kind, texts in
                    ((A["target"], targets), (A["ring"], rings)) for node, text in zip(elements[kind], texts)
                    if text.startswith("#")]
        for line, ref, how in sorted(located, key=lambda item: item[0]):
            if ref in missing:
                self._forward(ref, line or None, how)
        return ring_lookup

    def finish(self) -> None:
        """Report the references to ids that never came."""
        forward = self.forward_refs
        found = self.ids.find(hashes(list(forward)))[0]
        for (ref, (line, how)), ok in zip(forward.items(), found.tolist()):
            if not ok:
                self.issues.add("reference", line, None, f"{how} '#{ref}' points to no gml:id in this file.")


class RingRefs(NamedTuple):
    """The app:ring references of a part (without '#') and whether and with how many points each ring exists."""
    ids: list[str]
    found: np.ndarray
    points: np.ndarray

    def subset(self, keep: np.ndarray) -> RingRefs:
        return RingRefs([r for r, k in zip(self.ids, keep) if k], self.found[keep], self.points[keep])
