"""The numeric rule for ``robots.toml``: TOML's ``nan``/``inf`` and out-of-range sizes are refused."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from kbplanner.core.errors import InputFileError
from kbplanner.robot.robot_table import load_robot_specs, robots_toml


def _edited(tmp_path: Path, key: str, value: str) -> Path:
    text = robots_toml().read_text(encoding="utf-8")
    new, n = re.subn(rf"(?m)^{key}\s*=\s*[^\n#]+", f"{key} = {value}", text, count=1)
    assert n == 1, f"{key} not in the shipped robots.toml"
    out = tmp_path / "robots.toml"
    out.write_text(new, encoding="utf-8")
    return out


def test_the_shipped_table_passes() -> None:
    assert load_robot_specs()


@pytest.mark.parametrize(("key", "value", "words"), [
    ("max_speed_mps", "nan", "not a finite number"),
    ("max_speed_mps", "inf", "not a finite number"),
    ("max_speed_mps", "-1.0", "out of range"),
    ("mass_kg", "0.0", "out of range"),
    ("length_m", "-0.5", "out of range"),
])
def test_a_bad_number_names_the_file_key_and_value(tmp_path: Path, key: str, value: str, words: str) -> None:
    path = _edited(tmp_path, key, value)
    before = path.read_bytes()
    with pytest.raises(InputFileError) as exc:
        load_robot_specs(path)
    msg = str(exc.value)
    assert words in msg and key in msg and str(path) in msg
    assert path.read_bytes() == before


def test_nan_inside_an_arm_list_is_refused(tmp_path: Path) -> None:
    text = robots_toml().read_text(encoding="utf-8")
    new, n = re.subn(r"(?m)^(masses_kg\s*=\s*\[)\s*[-0-9.e]+", r"\1 nan", text, count=1)
    assert n == 1
    path = tmp_path / "robots.toml"
    path.write_text(new, encoding="utf-8")
    with pytest.raises(InputFileError, match=r"masses_kg\[0\] = nan is not a finite number"):
        load_robot_specs(path)
