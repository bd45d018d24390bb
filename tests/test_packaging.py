"""The installed package, not only the checkout, finds its ontology, shapes, queries and robot files.

A wheel is built from the checkout (offline: no build isolation) and imported from a directory outside
the repository, so only what the wheel ships is visible.
"""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHECK = r"""
import sys, kbplanner
from pathlib import Path
from rdflib import Graph
from rdflib.plugins.sparql import prepareQuery
from kbplanner.core import resources
from kbplanner.core import named_queries
assert str(Path(kbplanner.__file__).resolve()).startswith(sys.argv[1]), kbplanner.__file__
ttl = resources.ontology_files() + resources.shape_files()
for p in ttl:
    Graph().parse(p, format="turtle")
queries = named_queries.catalogue()
for q in queries.values():
    prepareQuery(q.text)
sim = resources.data_dir("sim")
print(len(ttl), len(queries), sum(1 for _ in sim.rglob("*") if _.is_file()))
"""


def test_a_built_wheel_ships_every_turtle_shape_query_and_sim_file(tmp_path: Path) -> None:
    wheel_dir = tmp_path / "wheel"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(wheel_dir), str(REPO)],
        check=True, capture_output=True, text=True,
    )
    wheel = next(wheel_dir.glob("kbplanner-*.whl"))
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as zf:
        zf.extractall(site)
        names = zf.namelist()
    assert "kbplanner/py.typed" in names
    assert any(n.startswith("kbplanner/_data/ontology/") and n.endswith(".ttl") for n in names)
    assert any(n.startswith("kbplanner/queries/") and n.endswith(".rq") for n in names)
    for viewer in ("three-bundle.min.js.gz", "LICENSE-three.txt", "playback.js"):  # the report's 4D playback
        assert f"kbplanner/analysis/viewer/{viewer}" in names
    out = subprocess.run(
        [sys.executable, "-c", CHECK, str(site.resolve())],
        cwd=tmp_path, env={"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin"},
        capture_output=True, text=True,
    )
    assert out.returncode == 0, out.stderr
    n_ttl, n_queries, n_sim = (int(x) for x in out.stdout.split())
    repo_ttl = len(list((REPO / "ontology").rglob("*.ttl"))) + len(list((REPO / "shapes").rglob("*.ttl")))
    assert n_ttl == repo_ttl
    assert n_queries == len(list((REPO / "src" / "kbplanner" / "queries").glob("*.rq")))
    assert n_sim == sum(1 for p in (REPO / "sim").rglob("*") if p.is_file() and "__pycache__" not in p.parts)
