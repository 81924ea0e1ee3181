"""The sweep's driver: the plan's runs as Dask tasks, results recorded as they arrive.

By default the runs go to a LocalCluster started here: one worker process per core, one thread each,
every socket bound to 127.0.0.1 (the scheduler, the workers, their nannies, and the scheduler's HTTP
server, which serves the dashboard only when bokeh is installed and only on loopback). ``scheduler=``
names an existing cluster instead (``tcp://host:8786``: dask-scheduler/dask-worker, dask-jobqueue,
dask-kubernetes); its workers must run the same mission (checked) and need no shared filesystem.

What makes a sweep robust is decided here and in store.py:

* resumable: runs whose rows are in the sweep directory are not submitted again;
* a worker lost mid-run: Dask runs the task again on another worker (its nanny restarts a local one);
  a run that kills ``allowed-failures`` (3) workers in a row is left unfinished, named, and runs again
  on the next resume; a run is recorded once, whatever Dask ran (store.SweepStore.record);
* deterministic: each run is ``run_scenario`` with its own seed, as ``mission run`` runs it;
* Ctrl-C (or SIGTERM): the runs in flight are cancelled, and the table and the summary are written from
  everything that finished before the cluster is shut down.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mission.core.errors import MissionError
from mission.sweep.plan import RunSpec, SweepPlan
from mission.sweep.store import SweepStore
from mission.sweep.task import RunResult, run_one, worker_identity

LOOPBACK = "127.0.0.1"
ALLOWED_FAILURES = 3  # workers a run may kill before it is left unfinished (Dask's default, made explicit)
TABLE_EVERY_S = 10.0  # results.parquet is rewritten at most this often while runs arrive (and at the end)
WORKER_WAIT_S = 60.0  # an existing scheduler must have a worker within this long
#: Dask settings of the local cluster, each measured on a 3 s simulated run (CPU seconds per run):
#: * the workers' statistical profiler samples every 10 ms for the dashboard's profile page: ~12 % more CPU;
#: * Dask spawns workers with MALLOC_TRIM_THRESHOLD_=65536, which fixes glibc's mmap threshold, so every
#:   camera image (~0.9 MB) is mapped and unmapped anew: ~0.7 s more system time per run (+25 %). Unset,
#:   a run costs on a worker what it costs alone. (An existing cluster keeps its own config: docs/tutorials/sweep.md.)
WORKER_SETTINGS = {
    "distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
    "distributed.worker.profile.enabled": False,
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
}


@dataclass
class SweepOutcome:
    """What one `mission sweep` did."""

    out: Path
    planned: int  # runs in the plan
    skipped: int  # already finished in the sweep directory (resumed)
    recorded: int = 0  # finished by this invocation
    unfinished: list[str] = field(default_factory=list)  # run ids neither finished before nor now
    duplicates: int = 0  # results dropped because the run was recorded already
    errors: list[str] = field(default_factory=list)  # runs whose task could not run (named, unfinished)
    interrupted: bool = False
    cut_short: bool = False  # budget_s reached
    wall_s: float = 0.0
    workers: int = 0
    scheduler: str = ""
    rows: list[dict[str, Any]] = field(default_factory=list)  # every row of the sweep directory


@contextlib.contextmanager
def connect(scheduler: str | None = None, workers: int | None = None, dashboard: int | None = None) -> Iterator[Any]:
    """A Dask client: on `scheduler` when given, else on a LocalCluster on 127.0.0.1 with `workers`
    processes (default: one per core). `dashboard`: the scheduler's HTTP port on loopback (0: any free)."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="15s")
        except (OSError, TimeoutError) as err:
            raise MissionError(
                f"--scheduler {scheduler}: cannot connect ({err}); expected the address of a "
                "running dask scheduler, e.g. tcp://host:8786"
            ) from None
        try:
            yield client
        finally:
            with contextlib.suppress(Exception):
                client.close(timeout=10)
        return
    n = max(1, workers or os.cpu_count() or 1)
    with dask.config.set(WORKER_SETTINGS), _workers_ignore_ctrl_c():
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,  # one simulation per process: pybullet and the GIL do not share well
            processes=True,
            host=LOOPBACK,
            dashboard_address=f"{LOOPBACK}:{dashboard or 0}",  # never ":8787", which listens on every interface
            silence_logs=logging.ERROR,
        )
    try:
        client = Client(cluster)
        try:
            yield client
        finally:
            with contextlib.suppress(Exception):
                client.close(timeout=10)
    finally:
        _quiet_shutdown()
        with contextlib.suppress(Exception):
            cluster.close(timeout=20)


@contextlib.contextmanager
def _workers_ignore_ctrl_c() -> Iterator[None]:
    """Ctrl-C in a terminal reaches every process of the sweep; it is the driver's to handle (cancel, write
    the table, shut the cluster down). Worker processes are spawned with SIGINT ignored, a disposition a
    child keeps (and Python then installs no KeyboardInterrupt handler), so they do not die mid-task with
    a traceback each. Ctrl-C is ignored meanwhile: the cluster's start-up, a second or two."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _quiet_shutdown() -> None:
    """Workers cancelled or killed mid-run make distributed log at shutdown what the sweep already said."""
    for name in ("distributed", "tornado"):
        logging.getLogger(name).setLevel(logging.CRITICAL)


def check_workers(client: Any, scheduler: str | None) -> int:
    """Wait for a worker (an existing cluster may still be starting them) and check every worker runs
    the same mission as this driver (the same version, and the same commit where both know theirs: a
    wheel installed on a worker has none); the number of workers."""
    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT_S)
    except TimeoutError:
        raise MissionError(
            f"--scheduler {scheduler}: no worker joined within {WORKER_WAIT_S:.0f} s; start "
            f"workers with `dask worker {scheduler}`"
        ) from None
    here = worker_identity()
    for address, theirs in client.run(worker_identity).items():
        commits = (theirs.get("commit"), here.get("commit"))
        if theirs.get("mission") != here.get("mission") or (None not in commits and commits[0] != commits[1]):
            raise MissionError(
                f"worker {address} runs mission {theirs.get('mission')} at commit {theirs.get('commit')}, this "
                f"driver {here.get('mission')} at {here.get('commit')}; every worker must run the same mission "
                "(the same seed must give the same outcome)"
            )
    return len(client.scheduler_info().get("workers", {}))


class _Bar:
    """A rich progress bar on stderr (nothing when not `show`): runs done, ok/failed, the last run."""

    def __init__(self, show: bool, total: int, skipped: int) -> None:
        self.show = show
        self.total = total
        self.skipped = skipped
        self.ok = self.failed = 0
        self._progress: Any = None
        self._task: Any = None

    def __enter__(self) -> _Bar:
        if self.show:
            from rich import progress as rp
            from rich.console import Console

            self._progress = rp.Progress(
                rp.TextColumn("sweep"),
                rp.BarColumn(),
                rp.MofNCompleteColumn(),
                rp.TimeElapsedColumn(),
                rp.TimeRemainingColumn(),
                rp.TextColumn("{task.description}"),
                console=Console(stderr=True),
                redirect_stdout=False,
                redirect_stderr=False,
            )
            self._progress.__enter__()
            note = f"{self.skipped} finished before, skipped" if self.skipped else ""
            self._task = self._progress.add_task(note, total=self.total)
        return self

    def advance(self, row: dict[str, Any] | None, lost: str | None = None) -> None:
        if row is not None:
            if row.get("success"):
                self.ok += 1
            else:
                self.failed += 1
        if self._progress is None:
            return
        last = f"{row['cell']} seed {row['seed']}: {'ok' if row.get('success') else 'FAIL'}" if row else lost
        self._progress.update(self._task, advance=1, description=f"ok {self.ok} · failed {self.failed} · {last}")

    def __exit__(self, *exc: Any) -> None:
        if self._progress is not None:
            self._progress.__exit__(*exc)


def run_sweep(
    plan: SweepPlan,
    out: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    dashboard: int | None = None,
    progress: bool = True,
    budget_s: float | None = None,
    summary: bool = True,
    on_result: Callable[[RunResult], None] | None = None,
) -> SweepOutcome:
    """Run every run of `plan` not yet finished in `out` and record each as it arrives; the table (and the
    summary, when `summary`) are written at the end however it ends. `budget_s`: submit no more after that
    many seconds and cancel what is left (a benchmark's time limit). Raises MissionError before anything
    runs when the plan or the directory is wrong."""
    plan.check()
    store = SweepStore(out)
    store.open(plan)
    runs = plan.runs()
    todo = [r for r in runs if not store.finished(r.run_id)]
    result = SweepOutcome(Path(out), planned=len(runs), skipped=len(runs) - len(todo), scheduler=scheduler or "local")
    t0 = time.perf_counter()
    written = False

    def finish() -> None:
        nonlocal written
        if not written:
            written = True
            store.write_table()
            if summary:
                from mission.sweep.summary import write_summary

                write_summary(store)

    try:
        if todo:
            with connect(scheduler, workers, dashboard) as client:
                try:
                    result.workers = check_workers(client, scheduler)
                    _drive(client, todo, store, result, progress, budget_s, t0, on_result)
                except KeyboardInterrupt:
                    result.interrupted = True
                finally:
                    finish()  # before the cluster shuts down, which can take a while after an interrupt
    except KeyboardInterrupt:
        result.interrupted = True
    finally:
        finish()
        result.wall_s = round(time.perf_counter() - t0, 2)
        result.duplicates = store.duplicates
        result.rows = list(store.rows.values())
        result.unfinished = [r.run_id for r in todo if not store.finished(r.run_id)]
    return result


def _drive(
    client: Any,
    todo: list[RunSpec],
    store: SweepStore,
    result: SweepOutcome,
    progress: bool,
    budget_s: float | None,
    t0: float,
    on_result: Callable[[RunResult], None] | None,
) -> None:
    from distributed import as_completed
    from distributed.client import FutureCancelledError
    from distributed.scheduler import KilledWorker

    token = uuid.uuid4().hex[:8]  # keys are unique on a shared scheduler, one sweep from another
    futures = client.map(run_one, todo, key=[f"mission-run-{token}-{r.run_id}" for r in todo], pure=False)
    specs = {f.key: spec for f, spec in zip(futures, todo, strict=True)}
    last_table = time.monotonic()
    try:
        with _Bar(progress, len(todo), result.skipped) as bar:
            for future in as_completed(futures):
                spec = specs[future.key]
                try:
                    res = future.result()
                except KilledWorker:  # it took ALLOWED_FAILURES workers down with it: unfinished, named at the end
                    bar.advance(None, lost=f"{spec.cell} seed {spec.seed}: its workers died")
                    continue
                except FutureCancelledError:
                    continue
                except Exception as err:  # the task could not run at all (run_one turns a crash into a row)
                    result.errors.append(f"{spec.run_id}: {type(err).__name__}: {err}")
                    bar.advance(None, lost=f"{spec.cell} seed {spec.seed}: {type(err).__name__}")
                    continue
                if store.record(res):
                    result.recorded += 1
                    if on_result is not None:
                        on_result(res)
                bar.advance(res.row)
                future.release()
                if time.monotonic() - last_table > TABLE_EVERY_S:
                    store.write_table(reread=False)
                    last_table = time.monotonic()
                if budget_s is not None and time.perf_counter() - t0 > budget_s:
                    result.cut_short = True
                    break
    finally:
        left = [f for f in futures if not f.done()]
        if left:
            with contextlib.suppress(Exception):
                client.cancel(left, force=True)
