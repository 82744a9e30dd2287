"""The runs of a study on Dask: an embedded ``LocalCluster`` by default, or a scheduler started elsewhere.

Each run is one Dask task, :func:`.execute.run_one`, which starts ``bimbot run`` as a process of its own
(its own bus, its own run folder). The embedded cluster keeps its workers as threads of this process
(``processes=False``): a task only waits for its ``bimbot run``, so nothing is gained by a worker process
per slot, and nothing listens beyond loopback. With ``scheduler`` (``tcp://HOST:8786``) the runs go to
that cluster's workers, which need this bimbot installed and the build and study folder at the same paths.

A task that fails in Dask itself (its worker died, the function raised) is still a row: ``failed``, with
Dask's reason. Rows come back in grid order, whatever order the runs finished in.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from bimbot.shared.errors import UserError

from .execute import RunJob, run_one
from .rows import failed_row

_log = logging.getLogger(__name__)

SCHEDULER_TIMEOUT_S = 30.0  # wall seconds to reach a --scheduler
# wall seconds the runs wait for their warm fork server to load (seconds; a first start after setup
# compiles the kernels: then the first runs load their own)
WARM_SERVER_WAIT_S = 60.0

Progress = Callable[[dict[str, Any]], None]  # called with each row as its run ends


@contextmanager
def dask_client(scheduler: str | None, workers: int) -> Iterator[Any]:
    """A ``distributed.Client`` on ``scheduler``, or on an embedded ``LocalCluster`` of ``workers`` slots
    (no dashboard), closed on leaving."""
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=f"{SCHEDULER_TIMEOUT_S:g}s")
        except (OSError, TimeoutError, ValueError) as error:
            raise UserError(f"--scheduler {scheduler}: no Dask scheduler answers there ({error})") from None
        with client:
            yield client
        return
    from bimbot.warm_fork_server import for_the_runs_of_this_process

    # the runs start on this machine: their services fork from one warm server, not one server a run
    with (
        for_the_runs_of_this_process(wait_s=WARM_SERVER_WAIT_S),
        LocalCluster(
            n_workers=1,
            threads_per_worker=workers,
            processes=False,
            dashboard_address="127.0.0.1:0",  # its HTTP endpoint on a free loopback port, not 8787
            worker_dashboard_address="127.0.0.1:0",  # the worker's too (else on every interface)
            scheduler_kwargs={"dashboard": False},
            silence_logs=logging.WARNING,
        ) as cluster,
        Client(cluster) as client,
    ):
        yield client


def run_on_dask(
    jobs: Sequence[RunJob],
    scheduler: str | None = None,
    workers: int = 1,
    progress: Progress | None = None,
) -> list[dict[str, Any]]:
    """Every job's row (in the order of ``jobs``), the runs done by Dask workers."""
    from distributed import as_completed

    rows: list[dict[str, Any] | None] = [None] * len(jobs)
    with dask_client(scheduler, workers) as client:
        futures = [
            client.submit(run_one, job, key=f"bimbot-study-{job.run.name}-{index}", pure=False, retries=0)
            for index, job in enumerate(jobs)
        ]
        index_of = {future.key: index for index, future in enumerate(futures)}
        for future in as_completed(futures):
            index = index_of[future.key]
            row = rows[index] = _row_of(future, jobs[index])
            if progress is not None:
                progress(row)
    return [row for row in rows if row is not None]


def _row_of(future: Any, job: RunJob) -> dict[str, Any]:
    """The task's row, or a ``failed`` row with Dask's reason when the task itself failed."""
    if future.status == "finished":
        return dict(future.result())
    error = future.exception()
    reason = f"the Dask task failed: {type(error).__name__}: {error}"
    _log.warning("%s: %s", job.run.name, reason)
    return failed_row(job.run, reason, None, 0.0, str(job.run_dir.relative_to(job.study_dir)))
