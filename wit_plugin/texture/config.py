"""The texture step's settings, its report and the names it writes (``texture_model``)."""
from __future__ import annotations

from dataclasses import dataclass, field

from ..infra import step_layers

FORMATS = {"JPEG": "jpg", "PNG": "png"}


TEXCOORDS_FILE = step_layers.TEXCOORD_FILE


TEXTURED_TIN_SURFACES = ("terrain", "road")


ROOF_TARGET, WALL_TARGET, TIN_TARGET, ROAD_TARGET = step_layers.TEX_TARGETS


FACADES_NONE, FACADES_GENERATED, FACADE_CHOICES = (step_layers.FACADES_NONE, step_layers.FACADES_GENERATED,
                                                   step_layers.FACADE_CHOICES)  # TextureConfig.facades

BEYOND_ORTHO = "outside_ortho"  # TextureReport.untextured key: surfaces beyond the ortho's coverage


@dataclass(frozen=True)
class TextureConfig:
    """Texture resolution, image format and atlas layout."""

    scale: float = 1.0
    """S, 0 < S ≤ 1: texture resolution relative to the ortho's."""
    image_format: str = "JPEG"
    """Either "JPEG" or "PNG"."""
    jpeg_quality: int = 90
    atlas_size: int = 2048
    """Maximum side of any image, a power of two."""
    gutter: int = 4
    """Texels of padding around each roof island (and of context around ground squares)."""
    write_mipmaps: bool = False
    """Write each image's mip chain to 1 × 1 as files (otherwise it is derivable by the viewer)."""
    facades: str = step_layers.DEFAULT_FACADES
    """Walls: "generated" (storey modules drawn from each building's use and storeys, ``texture.facade``) or
    "none" (left untextured)."""


@dataclass
class TextureReport:
    """What ``texture_model`` wrote."""

    output_dir: str
    texcoords: str
    """Path of ``texcoords.gpkg``."""
    images: list[str] = field(default_factory=list)
    """Images (level 0), relative to ``output_dir``."""
    surfaces: dict[str, int] = field(default_factory=lambda: {ROOF_TARGET: 0, WALL_TARGET: 0, TIN_TARGET: 0,
                                                              ROAD_TARGET: 0})
    """Textured rings per TEX_TARGET."""
    untextured: dict[str, int] = field(default_factory=dict)
    """Surfaces left untextured: LoD1 'ground' faces (never seen), 'wall' faces without generated facades, TIN
    'footprint' triangles, surfaces beyond the ortho's coverage."""
    facades: dict[str, int] = field(default_factory=dict)
    """Buildings with a generated facade, by style (``texture.facade.uses``)."""
    facade_images: int = 0
    atlases: int = 0
    ground_images: int = 0
    mip_files: int = 0
    downscaled: int = 0
    """Images or islands shrunk below S to fit ``atlas_size``."""
    texel_size: float = 0.0
    """Nominal ground size of a texel (CRS units, m) = ortho pixel size / S."""
    texels_per_m2: float = 0.0
    bytes_written: int = 0
