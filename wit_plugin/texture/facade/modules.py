"""Storey modules drawn in code: one tileable facade image per style and variant (no third-party images).

A *module* is one storey of ``MODULE_WIDTH`` metres of wall, ``MODULE_PX`` × ``STOREY_PX`` texels: piers,
windows with frames and sills, balcony bands, shop fronts, curtain-wall panels, corrugated metal, as each
style has them. It tiles horizontally (everything lies inside the module or is cut at its edge so that its
two edges meet). A facade image stacks ``rows`` storeys, the ground floor at the bottom (its own module for
the styles that have one: shop fronts, office lobbies, the pilotis of a 빌라, a factory's shutter door), so
that one image row is one storey and the whole wall of a building maps onto the image from v = 0 (ground)
to v = storeys / rows (roof line on a row boundary). Variants differ in colour and window rhythm. Drawing
is deterministic: the same style, variant and rows give the same pixels on every machine.
"""
from __future__ import annotations

import zlib

import numpy as np

from .uses import APARTMENT, CURTAIN_WALL, HOUSE, INDUSTRIAL, OFFICE, OTHER, PUBLIC, RETAIL, VARIANTS, VILLA

MODULE_PX = 64  # texels across a module
STOREY_PX = 32  # texels up a storey
MODULE_WIDTH = 6.4  # metres of wall one module covers (10 texels a metre)

Colour = tuple[int, int, int]

#: per style, per variant: (wall colour, accent colour, windows across a module)
_PALETTES: dict[str, tuple[tuple[Colour, Colour, int], ...]] = {
    HOUSE: (((152, 76, 56), (236, 232, 220), 1), ((226, 214, 186), (120, 84, 60), 2),
            ((120, 84, 64), (230, 226, 214), 2), ((206, 206, 198), (92, 96, 104), 1)),
    VILLA: (((162, 86, 66), (240, 238, 230), 2), ((214, 196, 160), (112, 88, 70), 2),
            ((190, 188, 182), (70, 74, 82), 3), ((140, 100, 74), (236, 230, 214), 2)),
    APARTMENT: (((238, 238, 232), (120, 150, 178), 2), ((232, 222, 200), (150, 120, 96), 3),
                ((212, 214, 216), (70, 110, 150), 2), ((210, 218, 226), (200, 90, 70), 3)),
    RETAIL: (((200, 200, 196), (200, 40, 40), 2), ((218, 204, 176), (30, 90, 170), 2),
             ((170, 96, 74), (240, 190, 30), 3), ((232, 232, 228), (40, 140, 80), 2)),
    OFFICE: (((150, 152, 156), (70, 100, 130), 8), ((196, 186, 164), (80, 110, 120), 4),
             ((96, 98, 104), (90, 120, 150), 8), ((222, 222, 218), (60, 90, 110), 4)),
    CURTAIN_WALL: (((70, 110, 152), (200, 206, 212), 4), ((62, 122, 124), (196, 204, 204), 4),
                   ((122, 138, 154), (220, 224, 228), 3), ((52, 62, 78), (150, 156, 164), 4)),
    PUBLIC: (((230, 220, 190), (60, 140, 90), 2), ((190, 122, 92), (236, 232, 220), 2),
             ((202, 202, 196), (220, 120, 40), 3), ((204, 216, 192), (70, 110, 150), 2)),
    INDUSTRIAL: (((200, 205, 210), (120, 126, 132), 1), ((92, 122, 160), (220, 224, 228), 0),
                 ((226, 220, 200), (110, 110, 104), 1), ((112, 142, 112), (214, 218, 210), 0)),
    OTHER: (((200, 194, 184), (90, 94, 100), 1), ((184, 176, 160), (80, 84, 90), 2),
            ((214, 210, 204), (96, 100, 110), 1), ((168, 160, 150), (230, 226, 218), 2)),
}
_GLASS = np.array([(70, 92, 112), (96, 124, 146)], dtype=np.float32)  # window glass: bottom, top of a pane
_DARK = np.array((44, 46, 50), dtype=np.float32)


def facade_image(style: str, variant: int, rows: int) -> np.ndarray:
    """The facade image of ``style``/``variant`` with ``rows`` storeys: (rows · STOREY_PX, MODULE_PX, 3) uint8."""
    if style not in _PALETTES or not 0 <= variant < VARIANTS or rows < 1:
        raise ValueError(f"no facade {style!r} variant {variant} of {rows} storeys")
    upper, ground = storey_modules(style, variant)
    return np.concatenate([upper] * (rows - 1) + [ground], axis=0)


def storey_modules(style: str, variant: int) -> tuple[np.ndarray, np.ndarray]:
    """(upper storey, ground floor) modules of ``style``/``variant``, each (STOREY_PX, MODULE_PX, 3) uint8."""
    wall, accent, count = _PALETTES[style][variant]
    rng = np.random.default_rng(zlib.crc32(f"{style}/{variant}".encode()))
    upper = _Module(wall, rng)
    ground = None
    if style in (HOUSE, OTHER):
        upper.windows(count, 0.30 if style == HOUSE else 0.24, top=9, bottom=23, frame=accent)
    elif style == VILLA:
        upper.windows(count, 0.32, top=8, bottom=22, frame=accent)
        ground = _Module(wall, rng).pilotis(accent)
    elif style == APARTMENT:
        upper.balconies(count, accent)
    elif style == RETAIL:
        upper.windows(count, 0.34, top=7, bottom=24, frame=(236, 236, 232))
        ground = _Module(wall, rng).shop_front(accent)
    elif style == OFFICE:
        upper.window_band(count, accent)
        ground = _Module(wall, rng).lobby(accent)
    elif style == CURTAIN_WALL:
        upper.curtain_wall(count, wall, accent)
        ground = _Module(wall, rng).lobby(accent)
    elif style == PUBLIC:
        upper.windows(count, 0.36, top=7, bottom=23, frame=(240, 240, 236))
        upper.band(accent, 25, 27)
    elif style == INDUSTRIAL:
        upper.corrugated()
        if count:
            upper.windows(2, 0.30, top=3, bottom=8, frame=accent)
        ground = _Module(wall, rng).corrugated().shutter(accent) if variant % 2 == 0 else None
    upper.slab()
    ground = (ground.slab() if ground is not None else upper)
    return upper.pixels(), ground.pixels()


class _Module:
    """One storey module being drawn (float RGB, row 0 at the top of the storey)."""

    def __init__(self, wall: Colour, rng: np.random.Generator):
        self.rng, self.wall = rng, np.array(wall, dtype=np.float32)
        grain = rng.normal(0.0, 3.0, (STOREY_PX, MODULE_PX, 1)).astype(np.float32)
        self.rgb = self.wall + grain

    def pixels(self) -> np.ndarray:
        return np.clip(np.rint(self.rgb), 0, 255).astype(np.uint8)

    def fill(self, x0: int, x1: int, y0: int, y1: int, colour) -> None:
        self.rgb[y0:y1, x0:x1] = np.asarray(colour, dtype=np.float32)

    def glass(self, x0: int, x1: int, y0: int, y1: int, tint: float = 0.0) -> None:
        """A pane, lighter towards its top (the sky it reflects)."""
        t = np.linspace(1.0, 0.0, max(1, y1 - y0), dtype=np.float32)[:, None, None]
        pane = _GLASS[0] + (_GLASS[1] - _GLASS[0]) * t
        self.rgb[y0:y1, x0:x1] = pane * (1.0 + tint)

    def windows(self, count: int, share: float, top: int, bottom: int, frame: Colour) -> _Module:
        """``count`` windows spaced evenly across the module, each ``share`` of a slot wide, with frame and sill."""
        slot = MODULE_PX / count
        width = max(4, round(slot * share * 2))
        for k in range(count):
            centre = round(slot * (k + 0.5))
            x0, x1 = centre - width // 2, centre + (width + 1) // 2
            self.fill(x0 - 1, x1 + 1, top - 1, bottom + 1, frame)
            self.glass(x0, x1, top, bottom)
            self.fill(x0 + (x1 - x0) // 2, x0 + (x1 - x0) // 2 + 1, top, bottom, frame)  # the sash's meeting rail
            self.fill(x0 - 2, x1 + 2, bottom + 1, bottom + 2, self.wall * 1.12)  # sill
        return self

    def balconies(self, count: int, accent: Colour) -> _Module:
        """An apartment storey: a glazed balcony across each unit over a solid parapet, piers between units."""
        pier = 4
        self.glass(pier // 2, MODULE_PX - pier // 2, 5, 22, tint=0.08)
        for k in range(1, 2 * count):
            x = round(k * MODULE_PX / (2 * count))
            self.fill(x, x + 1, 5, 22, (200, 204, 206))  # sash frames
        self.fill(pier // 2, MODULE_PX - pier // 2, 22, 30, self.wall * 1.04)  # parapet
        self.fill(pier // 2, MODULE_PX - pier // 2, 22, 23, (150, 152, 156))  # its coping
        self.fill(0, pier // 2, 0, STOREY_PX, np.asarray(accent, dtype=np.float32) * 0.5 + self.wall * 0.5)
        self.fill(MODULE_PX - pier // 2, MODULE_PX, 0, STOREY_PX, np.asarray(accent) * 0.5 + self.wall * 0.5)
        return self

    def window_band(self, mullions: int, glass: Colour) -> _Module:
        """An office storey: a continuous glass band with mullions over a stone spandrel."""
        self.glass(0, MODULE_PX, 6, 24, tint=0.05)
        self.rgb[6:24, :] = self.rgb[6:24, :] * 0.6 + np.asarray(glass, dtype=np.float32) * 0.4
        for k in range(mullions):
            x = round(k * MODULE_PX / mullions)
            self.fill(x, x + 1, 6, 24, (60, 62, 66))
        return self

    def curtain_wall(self, panels: int, glass: Colour, mullion: Colour) -> _Module:
        """A glass tower storey: panels with slightly different reflections, mullions, a spandrel line."""
        width = MODULE_PX / panels
        base = np.asarray(glass, dtype=np.float32)
        for k in range(panels):
            x0, x1 = round(k * width), round((k + 1) * width)
            t = np.linspace(1.25, 0.85, STOREY_PX, dtype=np.float32)[:, None, None]
            self.rgb[:, x0:x1] = base * t * (1.0 + self.rng.uniform(-0.08, 0.08))
            self.fill(x0, x0 + 1, 0, STOREY_PX, mullion)
        self.fill(0, MODULE_PX, 26, 29, base * 0.55)  # spandrel at the floor slab
        return self

    def band(self, colour: Colour, y0: int, y1: int) -> _Module:
        self.fill(0, MODULE_PX, y0, y1, colour)
        return self

    def pilotis(self, accent: Colour) -> _Module:
        """A 빌라's open ground floor: parking in the shade behind two columns (cut at the module's edges)."""
        self.fill(0, MODULE_PX, 3, STOREY_PX, _DARK)
        self.fill(0, MODULE_PX, 27, STOREY_PX, (88, 88, 86))  # the parking floor
        self.fill(0, 3, 3, STOREY_PX, self.wall)
        self.fill(MODULE_PX - 3, MODULE_PX, 3, STOREY_PX, self.wall)
        self.fill(0, MODULE_PX, 0, 3, np.asarray(accent, dtype=np.float32) * 0.3 + self.wall * 0.7)
        return self

    def shop_front(self, sign: Colour) -> _Module:
        """A shop's ground floor: a sign band over full-height glass and a door."""
        self.fill(0, MODULE_PX, 2, 9, sign)
        self.fill(0, MODULE_PX, 9, 10, (40, 40, 44))
        self.glass(3, MODULE_PX - 3, 10, 31, tint=-0.1)
        self.fill(38, 50, 12, 31, (36, 40, 46))  # the door
        self.fill(43, 44, 12, 31, (150, 150, 150))
        return self

    def lobby(self, frame: Colour) -> _Module:
        """An office lobby: tall glass in a dark frame."""
        self.glass(2, MODULE_PX - 2, 4, 31, tint=-0.15)
        for x in (2, MODULE_PX // 2, MODULE_PX - 3):
            self.fill(x, x + 1, 4, 31, np.asarray(frame, dtype=np.float32) * 0.5)
        self.fill(0, MODULE_PX, 2, 4, (54, 56, 60))
        return self

    def corrugated(self) -> _Module:
        """Profiled metal sheets: ribs every 4 texels, lit on one side."""
        shade = np.array([1.08, 1.0, 0.9, 0.96], dtype=np.float32)
        self.rgb *= np.tile(shade, MODULE_PX // 4)[None, :, None]
        return self

    def shutter(self, frame: Colour) -> _Module:
        """A roller shutter door across half the module."""
        self.fill(14, 50, 6, STOREY_PX, (150, 152, 150))
        self.rgb[6:STOREY_PX:2, 14:50] *= 0.86
        self.fill(13, 14, 5, STOREY_PX, frame)
        self.fill(50, 51, 5, STOREY_PX, frame)
        self.fill(13, 51, 5, 6, frame)
        return self

    def slab(self) -> _Module:
        """The floor slab under the storey: a shadow line on the bottom texel row."""
        self.rgb[-1:] *= 0.8
        return self

