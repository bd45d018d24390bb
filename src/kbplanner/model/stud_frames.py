"""Stud-frame panel geometry (model data, before A1): the pieces, stud count, volume, mass and centre
of mass of a prefabricated timber stud-frame panel.

Used wherever the project writes frame panels into an IFC model: the building generator
(:mod:`kbplanner.scale.building_geometry`) and the case study's tool that adds the 11 frames to the
Duplex (``data/case_study/tools/build_frames.py``). One function, so both kinds of model have the
same panels.

A panel of length ``L`` and height ``H`` (metres) in its own frame (x along the panel, symmetric
about x = 0; z up from the underside of the bottom plate; y across, the panel centred on y = 0):
a bottom and a top plate over the whole length, ``STUD_WIDTH`` thick; studs between the plates, one
at each end and the rest evenly spaced at most ``MAX_STUD_SPACING`` centre to centre; one row of
noggings at mid-height between neighbouring studs. Every piece is a rectangle in x-z extruded
``STUD_DEPTH`` across the panel (38 x 89 mm SPF lumber by default).

Example:
    >>> f = stud_frame(0.7)
    >>> f.studs, round(f.stud_spacing, 3), round(f.mass_kg(), 2)
    (3, 0.331, 13.63)
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

from kbplanner.core.errors import KbplannerError

PANEL_HEIGHT = 2.4  # m, underside of the bottom plate to the top of the top plate
STUD_WIDTH = 0.038  # m, along the panel (the 38 mm face)
STUD_DEPTH = 0.089  # m, across the panel (89 mm: a 92 mm stud partition)
MAX_STUD_SPACING = 0.600  # m, centre to centre
DENSITY = 450.0  # kg/m3, spruce-pine-fir (SPF) lumber, dry
MATERIAL = "Wood - SPF"


@dataclass(frozen=True)
class Piece:
    """One rectangular timber piece in panel coordinates (x along the panel, z up), metres."""

    kind: str  # bottom plate | top plate | stud | nogging
    x_min: float
    x_max: float
    z_min: float
    z_max: float
    depth: float = STUD_DEPTH  # across the panel (y from -depth/2 to depth/2)

    @property
    def volume(self) -> float:
        return (self.x_max - self.x_min) * self.depth * (self.z_max - self.z_min)


@dataclass(frozen=True)
class StudFrame:
    """A panel's pieces and what follows from them (unrounded; callers round what they write)."""

    length: float
    height: float
    pieces: tuple[Piece, ...]
    studs: int
    stud_spacing: float  # centre to centre
    volume_m3: float
    centre_of_mass_local: tuple[float, float, float]  # panel frame, uniform density

    def mass_kg(self, density: float = DENSITY) -> float:
        """Mass at ``density`` kg/m3."""
        return self.volume_m3 * density


def panel_pieces(length: float, height: float = PANEL_HEIGHT, *, stud_width: float = STUD_WIDTH,
                 stud_depth: float = STUD_DEPTH, max_spacing: float = MAX_STUD_SPACING) -> list[Piece]:
    """Plates, studs and noggings of a panel ``length`` x ``height`` (see the module docstring).

    Raises:
        KbplannerError: a panel too short for two studs or too low for two plates.
    """
    if length <= 2 * stud_width or height <= 2 * stud_width:
        raise KbplannerError(f"a stud-frame panel {length:.4f} x {height:.4f} m is too small for studs "
                             f"{stud_width} m wide", element="stud frame panel",
                             fix=f"make panels longer and higher than {2 * stud_width} m")
    half = length / 2.0
    gaps = max(1, math.ceil((length - stud_width) / max_spacing - 1e-9))
    spacing = (length - stud_width) / gaps
    centres = [-half + stud_width / 2.0 + i * spacing for i in range(gaps + 1)]
    z0, z1 = stud_width, height - stud_width  # studs stand between the plates
    pieces = [Piece("bottom plate", -half, half, 0.0, stud_width, stud_depth),
              Piece("top plate", -half, half, z1, height, stud_depth)]
    pieces += [Piece("stud", c - stud_width / 2, c + stud_width / 2, z0, z1, stud_depth) for c in centres]
    zm, h = height / 2.0, stud_width / 2
    pieces += [Piece("nogging", a + h, b - h, zm - h, zm + h, stud_depth)
               for a, b in itertools.pairwise(centres)]
    return pieces


def stud_frame(length: float, height: float = PANEL_HEIGHT, *, stud_width: float = STUD_WIDTH,
               stud_depth: float = STUD_DEPTH, max_spacing: float = MAX_STUD_SPACING) -> StudFrame:
    """The panel ``length`` x ``height`` with its stud count, spacing, volume and centre of mass."""
    pieces = panel_pieces(length, height, stud_width=stud_width, stud_depth=stud_depth,
                          max_spacing=max_spacing)
    vol = sum(p.volume for p in pieces)
    com_x = sum(p.volume * (p.x_min + p.x_max) / 2 for p in pieces) / vol
    com_z = sum(p.volume * (p.z_min + p.z_max) / 2 for p in pieces) / vol
    studs = sum(1 for p in pieces if p.kind == "stud")
    return StudFrame(length=length, height=height, pieces=tuple(pieces), studs=studs,
                     stud_spacing=(length - stud_width) / (studs - 1), volume_m3=vol,
                     centre_of_mass_local=(com_x, 0.0, com_z))
