"""The text encoding of a vector source, decided before GDAL reads it.

Korean road-name-address shapefiles come in CP949 with no ``.cpg`` and a DBF language-driver
byte of 0, so GDAL would decode them as ISO-8859-1 and garble every Korean name. The encoding is
therefore decided here (explicit parameter, else a ``.cpg`` or language driver whose codec decodes
the text, else sniffed from the DBF bytes: ASCII, UTF-8, then CP949) and passed to GDAL as the
``ENCODING`` open option.
"""
from __future__ import annotations

import codecs
import contextlib
import os
import struct
from pathlib import Path

from ..feedback import SILENT, Feedback
from . import bulk_read
from .fileio import sidecar

DBF_SAMPLE_BYTES = 4 << 20  # sniff the encoding from the first 4 MiB of records


def python_codec(name: str) -> str | None:
    """Python codec for an encoding name as GDAL/.cpg spell it ("949", "CP949", "UTF-8"), else None."""
    name = name.strip()
    for candidate in (name, f"cp{name}" if name.isdigit() else ""):
        with contextlib.suppress(LookupError):
            if candidate:
                return codecs.lookup(candidate).name
    return None


def _dbf_text_sample(dbf: Path) -> tuple[int, bytes]:
    """The DBF language-driver byte and the text to sniff: its field names and the bytes of its
    character fields (a sample), one per line."""
    with open(dbf, "rb") as fh:
        header = fh.read(32)
        if len(header) < 32:
            return 0, b""
        n_records, header_len, record_len = struct.unpack("<IHH", header[4:12])
        ldid = header[29]
        descriptors = fh.read(max(header_len - 32, 0))
        names, spans, offset = [], [], 1  # byte 0 of a record is the deletion flag
        for i in range(0, len(descriptors) - 31, 32):
            if descriptors[i] == 0x0D:
                break
            names.append(descriptors[i:i + 11].split(b"\0")[0])
            width = descriptors[i + 16]
            if descriptors[i + 11:i + 12] == b"C":
                spans.append((offset, offset + width))
            offset += width
        fh.seek(header_len)
        data = fh.read(min(n_records * record_len, DBF_SAMPLE_BYTES))
    chunks = names
    for start in range(0, len(data) - record_len + 1, record_len) if record_len else ():
        chunks += [data[start + a:start + b].rstrip(b" \x00") for a, b in spans]
    return ldid, b"\n".join(chunks)


def _decodes(sample: bytes, codec: str) -> bool:
    try:
        sample.decode(codec)
        return True
    except UnicodeDecodeError:
        return False


#: DBF language-driver ids (LDID, header byte 29) → codec, as GDAL reads the common ones
LDID_CODECS = {0x01: "cp437", 0x02: "cp850", 0x03: "cp1252", 0x57: "latin-1", 0x64: "cp852", 0x78: "cp950",
               0x79: "cp949", 0x7A: "gbk", 0x7B: "cp932", 0xC8: "cp1250", 0xC9: "cp1251"}


KOREAN_CODECS = ("cp949", "euc_kr", "johab", "utf-8")


#: Python codec → the name GDAL's ENCODING option (CPLRecode: iconv) knows, where upper case is not it.
#: EUC-KR is read as CP949, its superset: a file declared EUC-KR may hold syllables only CP949 has (똠).
GDAL_ENCODINGS = {"euc_kr": "CP949", "utf-8": "UTF-8", "iso8859-1": "ISO-8859-1"}


def gdal_encoding(name: str) -> str:
    """The encoding name to give GDAL's ``ENCODING`` open option for an encoding name or Python codec."""
    codec = python_codec(name) or name
    return GDAL_ENCODINGS.get(codec, codec.upper().replace("_", "-"))


def _looks_korean(sample: bytes) -> bool:
    """CP949 decodes the text into Hangul (at least half of the non-ASCII characters), nearly all of
    it in the EUC-KR range: Latin-1 text such as "été" also decodes as CP949, but not as that."""
    try:
        text = sample.decode("cp949")
    except UnicodeDecodeError:
        return False
    wide = [c for c in text if ord(c) > 127]
    hangul = sum("\uac00" <= c <= "\ud7a3" or "\u3131" <= c <= "\u318e" for c in wide)
    unmapped = sample.decode("euc_kr", errors="replace").count("\ufffd")
    return bool(wide) and hangul >= len(wide) / 2 and unmapped <= len(wide) / 10


def shapefile_encoding(path: str | os.PathLike, feedback: Feedback = SILENT) -> str | None:
    """The encoding to open a shapefile with (GDAL's ``ENCODING`` option), or None when its text is ASCII.

    Always explicit for non-ASCII text: QGIS sets ``SHAPE_ENCODING=""`` (no recoding), under which
    GDAL would hand over the raw bytes and ignore the ``.cpg``, and GDAL 3.6's Arrow reader crashes
    on field names that are not UTF-8 (Korean names in CP949). The field names and a sample of the
    text decide: a declaration (``.cpg``, or a non-zero DBF language-driver byte) is trusted when its
    codec decodes them and, for a non-Korean codec, they are not Korean CP949: some tools write
    CP949 text under an ISO-8859-1 or Windows-1252 declaration, which decodes into mojibake
    without an error; that is read as CP949 with a warning. Otherwise the text is sniffed: valid
    UTF-8 is UTF-8, valid CP949 is CP949 (the Korean national data), else ISO-8859-1 (GDAL's
    default) with a warning.
    """
    shp = Path(path)
    dbf = sidecar(shp, ".dbf")
    if dbf is None:
        return None
    ldid, sample = _dbf_text_sample(dbf)
    if sample.isascii():
        return None
    cpg = sidecar(shp, ".cpg")
    declared, origin = None, ""
    if cpg is not None:
        text = cpg.read_text("ascii", errors="replace").strip()
        declared, origin = python_codec(text), f"its .cpg file says {text}"
    elif ldid != 0:
        declared = python_codec(LDID_CODECS.get(ldid, ""))
        origin = (f"its .dbf language driver (LDID 0x{ldid:02X}) says {declared}" if declared else
                  f"its .dbf language driver (LDID 0x{ldid:02X}) names a code page this reader does not know")
    if declared and _decodes(sample, declared):
        if declared in KOREAN_CODECS or not _looks_korean(sample):
            return gdal_encoding(declared)
        feedback.warning(f"{shp.name}: {origin}, but its text is Korean (CP949): read as CP949. "
                         "Set the encoding parameter to choose another.")
        return "CP949"
    for candidate in ("UTF-8", "CP949"):
        if _decodes(sample, candidate):
            if origin:
                feedback.warning(f"{shp.name}: {origin}{', which does not decode its text' if declared else ''}; "
                                 f"read as {candidate}. Set the encoding parameter to choose another.")
            return candidate
    said = (f", and {origin}, which does not decode it" if declared else f" ({origin})" if origin else
            ", and no encoding is declared")
    feedback.warning(f"{shp.name}: its text is neither UTF-8 nor CP949{said}; read as ISO-8859-1: set the encoding "
                     "parameter if names look garbled.")
    return "ISO-8859-1"


def decode_text(text: str) -> str:
    """Text GDAL handed over undecoded (not UTF-8: the bindings escape such bytes as surrogates) decoded as
    CP949 when it is that, else as Latin-1; UTF-8 text as it is."""
    if bulk_read.is_utf8(text):
        return text
    raw = text.encode("utf-8", "surrogateescape")
    return raw.decode("cp949") if _decodes(raw, "cp949") else raw.decode("latin-1")
