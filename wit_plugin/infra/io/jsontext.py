"""JSON text as Python's ``json`` module writes it, whatever another package did to that module.

cjio (0.10, which CityJSON tools a user has in the same Python import, and so do our tests) replaces the
module's float formatting process-wide with six decimals, and its C encoder with the Python one: a tileset's
regions, a glTF's accessor bounds and the building attributes in 3D Tiles, rounded so, no longer hold what they
describe. Every JSON the core writes goes through ``dumps``.
"""
from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

_C_ENCODER: Callable[..., Any] | None = None
try:
    import _json
    _C_ENCODER = _json.make_encoder
except ImportError:  # an interpreter without the C accelerator
    pass


def dumps(value: object, **options) -> str:
    """``json.dumps(value, **options)`` with the module's own float formatting and encoder for the call (another
    package's replacement, if any, is put back after it)."""
    module: Any = json.encoder  # its attributes as another package may have replaced them
    encoder, number = module.c_make_encoder, module.__dict__.get("float")  # cjio shadows the built-in float there
    module.c_make_encoder = _C_ENCODER
    module.__dict__.pop("float", None)
    try:
        return json.dumps(value, **options)
    finally:
        module.c_make_encoder = encoder
        if number is not None:
            module.float = number
