"""Workers that start once (issue 25): one process pool per worker count, reused for the whole run, tasks sized by a
measured cost, results as compact arrays, and the same tasks on a Dask cluster.

* Local workers are forked from the running process where the platform allows it (Linux): they inherit its imports,
  loaded machines and compiled numba kernels, so a worker starts in milliseconds instead of seconds. Elsewhere they
  start with ``spawn`` and import pkmstiff once, in their initialiser. The pool stays alive until the process ends, so
  a second section, a sweep or the next chunk of a report reuses it.
* A machine travels to the workers as a :class:`Shared` (its pickle, ~16 kB, and a hash of it); each worker unpickles
  a given machine once and keeps it, so tasks of the same run do not rebuild it.
* :func:`plan` sizes the tasks from a *measured* cost per item (the caller times the first piece of work in this
  process): at least :data:`MIN_TASK_SECONDS` each, about :data:`TASKS_PER_WORKER` per worker for load balance, and a
  whole number of ``granule`` items so that the tasks evaluate exactly the chunks the serial run evaluates (results
  are then byte-identical whatever the number of workers).
* On Dask (``scheduler`` = an address or a ``distributed.Client``) the same tasks go to the cluster; the client is
  kept per address while :func:`connected` encloses the work, and :class:`PreloadPlugin` imports pkmstiff on every worker once. Start workers with
  ``dask worker ADDR --preload pkmstiff.evaluation.parallel`` to do that at worker start-up instead.
"""

from __future__ import annotations

import atexit
import hashlib
import math
import multiprocessing
import os
import pickle
import sys
import time
import weakref
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, ClassVar, Generic, TypeVar

from pkmstiff.errors import ArgumentError, ResourceError

T = TypeVar("T")

#: a Dask task should run at least this long (s): below it, sending it and collecting its result cost a noticeable
#: share (and at least :data:`DASK_OVERHEAD_FACTOR` times the measured round trip of an empty task)
MIN_TASK_SECONDS = 0.2
#: a task in the local (forked) pool should run at least this long (s): a local task costs ~1 ms to send and collect
#: (measured), so 20 ms keeps that below 5 % while 16 workers still get several tasks each of a 2 s section
MIN_LOCAL_TASK_SECONDS = 0.02
#: Dask tasks last at least this many measured round trips of an empty task: the scheduler's share stays below 5 %
DASK_OVERHEAD_FACTOR = 20
#: seconds a fresh (cold) Dask worker needs to import pkmstiff and load the compiled kernels from the on-disk cache
#: (measured ~2.6 s on the shared 2-core machine): work shorter than that stays here while the workers warm up
COLD_WORKER_SECONDS = 3.0
#: tasks per worker when the work allows it: with a few tasks each, a slow worker (a shared machine) delays the end
#: by at most a quarter of its share
TASKS_PER_WORKER = 4


# ------------------------------------------------------------------------------------------------------------ plan
@dataclass(frozen=True)
class Plan:
    """How ``items`` items of work are split: ``tasks`` tasks of ``task_items`` items (the last may hold fewer) on
    ``workers`` workers; ``item_seconds`` is the measured cost of one item (s) in this process."""

    items: int
    workers: int
    tasks: int
    task_items: int
    item_seconds: float
    where: str = "serial"

    @property
    def parallel(self) -> bool:
        return self.workers > 1 or self.where.startswith("Dask")

    def text(self, unit: str = "points", task: str = "tasks") -> str:
        """One line for the cost line, e.g. ``2 local workers, 8 tasks of 16384 points (≈ 0.9 s each)``."""
        if not self.parallel:
            return f"{self.where} ({self.items} {unit}, ≈ {self.items * self.item_seconds:.1f} s)"
        who = f"{self.workers} local workers" if self.where == "local" else f"{self.where}"
        return (f"{who}, {self.tasks} {task} of {self.task_items} {unit} "
                f"(≈ {self.task_items * self.item_seconds:.2f} s each)")


def resolve_workers(n_jobs: int) -> int:
    """``n_jobs`` -1 = all cores, otherwise a positive number of processes."""
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, int) or n_jobs == 0 or n_jobs < -1:
        raise ArgumentError(option="n_jobs", expected="-1 (all cores) or a positive integer", found=n_jobs)
    return os.cpu_count() or 1 if n_jobs == -1 else n_jobs


def plan(items: int, item_seconds: float, n_jobs: int = 1, scheduler: Any = None, granule: int = 1, *,
         tasks_per_worker: int = TASKS_PER_WORKER) -> Plan:
    """Split ``items`` items (each ``item_seconds`` s, measured) into tasks for ``n_jobs`` local workers or a Dask
    cluster: tasks of a whole number of ``granule`` items, each ≥ :data:`MIN_LOCAL_TASK_SECONDS` (local) or
    ≥ :data:`MIN_TASK_SECONDS` and :data:`DASK_OVERHEAD_FACTOR` measured round trips (Dask), about
    ``tasks_per_worker`` per worker (work that ends at a barrier, such as a generation of candidates, asks for as
    many as the least task time allows: the smaller the last task, the less a worker waits for the other). Too little work for two such tasks runs serially (workers=1, tasks=1), and
    so does work that the cluster would not finish sooner than this process (its text says why)."""
    work = items * max(item_seconds, 0.0)
    rtt = 0.0
    if scheduler is None:
        workers, least_seconds, where = resolve_workers(n_jobs), MIN_LOCAL_TASK_SECONDS, "local"
    else:
        workers, cold = _dask_workers(scheduler)
        where = f"Dask ({workers} workers at {_address(scheduler)})"
        if cold and work < COLD_WORKER_SECONDS + work / workers:
            _warm_in_background(scheduler)  # not worth waiting for them now; warm for the next run
            return Plan(items, 1, min(items, 1), items, item_seconds, "serial: the Dask workers are still cold")
        rtt = round_trip(scheduler)
        least_seconds = max(MIN_TASK_SECONDS, DASK_OVERHEAD_FACTOR * rtt)
    granules = math.ceil(items / granule) if items else 0
    per_granule = max(item_seconds, 0.0) * granule
    least = max(1, math.ceil(least_seconds / per_granule)) if per_granule > 0 else 1
    size = max(least, math.ceil(granules / (workers * tasks_per_worker))) if workers > 1 else granules
    tasks = math.ceil(granules / size) if size else 0
    if tasks < 2 and scheduler is not None and items:
        return Plan(items, 1, 1, items, item_seconds,
                    f"serial: here ≈ {work:.2f} s, too little for two Dask tasks of ≥ {least_seconds:.2f} s "
                    f"({rtt * 1e3:.0f} ms per task measured)" if workers > 1 else "serial: the Dask cluster has one "
                    "worker thread")
    if tasks < 2:
        return Plan(items, 1, min(tasks, 1), items, item_seconds)
    if scheduler is not None:
        on_dask = math.ceil(tasks / workers) * (size * per_granule + rtt)  # waves of tasks, each with its round trip
        if on_dask >= work:
            return Plan(items, 1, 1, items, item_seconds,
                        f"serial: here ≈ {work:.2f} s, on Dask ≈ {on_dask:.2f} s ({rtt * 1e3:.0f} ms per task "
                        f"measured)")
        _register_preload(scheduler)  # waits until every worker is warm (warm ones answer at once)
    return Plan(items, min(workers, tasks), tasks, size * granule, item_seconds, where)


def split(items: int, p: Plan) -> list[tuple[int, int]]:
    """(start, stop) of each task of ``p`` over ``items`` items."""
    return [(s, min(s + p.task_items, items)) for s in range(0, items, max(p.task_items, 1))]


# ---------------------------------------------------------------------------------------------------- shared data
class Shared(Generic[T]):
    """An object (a machine) sent to workers once per worker: its pickle and a hash of it. :meth:`get` returns the
    object, unpickled at most once per process."""

    _cache: ClassVar[dict[str, Any]] = {}
    #: objects kept per process (the most recently used; a design optimisation sends thousands of machines)
    KEEP = 8

    def __init__(self, obj: T) -> None:
        self.data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
        self.key = hashlib.sha1(self.data).hexdigest()
        self._keep(obj)  # this process (and workers forked later) hold it already

    def get(self) -> T:
        obj = Shared._cache.pop(self.key, None)
        return self._keep(pickle.loads(self.data) if obj is None else obj)

    def _keep(self, obj: T) -> T:
        Shared._cache.pop(self.key, None)
        Shared._cache[self.key] = obj  # newest last
        while len(Shared._cache) > Shared.KEEP:
            Shared._cache.pop(next(iter(Shared._cache)))
        return obj

    def __getstate__(self) -> dict[str, Any]:
        return {"data": self.data, "key": self.key}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.data, self.key = state["data"], state["key"]


# ----------------------------------------------------------------------------------------------------- local pool
_POOLS: dict[int, ProcessPoolExecutor] = {}


_WARM = False


def warm_up() -> None:
    """Import what workers run and load the compiled kernels from the on-disk cache (once per process; forked workers
    inherit both from the process that forks them): build a machine from its file, as a sweep's variants are built
    (the builder's imports), and evaluate a section of 441 points on it — enough that the compiled kernels, not the
    interpreted ones of small calls (:mod:`pkmstiff.kinematics.dispatch`), run and load."""
    global _WARM
    if _WARM:
        return
    from pkmstiff.evaluation.sections import axis_plane, evaluate_section
    from pkmstiff.machine.variants import machine_with

    evaluate_section(machine_with("hexaglide"), axis_plane("yz", 0.0, (0.0, 0.1), (-1.0, -0.9), 0.005), ["kx", "f1"],
                     progress=False)
    _WARM = True


def _is_warm() -> bool:
    return _WARM


def _worker_init(warm: bool) -> None:
    """A local worker leaves Ctrl-C (SIGINT to the process group) to the main process, which stops the run and
    reports once; ``warm``: import and load the kernels (spawned workers)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if warm:
        warm_up()


def _context() -> multiprocessing.context.BaseContext:
    if sys.platform.startswith("linux"):
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")


def pool(workers: int) -> ProcessPoolExecutor:
    """The process pool of ``workers`` workers, started at the first call and kept for the life of this process."""
    p = _POOLS.get(workers)
    if p is None:
        ctx = _context()
        p = _POOLS[workers] = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init,
                                                  initargs=(ctx.get_start_method() != "fork",))
    return p


def _pid(_: int) -> int:
    time.sleep(0.005)  # long enough that every started worker takes one of the calls
    return os.getpid()


def start_workers(workers: int) -> int:
    """Start the pool of ``workers`` (if not yet running) and have the workers answer 2 × ``workers`` calls of 5 ms;
    returns the number of distinct worker processes that answered (for benchmarks of the start-up, which the 5 ms
    calls bound from above)."""
    p = pool(workers)
    return len(set(p.map(_pid, range(2 * workers))))


def worker_pids() -> list[int]:
    """Process ids of the running local workers (every pool), for benchmarks that read each worker's CPU time."""
    return sorted(pid for p in _POOLS.values() for pid in (getattr(p, "_processes", None) or {}))


def shutdown() -> None:
    """Stop the local pools and close the Dask clients this process opened."""
    for p in _POOLS.values():
        p.shutdown(wait=True, cancel_futures=True)
    _POOLS.clear()
    for c in _CLIENTS.values():
        c.close()
    _CLIENTS.clear()


atexit.register(shutdown)


# ------------------------------------------------------------------------------------------------------------ dask
_CLIENTS: dict[str, Any] = {}


def _address(scheduler: Any) -> str:
    return scheduler if isinstance(scheduler, str) else str(getattr(scheduler, "scheduler", scheduler).address)


def client(scheduler: Any) -> Any:
    """A ``distributed.Client`` for ``scheduler`` (an address or a client), kept per address for the run
    (:func:`plan` registers :class:`PreloadPlugin` when the work goes to the cluster)."""
    try:
        from distributed import Client
    except ImportError:
        raise ResourceError("scheduler: Dask execution needs dask.distributed (pip install 'pkmstiff[dask]')") from None
    if isinstance(scheduler, Client):
        c = scheduler
    else:
        c = _CLIENTS.get(scheduler)
        if c is None:
            try:
                c = _CLIENTS[scheduler] = Client(scheduler, timeout=30)
            except (OSError, TimeoutError, ValueError) as exc:
                raise ResourceError(f"scheduler: cannot connect to the Dask scheduler {scheduler!r}: {exc}") from None
    return c


@contextmanager
def connected(scheduler: Any) -> Iterator[None]:
    """Keep one client to ``scheduler`` (an address) for the enclosed work and close it afterwards (a client passed
    in by the caller stays open)."""
    try:
        yield
    finally:
        if isinstance(scheduler, str) and scheduler in _CLIENTS:
            _CLIENTS.pop(scheduler).close()


def _dask_workers(scheduler: Any) -> tuple[int, int]:
    """(worker threads, workers not yet warm) of the cluster."""
    c = client(scheduler)
    info = c.scheduler_info()
    warm = c.run(_is_warm)
    return (max(1, sum(int(w.get("nthreads", 1)) for w in info.get("workers", {}).values())),
            sum(1 for v in warm.values() if not v))


_ROUND_TRIP: dict[str, float] = {}
_REGISTERED: weakref.WeakSet = weakref.WeakSet()  # clients that registered the plugin


def _noop() -> None:
    return None


def round_trip(scheduler: Any) -> float:
    """Seconds to submit an empty task to the cluster and collect its result (best of three, measured once per
    address): the scheduler's overhead per task."""
    key = _address(scheduler)
    if key not in _ROUND_TRIP:
        c, best = client(scheduler), float("inf")
        for _ in range(3):
            t0 = time.perf_counter()
            c.submit(_noop, pure=False).result()
            best = min(best, time.perf_counter() - t0)
        _ROUND_TRIP[key] = best
    return _ROUND_TRIP[key]


def _register_preload(scheduler: Any) -> None:
    """Register :class:`PreloadPlugin` once per client (it then also warms workers that join later)."""
    c = client(scheduler)
    if c not in _REGISTERED:
        c.register_plugin(PreloadPlugin())
        _REGISTERED.add(c)


def _warm_in_background(scheduler: Any) -> None:
    """One warm-up task per cold worker, not waited for."""
    from distributed import fire_and_forget

    c = client(scheduler)
    for addr, warm in c.run(_is_warm).items():
        if not warm:
            fire_and_forget(c.submit(warm_up, workers=[addr], allow_other_workers=False, pure=False))


try:  # the plugin base class only where distributed is installed
    from distributed.diagnostics.plugin import WorkerPlugin as _WorkerPlugin
except ImportError:  # pragma: no cover
    _WorkerPlugin = object  # type: ignore[assignment,misc]


class PreloadPlugin(_WorkerPlugin):  # type: ignore[misc,valid-type]
    """Dask worker plugin: imports pkmstiff's evaluation modules once per worker (machines are then kept per worker
    by :class:`Shared`)."""

    name = "pkmstiff-preload"

    def setup(self, worker: Any) -> None:
        warm_up()


def dask_setup(worker: Any) -> None:
    """Entry point of ``dask worker --preload pkmstiff.evaluation.parallel``."""
    warm_up()


# ------------------------------------------------------------------------------------------------------------- run
_MEANWHILE_CPU = [0.0]


def meanwhile_cpu_seconds() -> float:
    """CPU seconds this process has spent in :func:`run_tasks`' ``meanwhile`` work while its workers ran (parallel
    work done here: a benchmark's serial fraction leaves it out)."""
    return _MEANWHILE_CPU[0]


def run_tasks(fn: Callable[..., T], payloads: Sequence[tuple], p: Plan, scheduler: Any = None,
              progress: Callable[[int], None] | None = None, *,
              meanwhile: Callable[[], None] | None = None) -> list[T]:
    """``[fn(*args) for args in payloads]`` in order: in this process (serial plan), in the local pool or on the Dask
    cluster. ``progress(k)`` is called after each finished task (any order) with the number finished.
    ``meanwhile()`` runs in this process once the tasks are submitted (first, for a serial plan): work of its own
    that would otherwise make the workers wait."""
    if meanwhile is not None and not (payloads and p.parallel):
        meanwhile()
    if not payloads:
        return []
    if not p.parallel:
        out = []
        for k, args in enumerate(payloads, 1):
            out.append(fn(*args))
            if progress:
                progress(k)
        return out
    if scheduler is not None:
        c = client(scheduler)
        futures = [c.submit(fn, *args, pure=False) for args in payloads]
    else:
        ex = pool(p.workers)
        try:
            futures = [ex.submit(fn, *args) for args in payloads]
        except BrokenProcessPool as exc:
            _POOLS.pop(p.workers, None)
            raise ResourceError(f"local worker pool broke: {exc}") from None
    if meanwhile is not None:
        c0 = time.thread_time()  # this thread's CPU only: the pool's own threads are not the meanwhile work
        meanwhile()
        _MEANWHILE_CPU[0] += time.thread_time() - c0
    if progress:
        _report_progress(futures, progress, scheduler is not None)
    try:
        return c.gather(futures) if scheduler is not None else [f.result() for f in futures]
    except BrokenProcessPool as exc:
        _POOLS.pop(p.workers, None)
        raise ResourceError(f"a local worker died ({exc}); rerun with fewer --jobs or a larger memory budget") from None


def _report_progress(futures: list, progress: Callable[[int], None], dask: bool) -> None:
    if dask:
        from distributed import as_completed as done
    else:
        from concurrent.futures import as_completed as done  # type: ignore[assignment]
    for k, _ in enumerate(done(futures), 1):
        progress(k)


__all__ = [
    "DASK_OVERHEAD_FACTOR",
    "MIN_LOCAL_TASK_SECONDS",
    "MIN_TASK_SECONDS",
    "TASKS_PER_WORKER",
    "Plan",
    "PreloadPlugin",
    "Shared",
    "client",
    "connected",
    "meanwhile_cpu_seconds",
    "plan",
    "pool",
    "resolve_workers",
    "round_trip",
    "run_tasks",
    "shutdown",
    "split",
    "start_workers",
    "worker_pids",
]
