"""``kbplanner run`` (cli/run.py): a run that does not install every element ends with a ``Negative result``
naming, per scenario, each element not installed with its reason (issue 10: negative results exit 1 with
reasons on the console, not only in metrics.json and the report)."""

from __future__ import annotations

import json
from pathlib import Path

from kbplanner.cli.run import negative_result
from kbplanner.pipeline import PipelineResult, ScenarioSummary


def _scenario(name: str, *, conforms: bool = True, installed: int = 7) -> ScenarioSummary:
    return ScenarioSummary(name, conforms, 0 if conforms else 3, ["husky-ur16e"], 16, 7, (800, 720),
                           installed=installed, elements=7, simulated=conforms)


def test_each_element_not_installed_is_named_with_its_reason(tmp_path: Path) -> None:
    sim = tmp_path / "scenarios" / "storage-inside" / "simulation"
    sim.mkdir(parents=True)
    reason = "step 20 (install frame): installed pose out of reach from 0 free base pose(s) tried"
    per_element = [{"label": f"F00{n}", "global_id": f"g{n}", "outcome": "installed", "reason": None}
                   for n in range(1, 7)]
    per_element.append({"label": "F007", "global_id": "g7", "outcome": "failed", "reason": reason})
    (sim / "metrics.json").write_text(json.dumps({"per_element": per_element}), encoding="utf-8")
    result = PipelineResult(tmp_path, "p", 2, 14, scenarios=[
        _scenario("storage-inside", installed=6), _scenario("storage-outside"),
        _scenario("storage-elsewhere", conforms=False)])
    assert not result.ok
    text = negative_result(result)
    assert text.startswith("Negative result: ")
    assert "storage-inside: 1 of 7 element(s) not installed" in text
    assert f"F007: failed: {reason}" in text
    assert "storage-outside" not in text  # it installed everything
    assert "storage-elsewhere: the model does not conform (3 violation(s)" in text
