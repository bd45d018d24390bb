"""Scenario sweeps (analysis, after B5), step 4: where the variants run (serial, processes, Dask, Ray).

``execute`` runs the variant tasks serially in this process, in local processes
(``ProcessPoolExecutor`` with the ``spawn`` context), or on a Dask (``dask://HOST:PORT``) or Ray
(``ray://HOST:PORT``) cluster, and gives the results in task order whatever finished first. A
missing extra or an unreachable cluster is a ``SweepError`` naming the address and the fix.
"""

from __future__ import annotations

import logging
import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

from kbplanner.scale.sweep_axes import SweepError
from kbplanner.scale.sweep_simulate import VariantResult, VariantTask, run_variant

log = logging.getLogger(__name__)

CONNECT_TIMEOUT_S = 30  # Dask: seconds to reach the scheduler (Ray Client waits about as long)
RAY_CONNECT_ATTEMPTS = 4  # Ray Client sessions that failed to start (see _ray_connect)

Progress = Callable[[int, int, str], None]  # (done, total, variant id)


def _missing_extra(module: str, extra: str) -> SweepError:
    return SweepError(f"{module} is not installed; a cluster address needs it", element=module,
                      fix=f"pip install 'kbplanner[{extra}]' (or run with --workers N on this machine)")


def _unreachable(address: str, what: str, err: Exception) -> SweepError:
    return SweepError(f"cannot reach the cluster at {address} ({type(err).__name__}: {err})", element=address,
                      fix=f"start {what} there, or run with --workers N on this machine")


def _ray_connect(ray: Any, address: str) -> Any:
    """A Ray Client connection of its own to ``address`` (``allow_multiple``: not the process's global
    one, so a later sweep to another address never reuses this cluster); the caller disconnects it
    (leaving its ``with`` block alone does not disconnect such a connection).

    The Ray Client server sometimes accepts a connection and then fails to start the session's server
    process (``ConnectionAbortedError`` "Initialization failure from server": a fork race in Ray's
    client proxy, ray-project/ray issue 63202, within a second); that is tried again, up to
    ``RAY_CONNECT_ATTEMPTS`` times. No answer at all (``ConnectionError`` after about 30 s) is final.
    """
    what = "the Ray Client server of a Ray head (ray start --head --ray-client-server-port PORT)"
    for attempt in range(1, RAY_CONNECT_ATTEMPTS + 1):
        try:
            return ray.init(address=address, logging_level=logging.WARNING, allow_multiple=True)
        except ConnectionAbortedError as err:
            if attempt == RAY_CONNECT_ATTEMPTS:
                raise _unreachable(address, what, err) from None
            log.warning("Ray Client at %s: session start failed (attempt %d of %d), trying again",
                        address, attempt, RAY_CONNECT_ATTEMPTS)
        except ConnectionError as err:
            raise _unreachable(address, what, err) from None
    raise AssertionError("unreachable")  # pragma: no cover


def execute(tasks: Sequence[VariantTask], *, workers: int = 1, cluster: str | None = None,
            progress: Progress | None = None) -> list[VariantResult]:
    """Run the tasks serially, in ``workers`` local processes or on a cluster; results in task order."""
    say = progress or (lambda _d, _t, _v: None)
    total = len(tasks)
    results: dict[str, VariantResult] = {}
    if cluster:
        return _execute_cluster(tasks, cluster, say)
    if workers < 1:
        raise SweepError(f"--workers {workers} is not positive", element="--workers",
                         fix="use --workers 1 or more")
    if workers == 1 or total <= 1:
        for n, t in enumerate(tasks, start=1):
            results[t.variant.id] = run_variant(t)
            say(n, total, t.variant.id)
    else:
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=min(workers, total), mp_context=ctx) as pool:
            futures = {pool.submit(run_variant, t): t.variant.id for t in tasks}
            for n, fut in enumerate(as_completed(futures), start=1):
                results[futures[fut]] = fut.result()
                say(n, total, futures[fut])
    return [results[t.variant.id] for t in tasks]


def _execute_cluster(tasks: Sequence[VariantTask], address: str, say: Progress) -> list[VariantResult]:
    scheme, sep, rest = address.partition("://")
    if not sep or not rest or scheme not in ("dask", "ray"):
        raise SweepError(f"cluster address {address!r} is not dask://HOST:PORT or ray://HOST:PORT",
                         element=address, fix="write --cluster dask://127.0.0.1:8786 or --cluster ray://HOST:10001")
    total = len(tasks)
    results: dict[str, VariantResult] = {}
    if scheme == "dask":
        try:
            from dask.distributed import Client
            from dask.distributed import as_completed as dask_completed
        except ImportError:
            raise _missing_extra("dask.distributed", "cluster") from None
        try:
            client = Client(f"tcp://{rest}", timeout=CONNECT_TIMEOUT_S)
        except OSError as err:  # dask's connection time-out is an OSError too
            raise _unreachable(address, "a Dask scheduler (dask scheduler --port PORT)", err) from None
        with client:
            futures = client.map(run_variant, list(tasks), pure=False)
            ids = {f.key: t.variant.id for f, t in zip(futures, tasks, strict=True)}
            for n, fut in enumerate(dask_completed(futures), start=1):
                results[ids[fut.key]] = fut.result()
                say(n, total, ids[fut.key])
        return [results[t.variant.id] for t in tasks]
    try:
        import ray  # type: ignore[import-not-found,unused-ignore]
    except ImportError:
        raise _missing_extra("ray", "ray") from None
    context = _ray_connect(ray, address)
    try:
        with context:
            remote = ray.remote(run_variant)
            refs = {remote.remote(t): t.variant.id for t in tasks}
            pending = list(refs)
            n = 0
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    n += 1
                    results[refs[ref]] = ray.get(ref)
                    say(n, total, refs[ref])
    finally:
        context.disconnect()
    return [results[t.variant.id] for t in tasks]
