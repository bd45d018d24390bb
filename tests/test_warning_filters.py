"""Every warnings filter of pyproject.toml matches the warning it is there for."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def test_the_mock_name_filter_matches_rdflibs_warning() -> None:
    filters = tomllib.loads(PYPROJECT.read_text())["tool"]["pytest"]["ini_options"]["filterwarnings"]
    mock = [f for f in filters if "_mock_name" in f]
    assert len(mock) == 1
    _action, pattern, category = mock[0].split(":")
    probe = ("import warnings\nwith warnings.catch_warnings(record=True) as seen:\n"
             "    warnings.simplefilter('always')\n    from rdflib import XSD\n"
             "    getattr(XSD, '_mock_name', None)\n"
             "print('\\n'.join(f'{w.category.__name__}|{w.message}' for w in seen))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout
    messages = [m.split("|", 1)[1] for m in out.splitlines() if m.startswith(category + "|")]
    assert messages and all(re.match(pattern, m) for m in messages)
