"""The regular bulk of a file checked from its bytes, so that the XML parser and the element checks see the rest.

Most of a city model's bytes are three kinds of small, regular elements repeated hundreds of thousands of
times: the TIN's triangles, the polygons of a MultiSurface (a road's traffic area) and the texture
associations of one ring each. Handing each of their elements to Python through lxml cost most of the
validation's time. So each chunk read is first scanned with compiled patterns (C speed) for whole elements
of exactly those layouts, written with the usual prefixes and attributes; their values are checked in bulk
with numpy by the same rules as the element checks (unique gml:ids, 3D positions, closed triangles with an
area, references that resolve, as many texture-coordinate pairs as the ring has points), and when all of
them pass they are *thinned*: cut out of the chunk before the parser gets it. They hold no newline, so every
line number the parser reports stays where it was. A chunk with an element that fails, or with what the
patterns cannot read safely, goes to the parser whole and the element checks report it in their words; an
element cut by the chunk's end is not matched, the parser gets it whole. The XSD validation reads the file
itself and sees everything.

The bytes mean what they seem only without comments, CDATA sections and a DOCTYPE (``<!``), with the ``gml``
and ``app`` prefixes bound once, on the root, to GML 3.2 and CityGML 3.0's appearance; triangles are measured
in the model's CRS only while no other ``srsName`` has been read. A start tag comes before what it holds, so
each of these is known for a chunk when it is read: from the first chunk that breaks one, nothing is thinned.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .context import FileContext
from .geometry import triangle_areas
from .ids import hashes
from .names import APP, GML
from .references import ReferenceChecks
from .textures import TextureChecks

_ID = rb'"([^"]*)"'  # what an id or a text may hold is checked on all of them at once (``_token_counts``)
_NUMBERS = rb"([^<]*)"
_TRIANGLE = re.compile(
    rb"<gml:Triangle><gml:exterior><gml:LinearRing gml:id=" + _ID + rb'><gml:posList srsDimension="3">' + _NUMBERS
    + rb"</gml:posList></gml:LinearRing></gml:exterior></gml:Triangle>")
_POLYGON = re.compile(
    rb"<gml:surfaceMember><gml:Polygon gml:id=" + _ID + rb"><gml:exterior><gml:LinearRing gml:id=" + _ID
    + rb'><gml:posList srsDimension="3">' + _NUMBERS + rb"</gml:posList></gml:LinearRing></gml:exterior>"
    rb"</gml:Polygon></gml:surfaceMember>")
_ASSOCIATION = re.compile(
    rb"<app:textureParameterization><app:TextureAssociation><app:target>#([^<]*)</app:target>"
    rb"<app:textureParameterization><app:TexCoordList><app:textureCoordinates>" + _NUMBERS
    + rb"</app:textureCoordinates><app:ring>#([^<]*)</app:ring></app:TexCoordList></app:textureParameterization>"
    rb"</app:TextureAssociation></app:textureParameterization>")
_MODEL_CRS = re.compile(  # envelope_srs from the bytes: the root's first child is its boundedBy
    rb'<core:CityModel\s[^>]*>\s*<gml:boundedBy>\s*<gml:Envelope\s[^>]*\bsrsName="([^"<&]*)"')
_TEXTURE_ID = re.compile(rb'<app:ParameterizedTexture gml:id="([^"]*)"')
_NOT_IN_ID = re.compile(rb"[\s&<>|]")
_NUMBER_BYTES = b"0123456789eE+-. |"  # single spaces between the numbers (and "|" between texts): counted below
_HEAD = 1 << 16  # bytes in which the model's CRS is looked for
_MARK = 16  # bytes kept from the chunk before: a marker split by the chunk boundary is still seen


class BulkChecks:
    """Checks the regular elements of each chunk and thins them out of it (``thin``)."""

    def __init__(self, ctx: FileContext, references: ReferenceChecks, textures: TextureChecks,
                 min_triangle_area: float):
        self.ctx, self.issues = ctx, ctx.issues
        self.references, self.textures, self.min_area = references, textures, min_triangle_area
        self.enabled = True
        self.offset = 0  # of the chunk in the file
        self.lines = _LinesBefore(ctx.path)
        self.in_shell = 0  # gml:Shell elements open at the chunk's start (their polygons are a solid's faces)
        self.texture_id: str | None = None  # the last app:ParameterizedTexture met (owns the associations)
        self.tail = b""
        self.first = True
        self.head: bytes | None = b""  # the file's start, until the model's CRS is read from it
        self.thinned = 0  # elements checked from the bytes

    def disable_for(self, nsmap: dict[str | None, str]) -> None:
        """No bulk reading for a file whose root binds ``gml`` or ``app`` otherwise."""
        if nsmap.get("gml") != GML or nsmap.get("app") != APP:
            self.enabled = False

    def thin(self, chunk: bytes) -> bytes:
        """The chunk with its regular elements checked and cut out (or as it is; see the module docstring)."""
        if self.enabled and not self._plain(chunk):
            self.enabled = False
        self.tail = chunk[-_MARK:]
        if self.head is not None:
            self._model_crs(self.head, chunk)
        self.first = False
        shells = (chunk.count(b"<gml:Shell"), chunk.count(b"</gml:Shell>")) if b"Shell" in chunk else (0, 0)
        open_shells, self.in_shell = self.in_shell, max(0, self.in_shell + shells[0] - shells[1])
        thinned = chunk
        if self.enabled:
            thinned = self._triangles(thinned)
            if not (open_shells or shells[0]):  # a solid's faces (same layout) are checked with their solid
                thinned = self._polygons(thinned)
            thinned = self._associations(thinned)
        self.offset += len(chunk)
        return thinned

    def _plain(self, chunk: bytes) -> bool:
        """No ``<!`` (comment, CDATA, DOCTYPE) and, after the root's start tag, no ``gml``/``app`` prefix bound
        again; a marker split by the chunk boundary is seen in the tail of the chunk before."""
        seam = self.tail + chunk[:_MARK]
        if b"<!" in chunk or b"<!" in seam:
            return False
        if self.first or not (b"xmlns:" in chunk or b"xmlns:" in seam):
            return True
        seen = self.tail + chunk
        return not (b"xmlns:gml=" in seen or b"xmlns:app=" in seen)

    def _model_crs(self, head: bytes, chunk: bytes) -> None:
        """The model's CRS from the start of the file (``head``: read so far), before the parser hands out the
        root's first part."""
        self.head = head = head + chunk
        found = _MODEL_CRS.search(head)
        if found or b"</gml:Envelope>" in head or b"Member>" in head or len(head) > _HEAD:
            if found and self.ctx.model_crs is None:
                self.ctx.model_crs = found.group(1).decode()
            self.head = None

    def _triangles(self, chunk: bytes) -> bytes:
        frame = self.ctx.model_frame()
        if frame.assumed or self.ctx.own_crs_possible() or b"<gml:Triangle>" not in chunk:
            return chunk  # a CRS not known (yet), or an srsName of some geometry's own: the element checks' frames
        pieces = _TRIANGLE.split(chunk)
        ids, texts = pieces[1::3], pieces[2::3]
        counts = _token_counts(ids, texts)
        if counts is None or (counts != 12).any():
            return chunk
        corners = np.fromstring(b" ".join(texts), sep=" ").reshape(-1, 4, 3)
        areas, swapped = triangle_areas(corners[:, :3], [frame] * len(corners))
        if swapped or not ((corners[:, 0] == corners[:, 3]).all() and (areas > self.min_area).all()):
            return chunk  # the element checks report the bad triangles, and the reading swapped
        self._ids(pieces, 3, [ids], np.full(len(ids), 4, dtype=np.uint32))
        return b"".join(pieces[0::3])

    def _polygons(self, chunk: bytes) -> bytes:
        if b"<gml:surfaceMember><gml:Polygon " not in chunk:
            return chunk
        pieces = _POLYGON.split(chunk)
        counts = _token_counts(pieces[1::4] + pieces[2::4], pieces[3::4])
        if counts is None or (counts % 3).any():
            return chunk
        points = np.zeros(2 * len(counts), dtype=np.uint32)
        points[1::2] = counts // 3
        self._ids(pieces, 4, [pieces[1::4], pieces[2::4]], points)
        return b"".join(pieces[0::4])

    def _associations(self, chunk: bytes) -> bytes:
        owner = self.texture_id
        textures = _TEXTURE_ID.findall(chunk) if b"<app:ParameterizedTexture " in chunk else []
        if textures:
            self.texture_id = textures[-1].decode()
        if b"<app:textureParameterization><app:TextureAssociation><app:target>" not in chunk:
            return chunk
        pieces = _ASSOCIATION.split(chunk)
        counts = _token_counts(pieces[1::4] + pieces[3::4], pieces[2::4])
        if counts is None or (counts % 2).any():
            return chunk  # the element checks name the bad values
        targets = [target.decode() for target in pieces[1::4]]
        rings = [ring.decode() for ring in pieces[3::4]]
        known, points = self.references.ids.find(hashes(targets + rings))
        pairs = counts // 2
        self.thinned += len(targets)
        if not known.all() or (points[len(targets):] != pairs).any():  # said now or at the end, with their lines
            lines = self._lines(pieces, 4)
            names = [owner] + [name.decode() for name in textures]
            owners = [names[min(k, len(names) - 1)] for k in self._texture_before(pieces, 4)]
            self.references.resolve(targets + rings, np.array(lines + lines),
                                    ["app:target"] * len(targets) + ["app:ring"] * len(rings))
            self.textures.compare(rings, pairs.tolist(), lines, owners)
        return b"".join(pieces[0::4])

    def _ids(self, pieces: list[bytes], step: int, columns: list[list[bytes]], points: np.ndarray) -> None:
        """Store the ids of the matches (``columns``: the id groups, interleaved per match); a repeated one is
        reported on its line."""
        ids = [gid.decode() for row in zip(*columns) for gid in row]
        self.thinned += len(ids) // len(columns)
        duplicate = self.references.ids.add(hashes(ids), points)
        if duplicate.any():
            lines = self._lines(pieces, step)
            for k in np.flatnonzero(duplicate).tolist():
                self.issues.add("duplicate-id", lines[k // len(columns)], ids[k], f"gml:id '{ids[k]}' is used more "
                                "than once; every gml:id in a file must be unique.")

    def _lines(self, pieces: list[bytes], step: int) -> list[int]:
        """The line of each match of a ``split`` (the matches hold no newline: those of the gaps before)."""
        before = np.cumsum([gap.count(b"\n") for gap in pieces[0:-1:step]])
        return (self.lines.before(self.offset) + before + 1).tolist()

    def _texture_before(self, pieces: list[bytes], step: int) -> list[int]:
        """For each match of a ``split``, how many ParameterizedTexture start tags the chunk has before it."""
        return np.cumsum([gap.count(b"<app:ParameterizedTexture ") for gap in pieces[0:-1:step]]).tolist()


class _LinesBefore:
    """Lines of the file before a byte offset: counted only when a report needs a line, from where the last count
    stopped (a valid file is never counted)."""

    def __init__(self, path: Path):
        self.path, self.offset, self.lines = path, 0, 0

    def before(self, offset: int) -> int:
        if offset < self.offset:
            self.offset = self.lines = 0
        with open(self.path, "rb") as stream:
            stream.seek(self.offset)
            while self.offset < offset:
                block = stream.read(min(offset - self.offset, 1 << 20))
                if not block:
                    break
                self.lines += block.count(b"\n")
                self.offset += len(block)
        return self.lines


def _token_counts(ids: list[bytes], texts: list[bytes]) -> np.ndarray | None:
    """Numbers per text, or None when an id or a text is not written the regular way: ids without spaces or
    markup, numbers in plain notation separated by single spaces (then counting the spaces counts them)."""
    if not texts or not all(texts):
        return None
    joined = b"|".join(texts)
    if (joined.translate(None, _NUMBER_BYTES) or b"  " in joined or b" |" in joined or b"| " in joined
            or joined[:1] == b" " or joined[-1:] == b" " or _NOT_IN_ID.search(b"".join(ids))):
        return None
    buffer = np.frombuffer(joined, dtype=np.uint8)
    starts = np.zeros(len(texts), dtype=np.int64)
    starts[1:] = np.flatnonzero(buffer == 124) + 1
    return np.add.reduceat(buffer == 32, starts, dtype=np.int64) + 1
