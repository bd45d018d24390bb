"""Scenario sweeps on a Dask cluster (a LocalCluster on 127.0.0.1): the same table as a serial sweep."""

from __future__ import annotations

from pathlib import Path

import pytest

from kbplanner.sweep import SweepSpec, parse_vary, run_sweep
from sim_project_factory import make_sim_project

distributed = pytest.importorskip("dask.distributed", reason="pip install 'kbplanner[cluster]'")


def test_a_sweep_on_a_local_dask_cluster_gives_the_serial_table(tmp_path: Path) -> None:
    project = tmp_path / "p"
    make_sim_project(project, high_panel=False)
    spec = SweepSpec(project, scenario="stored", max_elements=1, axes=parse_vary(["storage=2.5,-4.5"]))
    serial = run_sweep(spec, out_dir=tmp_path / "serial", workers=1)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        address = cluster.scheduler_address.removeprefix("tcp://")
        seen: list[str] = []
        on_dask = run_sweep(spec, out_dir=tmp_path / "dask", cluster=f"dask://{address}",
                            progress=lambda _d, _t, v: seen.append(v))
    assert seen == [r.variant for r in serial.rows]
    assert on_dask.rows == serial.rows and serial.rows[0].installed == 1
    for name in ("sweep.csv", "sweep.json", "pareto.csv"):
        assert (tmp_path / "serial" / name).read_bytes() == (tmp_path / "dask" / name).read_bytes()
