"""The CityGML reader: one streaming parse of a file, handed out in finished parts that are freed once read.

The validator checks every part; the metrics read the buildings' solids from them.

The file is fed to lxml's push parser a chunk at a time. After each chunk, the elements along the
path to the parser's position are open; the children before the last child of an open element are
finished. Those are handed out as a part (parent, n) — the root's finished children after every
chunk, a deeper element's once it holds ``MIN_PART`` of them (the triangles of a TIN, the texture
associations of an appearance, the entries of a texture coordinate list) — and deleted when the
consumer asks for the next part. Memory thus stays about one chunk whatever the file's size.
A ``gml:Solid`` is never split: its faces are checked together.

The last child of an open element is never handed out or deleted, even if finished: the parser may
still be appending its tail text.
"""
from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from lxml import etree

from .namespaces import GML

_POSITION = re.compile(r", line \d+, column \d+$")
CHUNK_BYTES = 1 << 20
"""Bytes fed to the parser between two hand-outs (1 MB measured faster than 2 or 4 MB, and smaller)."""
MIN_PART = 64
"""Finished children an element below the root needs before they are handed out (fewer wait for more)."""

PARSE_OPTIONS = {"resolve_entities": False, "no_network": True, "load_dtd": False, "remove_comments": True,
                 "remove_pis": True}
"""Never expand entities, load DTDs or touch the network (XXE-safe); comments and PIs are dropped."""


class SyntaxProblem(Exception):
    """The file stops being well-formed XML; ``at_end``: only its end was missing (truncated)."""

    def __init__(self, line: int | None, message: str, at_end: bool):
        super().__init__(message)
        self.line, self.message, self.at_end = line, message, at_end


def first_element(path: Path) -> etree._Element:
    """The root element as parsed from the start of the file (raises ``SyntaxProblem``).

    The file is opened and closed here: iterparse leaves a path it opened to the garbage collector to
    close (a ResourceWarning, "unclosed file", after every validation)."""
    with open(path, "rb") as stream:
        events = etree.iterparse(stream, events=("start",), **PARSE_OPTIONS)
        try:
            return next(events)[1]
        except etree.XMLSyntaxError as exc:
            raise _problem(exc, events.error_log, at_end=False) from None
        except StopIteration:
            raise SyntaxProblem(None, "no element found", at_end=True) from None


class Stream:
    """The parts of one file, in document order (see the module docstring)."""

    def __init__(self, path: Path, root_tag: str, on_chunk: Callable[[int], None],
                 schema: etree.XMLSchema | None = None):
        self.path, self.on_chunk = path, on_chunk
        self.root: etree._Element | None = None
        self.parser = etree.XMLPullParser(events=("start",), tag=root_tag, schema=schema, **PARSE_OPTIONS)
        self.schema_errors: list[etree._LogEntry] = []  # when validating with ``schema`` (no line numbers)
        self.raw = RawCounts()
        self.thin: Callable[[bytes], bytes] | None = None  # cuts what of a chunk the parser need not see

    def parts(self, chunk_bytes: int | None = None) -> Iterator[tuple[etree._Element, int]]:
        """Yield (parent, n): the first n children of ``parent`` are finished; they go when the next part is
        asked for."""
        size = chunk_bytes or CHUNK_BYTES
        with open(self.path, "rb") as stream:
            while True:
                chunk = stream.read(size)
                if not chunk:
                    break
                self.raw.count(chunk)
                try:
                    self.parser.feed(self.thin(chunk) if self.thin is not None else chunk)
                except etree.XMLSyntaxError as exc:
                    raise _problem(exc, self.parser.feed_error_log, at_end=False) from None
                for _, element in self.parser.read_events():
                    if self.root is None:
                        self.root = element
                if self.root is not None:
                    yield from self._finished()
                self.on_chunk(stream.tell())
        try:
            self.parser.close()
        except etree.XMLSyntaxError as exc:
            log = self.parser.feed_error_log.filter_from_errors()  # this parse only (the exception's may hold older)
            schema = [e for e in log if e.domain == etree.ErrorDomains.SCHEMASV]
            if not schema or len(schema) < len(log):
                raise _problem(exc, self.parser.feed_error_log, at_end=True) from None
            self.schema_errors = schema
        if self.root is not None and len(self.root):
            yield self.root, len(self.root)
            del self.root[:]

    def _finished(self) -> Iterator[tuple[etree._Element, int]]:
        node, depth, in_solid = self.root, 0, False
        while node is not None:
            in_solid = in_solid or node.tag == GML + "Solid"
            done = len(node) - 1
            if done > 0 and (depth == 0 or (done >= MIN_PART and not in_solid)):
                yield node, done
                del node[:done]
            node, depth = (node[-1] if len(node) else None), depth + 1


def envelope_srs(children: Iterable[etree._Element]) -> str | None:
    """The srsName of the model's envelope (``gml:boundedBy/gml:Envelope``) among the root's ``children``."""
    for child in children:
        if child.tag == GML + "boundedBy":
            envelope = child.find(GML + "Envelope")
            return envelope.get("srsName") if envelope is not None else None
    return None


class RawCounts:
    """Counts of a few attribute spellings in the bytes read so far: a cheap sign that the slow paths are needed.

    A positive count may come from text that merely looks like the attribute (then a slow path runs
    for nothing); an attribute is never missed, since it is spelled out in the bytes.
    """

    _WORDS = (b"srsName", b"srsDimension", b'srsDimension="3"', b"href")

    def __init__(self) -> None:
        self.counts = dict.fromkeys(self._WORDS, 0)
        self._tail = b""

    def count(self, chunk: bytes) -> None:
        seam = self._tail + chunk[:32]  # words split by the chunk boundary
        for word in self._WORDS:
            if word == b"href" and self.counts[word]:
                continue  # only whether there are any matters
            self.counts[word] += chunk.count(word) + seam.count(word) - self._tail.count(word) - chunk[:32].count(word)
        self._tail = chunk[-32:]

    @property
    def srs_names(self) -> int:
        return self.counts[b"srsName"]

    @property
    def hrefs(self) -> int:
        return self.counts[b"href"]

    @property
    def any_dimension_not_3(self) -> bool:
        return self.counts[b"srsDimension"] != self.counts[b'srsDimension="3"']


def _problem(exc: etree.XMLSyntaxError, log: etree._ListErrorLog, at_end: bool) -> SyntaxProblem:
    """The error that stopped the parser, from this parse's own log (the exception's may hold older errors).

    The last entry is the one placed in the document: inside an entity's text libxml2 counts lines
    from the entity's start (an entity loop is "line 1" there, then the line that used it).
    """
    errors = log.filter_from_errors() if log is not None else []
    if errors:
        return SyntaxProblem(errors[-1].line or None, errors[-1].message.strip(), at_end)
    return SyntaxProblem(exc.lineno or None, _POSITION.sub("", exc.msg or str(exc)).strip(), at_end)
