"""Scenario sweeps (analysis, after B5), step 5: the Pareto front and the sweep's output files.

``pareto_front`` gives the complete variants not dominated in (time below the safety threshold,
total duration), both minimised; ``write_sweep`` writes ``sweep.csv``, ``sweep.json``, ``pareto.csv``
and ``pareto.png`` (a scatter with the front drawn and labelled).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from kbplanner.core.outputs import atomic_write_bytes, atomic_write_text, write_json
from kbplanner.scale.sweep_axes import SweepError
from kbplanner.scale.sweep_simulate import COLUMNS, VariantResult

SAFETY_KEYS = {"threshold": "below_threshold_s", "iso": "below_separation_s"}


@dataclass
class SweepResult:
    """All rows (in variant order), the Pareto front and where the outputs went."""

    rows: list[VariantResult]
    front: list[VariantResult]
    safety: str
    out_dir: Path | None = None

    def table(self, rows: Sequence[VariantResult] | None = None, fmt: str = "table") -> str:
        """The rows (default: all) as an aligned text table or CSV."""
        from kbplanner.core.tables import render

        data = [[getattr(r, c) for c in COLUMNS] for r in (self.rows if rows is None else rows)]
        return render(COLUMNS, data, fmt)


def pareto_front(rows: Sequence[VariantResult], safety: str = "threshold") -> list[VariantResult]:
    """Complete variants not dominated in (time below the safety threshold, total duration), both minimised.

    ``safety`` is ``threshold`` (time below the proximity threshold) or ``iso`` (below the ISO/TS 15066
    protective separation distance). Variants that did not install every element are not candidates.
    Sorted by total duration, then variant id.
    """
    key = SAFETY_KEYS.get(safety)
    if key is None:
        raise SweepError(f"unknown safety objective {safety!r}", element=safety, fix="use threshold or iso")

    def point(r: VariantResult) -> tuple[float, float]:
        return float(getattr(r, key) or 0.0), float(r.total_min or 0.0)

    cands = [r for r in rows if r.complete]
    front = []
    for r in cands:
        a = point(r)
        dominated = any(b[0] <= a[0] and b[1] <= a[1] and b != a for b in map(point, cands))
        if not dominated:
            front.append(r)
    return sorted(front, key=lambda r: (point(r)[1], point(r)[0], r.variant))


def _csv(rows: Sequence[VariantResult]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for r in rows:
        w.writerow(["" if getattr(r, c) is None else getattr(r, c) for c in COLUMNS])
    return buf.getvalue()


def pareto_png(rows: Sequence[VariantResult], front: Sequence[VariantResult], safety: str) -> bytes:
    """A scatter of the complete variants, total duration over time below the threshold, front highlighted."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    key = SAFETY_KEYS[safety]
    label = ("time below the proximity threshold (s)" if safety == "threshold"
             else "time below the ISO/TS 15066 protective separation distance (s)")
    ok = [r for r in rows if r.complete]
    fig, ax = plt.subplots(figsize=(7, 5), dpi=100)
    ax.scatter([float(getattr(r, key) or 0.0) for r in ok], [float(r.total_min or 0.0) for r in ok],
               c="#9aa5b1", label="variants")
    fx = [float(getattr(r, key) or 0.0) for r in front]
    fy = [float(r.total_min or 0.0) for r in front]
    ax.plot(fx, fy, "-o", c="#d1495b", label="Pareto front")
    for r in front:
        ax.annotate(r.variant, (getattr(r, key), r.total_min), fontsize=7, xytext=(4, 4),
                    textcoords="offset points")
    ax.set_xlabel(label)
    ax.set_ylabel("total duration (min)")
    ax.set_title("Storage locations and start times: safety vs duration")
    ax.legend()
    ax.grid(alpha=0.3)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def write_sweep(result: SweepResult, out_dir: Path) -> None:
    """``sweep.csv``, ``sweep.json``, ``pareto.csv`` and ``pareto.png`` into ``out_dir``."""
    atomic_write_text(out_dir / "sweep.csv", _csv(result.rows))
    write_json(out_dir / "sweep.json", {"safety_objective": SAFETY_KEYS[result.safety],
                                        "rows": [asdict(r) for r in result.rows],
                                        "pareto": [r.variant for r in result.front]})
    atomic_write_text(out_dir / "pareto.csv", _csv(result.front))
    atomic_write_bytes(out_dir / "pareto.png", pareto_png(result.rows, result.front, result.safety))
