"""Names and texts written into SQL statements, quoted."""
from __future__ import annotations


def sql_name(name: str) -> str:
    """``name`` (a layer's or a field's, maybe a user's) as an SQL identifier: quoted, inner quotes doubled."""
    return '"' + name.replace('"', '""') + '"'


def sql_text(text: str) -> str:
    """``text`` as an SQL string literal: single-quoted, inner single quotes doubled."""
    return "'" + text.replace("'", "''") + "'"
