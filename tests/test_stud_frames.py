"""Stud-frame panel geometry (kbplanner.model.stud_frames), shared by the building generator and the case
study's build_frames.py."""

from __future__ import annotations

import itertools

import pytest

from kbplanner.core.errors import KbplannerError
from kbplanner.model.stud_frames import (
    DENSITY,
    MAX_STUD_SPACING,
    PANEL_HEIGHT,
    STUD_DEPTH,
    STUD_WIDTH,
    stud_frame,
)


@pytest.mark.parametrize("length", [0.3, 0.6, 0.638, 0.639, 0.75, 1.2, 2.9])
def test_a_panel_has_studs_at_both_ends_at_most_600_mm_apart_between_two_plates(length: float) -> None:
    f = stud_frame(length)
    studs = sorted((p for p in f.pieces if p.kind == "stud"), key=lambda p: p.x_min)
    assert len(studs) == f.studs >= 2
    assert studs[0].x_min == pytest.approx(-length / 2) and studs[-1].x_max == pytest.approx(length / 2)
    centres = [(p.x_min + p.x_max) / 2 for p in studs]
    gaps = [b - a for a, b in itertools.pairwise(centres)]
    assert max(gaps) <= MAX_STUD_SPACING + 1e-9 and gaps == pytest.approx([f.stud_spacing] * len(gaps))
    if f.studs > 2:  # one stud fewer would exceed the spacing: as few studs as the rule allows
        assert (length - STUD_WIDTH) / (f.studs - 2) > MAX_STUD_SPACING
    plates = [p for p in f.pieces if "plate" in p.kind]
    assert [v for p in plates for v in (p.z_min, p.z_max)] == pytest.approx(
        [0.0, STUD_WIDTH, PANEL_HEIGHT - STUD_WIDTH, PANEL_HEIGHT])
    assert all(p.x_max - p.x_min == pytest.approx(length) for p in plates)
    assert all(p.z_min == pytest.approx(STUD_WIDTH) and p.z_max == pytest.approx(PANEL_HEIGHT - STUD_WIDTH)
               for p in studs)
    noggings = [p for p in f.pieces if p.kind == "nogging"]
    assert len(noggings) == f.studs - 1
    assert all(abs((p.z_min + p.z_max) / 2 - PANEL_HEIGHT / 2) < 1e-9 for p in noggings)


def test_volume_mass_and_centre_of_mass_follow_from_the_pieces() -> None:
    f = stud_frame(0.7)
    # plates 2 x 0.7, studs 3 x 2.324, noggings 2 x (0.331 - 0.038), all 38 x 89 mm
    expected = (2 * 0.7 * 0.038 + 3 * 0.038 * 2.324 + 2 * (0.331 - 0.038) * 0.038) * STUD_DEPTH
    assert f.volume_m3 == pytest.approx(expected, rel=1e-3)
    assert f.mass_kg() == pytest.approx(f.volume_m3 * DENSITY)
    x, y, z = f.centre_of_mass_local
    assert x == pytest.approx(0.0, abs=1e-12) and y == 0.0 and z == pytest.approx(PANEL_HEIGHT / 2)


def test_height_and_section_are_parameters() -> None:
    f = stud_frame(1.0, 3.0, stud_width=0.045, stud_depth=0.14, max_spacing=0.4)
    assert f.studs == 4 and max(p.z_max for p in f.pieces) == 3.0
    assert all(p.depth == 0.14 for p in f.pieces)


def test_a_panel_too_small_for_two_studs_is_a_clear_error() -> None:
    with pytest.raises(KbplannerError, match="too small"):
        stud_frame(0.05)
