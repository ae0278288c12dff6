"""Textures: image files that exist, and one (s t) pair of finite numbers per point of each textured ring."""
from __future__ import annotations

import math
import re
from array import array

import numpy as np
from lxml import etree

from .context import FileContext
from .ids import hashes
from .names import A, owner_id
from .parts import NON_NUMBER, Elements, Part, Query, token_counts
from .references import RingRefs

_REMOTE = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]+://")
_UNEVEN_LISTS = Query("app:TexCoordList[count(app:textureCoordinates) != count(app:ring)]")


class TextureChecks:
    """Texture images and coordinates; pairs for rings not seen yet are compared at the end."""

    def __init__(self, ctx: FileContext):
        self.ctx, self.issues, self.ids = ctx, ctx.issues, ctx.ids
        self.tex_rings: list[tuple[str, int, int | None, str | None]] = []  # ring id, pairs, line, texture
        self.forward_tex_rings: list[tuple[str, int, int | None, str | None]] = []
        self.tex_lists: dict[etree._Element, _TexCoordPairs] = {}  # lists handed out in several parts
        self.images: set[str] = set()

    def check(self, part: Part, elements: Elements, rings: RingRefs) -> None:
        for node in elements[A["imageURI"]]:
            uri = (node.text or "").strip()
            if uri in self.images:
                continue
            self.images.add(uri)
            if _REMOTE.match(uri):
                self.issues.add("texture-image", node.sourceline, owner_id(node), f"Texture image {uri} is remote and "
                                "was not checked.", "warning")
            elif not uri or not (self.ctx.path.parent / uri).is_file():
                self.issues.add("texture-image", node.sourceline, owner_id(node), f"Texture image '{uri}' does not "
                                f"exist (looked for {self.ctx.path.parent / uri}).")
        if part.parent.tag == A["TexCoordList"]:  # a long list handed out in parts
            pairs = self.tex_lists.get(part.parent)
            if pairs is None:
                pairs = self.tex_lists[part.parent] = _TexCoordPairs(self, part.parent)
            pairs.add(elements[A["textureCoordinates"]], elements[A["ring"]])
        elif elements[A["TexCoordList"]]:
            self._texcoord_lists(part, elements, rings)
        self._compare_tex(self.tex_rings, self.forward_tex_rings)
        self.tex_rings = []

    def _texcoord_lists(self, part: Part, elements: Elements, refs: RingRefs) -> None:
        """Pair the k-th coordinates with the k-th ring of all lists at once when each list pairs up evenly."""
        lists, coords, rings = elements[A["TexCoordList"]], elements[A["textureCoordinates"]], elements[A["ring"]]
        if self.tex_lists and any(tcl in self.tex_lists for tcl in lists):  # the end of lists handed out in parts
            for tcl in lists:
                pairs = self.tex_lists.pop(tcl, None)
                if pairs is not None:
                    pairs.add([c for c in tcl if c.tag == A["textureCoordinates"]],
                              [c for c in tcl if c.tag == A["ring"]])
                    pairs.close()
                    del tcl[:]
            coords = [node for node in coords if node.getparent() is not None]
            kept = np.fromiter((node.getparent() is not None for node in rings), dtype=bool, count=len(rings))
            rings, refs = [r for r, k in zip(rings, kept) if k], refs.subset(kept)
        texts = [node.text or "" for node in coords]
        if len(coords) != len(rings) or _UNEVEN_LISTS(part) or NON_NUMBER.search(" ".join(texts)):
            for tcl in lists:
                pairs = _TexCoordPairs(self, tcl)
                pairs.add([c for c in tcl if c.tag == A["textureCoordinates"]], [c for c in tcl if c.tag == A["ring"]])
                pairs.close()
            return
        counts = token_counts(texts)
        ring_ids, found, points = refs.ids, refs.found, refs.points
        for k in np.flatnonzero(counts % 2):
            self.issues.add("texture-coordinates", coords[k].sourceline, owner_id(coords[k]),
                            f"Texture coordinates for ring #{ring_ids[k]} have an odd number of values ({counts[k]}); "
                            "they are (s t) pairs.")
        even = counts % 2 == 0
        pair_counts = counts // 2
        for k in np.flatnonzero(even & found & (points > 0) & (pair_counts != points)):
            self._wrong_pairs(ring_ids[k], int(pair_counts[k]), int(points[k]), coords[k].sourceline,
                              owner_id(coords[k]))
        self.forward_tex_rings += [(ring_ids[k], int(pair_counts[k]), coords[k].sourceline, owner_id(coords[k]))
                                   for k in np.flatnonzero(even & ~found)]

    def compare(self, ring_ids: list[str], pairs: list[int], lines: list[int], texture_ids: list[str | None]) -> None:
        """Coordinate pairs of rings read from the bytes (``bulk``): compared with the rings seen, the others at the
        end."""
        self._compare_tex(list(zip(ring_ids, pairs, lines, texture_ids)), self.forward_tex_rings)

    def _compare_tex(self, tex_rings: list, unknown: list | None) -> None:
        """Compare texture pairs with the points of the rings seen; put the others in ``unknown`` (None: ignore)."""
        if not tex_rings:
            return
        found, points = self.ids.find(hashes([r[0] for r in tex_rings]))
        for (ring_id, pairs, line, tex_id), ok, n in zip(tex_rings, found.tolist(), points.tolist()):
            if not ok:
                if unknown is not None:
                    unknown.append((ring_id, pairs, line, tex_id))
            elif n and pairs != n:
                self._wrong_pairs(ring_id, pairs, n, line, tex_id)

    def _wrong_pairs(self, ring_id: str, pairs: int, points: int, line: int | None, tex_id: str | None) -> None:
        self.issues.add("texture-coordinates", line, tex_id, f"{pairs} texture coordinate pairs for ring #{ring_id}, "
                        f"which has {points} points; there must be one pair per point (closing point included).")

    def finish(self) -> None:
        """Compare the pairs of rings that came after their coordinates."""
        self._compare_tex(self.forward_tex_rings, None)


class _TexCoordPairs:
    """Pairs the textureCoordinates of one TexCoordList with its rings, in order, as they come.

    All coordinates come before the rings, so a list handed out in parts keeps only the number of
    pairs and the line of each coordinate list (16 bytes) until its ring arrives, not the elements.
    """

    def __init__(self, fc: TextureChecks, tcl: etree._Element):
        self.fc, self.line, self.tex_id = fc, tcl.sourceline, owner_id(tcl)
        self.pairs = array("q")  # (s t) pairs per coordinate list; minus the number of values when it is odd
        self.lines = array("q")
        self.faults: dict[int, list[str]] = {}  # coordinate list -> its non-finite values (first three)
        self.n_rings = 0

    def add(self, coords: list[etree._Element], rings: list[etree._Element]) -> None:
        """The next coordinate lists and ring references of the list (coordinates first, as the schema orders them)."""
        texts = [node.text or "" for node in coords]
        if NON_NUMBER.search(" ".join(texts)):
            for k, text in enumerate(texts):
                bad = non_finite(text.split()) if NON_NUMBER.search(text) else []
                if bad:
                    self.faults[len(self.pairs) + k] = bad[:3]
        counts = token_counts(texts)
        self.pairs.extend(np.where(counts % 2, -counts, counts // 2).tolist())
        self.lines.extend([node.sourceline or 0 for node in coords])
        first, self.n_rings = self.n_rings, self.n_rings + len(rings)
        ring_ids = [(node.text or "").strip().lstrip("#") for node in rings[:max(0, len(self.pairs) - first)]]
        issues = self.fc.issues
        for k, ring_id in zip(range(first, first + len(ring_ids)), ring_ids):
            pairs, line = self.pairs[k], self.lines[k] or None
            faults = self.faults.pop(k, None) if self.faults else None
            if faults:
                issues.add("texture-coordinates", line, self.tex_id, f"Texture coordinates for ring #{ring_id} "
                           f"contain {', '.join(repr(b) for b in faults)}: each must be a finite number.")
            if pairs < 0:
                issues.add("texture-coordinates", line, self.tex_id, f"Texture coordinates for ring #{ring_id} have "
                           f"an odd number of values ({-pairs}); they are (s t) pairs.")
            else:
                self.fc.tex_rings.append((ring_id, pairs, line, self.tex_id))

    def close(self) -> None:
        if len(self.pairs) != self.n_rings:
            self.fc.issues.add("texture-coordinates", self.line, self.tex_id, f"TexCoordList has {len(self.pairs)} "
                               f"textureCoordinates but {self.n_rings} ring references; they must pair up in order.")


def non_finite(tokens: list[str]) -> list[str]:
    """The tokens that are not finite numbers (one float() per token; most lists have none)."""
    try:
        if all(map(math.isfinite, map(float, tokens))):
            return []
    except ValueError:
        pass
    return [t for t in tokens if not _finite(t)]


def _finite(token: str) -> bool:
    try:
        return math.isfinite(float(token))
    except ValueError:
        return False
