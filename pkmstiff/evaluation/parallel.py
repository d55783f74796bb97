"""Workers that start once (issue 25): one process pool per worker count, reused for the whole run, tasks sized by a
measured cost, results as compact arrays, and the same tasks on a Dask cluster.

* Local workers are forked from the running process where the platform allows it (Linux): they inherit its imports,
  loaded machines and compiled numba kernels, so a worker starts in milliseconds instead of seconds. Elsewhere they
  start with ``spawn`` and import pkmstiff once, in their initialiser. The pool stays alive until the process ends, so
  a second section, a sweep or the next chunk of a report reuses it.
* A machine travels to the workers as a :class:`Shared` (its pickle, ~16 kB, and a hash of it); each worker unpickles
  a given machine once and keeps it, so tasks of the same run do not rebuild it.
* A task's large result arrays come back through files in shared memory, mapped here without a copy
  (:mod:`pkmstiff.evaluation.result_files`; the result pipe carries the rest).
* :func:`plan` sizes the tasks from a *measured* cost per item (the caller times the first piece of work in this
  process): at least :data:`MIN_TASK_SECONDS` each, about :data:`TASKS_PER_WORKER` per worker for load balance, and a
  whole number of ``granule`` items so that the tasks evaluate exactly the chunks the serial run evaluates (results
  are then byte-identical whatever the number of workers).
* On Dask (``scheduler`` = an address or a ``distributed.Client``) the same tasks go to the cluster while this
  process takes tasks too (from the other end; it also takes over tasks that run late there), so a run is never much
  slower than a serial one. The plan counts the cluster's fixed costs (connecting, asking for the workers, measuring
  the round trip of an empty task, registering :class:`PreloadPlugin`, the warm-up of cold workers) and connects only
  when the estimate alone does not already keep the work here; what it measured is kept per address for the process.
  Start workers with ``dask worker ADDR --preload pkmstiff.evaluation.parallel`` to warm them at start-up.
"""

from __future__ import annotations

import atexit
import hashlib
import math
import multiprocessing
import os
import pickle
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, ClassVar, Generic, TypeVar

import numpy as np

from pkmstiff.errors import ArgumentError, ResourceError
from pkmstiff.evaluation import result_files

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
#: (measured ~2.6 s on the shared 2-core machine): the plan waits for cold workers only when that pays
COLD_WORKER_SECONDS = 3.0
#: fixed costs of a Dask cluster not yet measured by this process (s): connecting (66–79 ms measured with a local
#: cluster on the shared 2-core machine), asking for the workers and whether they are warm (13–33 ms), three round
#: trips of an empty task (47–124 ms) and registering :class:`PreloadPlugin` (3–18 ms on warm workers)
DASK_FIXED_SECONDS = 0.2
#: importing dask.distributed, where this process has not imported it yet (0.3–0.9 s measured on that machine)
DASK_IMPORT_SECONDS = 0.3
#: registering :class:`PreloadPlugin` with warm workers (3–18 ms measured)
DASK_PLUGIN_SECONDS = 0.02
#: round trip of an empty Dask task (s) assumed until it can be measured on a warm worker (6–14 ms measured there)
ROUND_TRIP_SECONDS = 0.02
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
    #: on Dask: the estimate that chose the plan and the cluster's fixed costs (for the cost line)
    note: str = ""

    @property
    def parallel(self) -> bool:
        return self.workers > 1 or self.where.startswith("Dask")

    def text(self, unit: str = "points", task: str = "tasks") -> str:
        """One line for the cost line, e.g. ``2 local workers, 8 tasks of 16384 points (≈ 0.9 s each)``."""
        note = f"; {self.note}" if self.note else ""
        if not self.parallel:
            return f"{self.where} ({self.items} {unit}, ≈ {self.items * self.item_seconds:.1f} s){note}"
        who = f"{self.workers} local workers" if self.where == "local" else f"{self.where}"
        return (f"{who}, {self.tasks} {task} of {self.task_items} {unit} "
                f"(≈ {self.task_items * self.item_seconds:.2f} s each){note}")


def resolve_workers(n_jobs: int) -> int:
    """``n_jobs`` -1 = all cores, otherwise a positive number of processes."""
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, int) or n_jobs == 0 or n_jobs < -1:
        raise ArgumentError(option="n_jobs", expected="-1 (all cores) or a positive integer", found=n_jobs)
    return os.cpu_count() or 1 if n_jobs == -1 else n_jobs


def plan(items: int, item_seconds: float, n_jobs: int = 1, scheduler: Any = None, granule: int = 1, *,
         tasks_per_worker: int = TASKS_PER_WORKER) -> Plan:
    """Split ``items`` items (each ``item_seconds`` s, measured) into tasks for ``n_jobs`` local workers or a Dask
    cluster: tasks of a whole number of ``granule`` items, each ≥ :data:`MIN_LOCAL_TASK_SECONDS` (local), about
    ``tasks_per_worker`` per worker (work that ends at a barrier, such as a generation of candidates, asks for as many
    as the least task time allows: the smaller the last task, the less a worker waits for the other; locally only).
    Too little work for two such tasks runs serially (workers=1, tasks=1). On Dask (:func:`_dask_plan`) the work stays here unless the cluster, with this process working beside it, finishes
    it sooner including the cluster's fixed costs; the plan's text says why."""
    if scheduler is not None:
        return _dask_plan(items, item_seconds, scheduler, granule)
    workers = resolve_workers(n_jobs)
    size, tasks = _task_size(items, item_seconds, granule, workers, MIN_LOCAL_TASK_SECONDS,
                             tasks_per_worker)
    if tasks < 2:
        return Plan(items, 1, min(tasks, 1), items, item_seconds)
    return Plan(items, min(workers, tasks), tasks, size * granule, item_seconds, "local")


def _task_size(items: int, item_seconds: float, granule: int, workers: int, least_seconds: float,
               tasks_per_worker: int = TASKS_PER_WORKER) -> tuple[int, int]:
    """(granules per task, tasks) for ``workers`` workers: tasks of ≥ ``least_seconds``, about
    ``tasks_per_worker`` per worker (one task of everything for one worker)."""
    granules = math.ceil(items / granule) if items else 0
    per_granule = max(item_seconds, 0.0) * granule
    least = max(1, math.ceil(least_seconds / per_granule)) if per_granule > 0 else 1
    size = max(least, math.ceil(granules / (workers * tasks_per_worker))) if workers > 1 else granules
    return size, (math.ceil(granules / size) if size else 0)


def split(items: int, p: Plan) -> list[tuple[int, int]]:
    """(start, stop) of each task of ``p`` over ``items`` items."""
    return [(s, min(s + p.task_items, items)) for s in range(0, items, max(p.task_items, 1))]


#: the last task of a guided split holds this fraction of the first's items
GUIDED_LAST = 0.25


def guided_bounds(items: int, tasks: int, workers: int, last: float = GUIDED_LAST) -> np.ndarray:
    """(tasks + 1,) bounds of ``tasks`` contiguous tasks over ``items`` items whose sizes fall geometrically from the
    first to the last (``last`` times the first's): the workers take them in order, so the long ones start first and
    the short ones fill the ends, and a worker waits for the other at the end for at most about a short task
    (guided self-scheduling, Polychronopoulos & Kuck 1987) where equal tasks of varying cost leave one core idle for up
    to a long one. Equal tasks where there are no more than ``workers`` (each worker takes one). Every task holds at
    least one item while ``items >= tasks``."""
    if tasks <= max(workers, 1) or items <= tasks:
        return np.linspace(0, items, max(tasks, 1) + 1).round().astype(np.int64)
    w = last ** (np.arange(tasks) / (tasks - 1))
    b = np.concatenate([[0.0], np.cumsum(w)]) * (items / w.sum())
    b = b.round().astype(np.int64)
    b = np.maximum(b, np.arange(tasks + 1))  # at least one item per task ...
    return np.minimum(b, items - tasks + np.arange(tasks + 1))  # ... from both ends


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
_WARM_LOCK = threading.Lock()


def warm_up() -> None:
    """Import what workers run and load the compiled kernels from the on-disk cache (once per process; forked workers
    inherit both from the process that forks them): build a machine from its file, as a sweep's variants are built
    (the builder's imports), and evaluate a section of 441 points on it — enough that the compiled kernels, not the
    interpreted ones of small calls (:mod:`pkmstiff.kinematics.dispatch`), run and load — and one pose as a sweep's
    point evaluation does (the small-N kernels: without it a warm Dask worker's first batch of four sweep tasks took
    0.44 s, the next ones 0.2 s)."""
    global _WARM
    if _WARM:
        return
    with _WARM_LOCK:  # once, also where a Dask worker's background warm-up and a task's ask at the same time
        if _WARM:
            return
        from pkmstiff.evaluation.requests import PointRequest
        from pkmstiff.evaluation.sections import axis_plane, evaluate_section
        from pkmstiff.machine.variants import machine_with

        machine = machine_with("hexaglide")
        evaluate_section(machine, axis_plane("yz", 0.0, (0.0, 0.1), (-1.0, -0.9), 0.005), ["kx", "f1"],
                         progress=False)
        PointRequest((0.0, 0.0, -1.0, 0.0, 0.0, 0.0), ("kx", "f1"), frame="report").evaluate(machine)
        _WARM = True


def _is_warm() -> bool:
    return _WARM


def _worker_init(warm: bool) -> None:
    """A local worker leaves Ctrl-C (SIGINT to the process group) to the main process, which stops the run and
    reports once; its allocator keeps freed memory (:func:`steady_malloc`); ``warm``: import and load the kernels
    (spawned workers). The objects a forked worker inherits are frozen out of its garbage collector
    (:func:`gc.freeze`): a collection writes to every object it visits, which would copy each page of the inherited
    heap that holds one (copy on write; measured on the optimise pair of benchmarks/bench_scaling.py, its two figures
    took 15,000 page faults each and 0.46 s of CPU in the workers without it, about 1,800 and 0.23 s with it, 0.19 s
    in the serial run). Objects made in the worker are collected as usual; the inherited ones belong to the process
    that forked it."""
    import gc
    import signal

    gc.freeze()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    steady_malloc()
    if warm:
        warm_up()


#: glibc ``mallopt`` parameters and the values a command and its workers set (:func:`steady_malloc`)
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD, M_ARENA_MAX = -1, -3, -8
MALLOC_MMAP_THRESHOLD = 32 << 20  # bytes: arrays below it come from the heap (glibc's own upper bound for its
#: adaptive threshold, which a long-running command reaches after its first large arrays)
MALLOC_TRIM_THRESHOLD = 128 << 20  # bytes of free memory a process keeps at the top of its heap
_MALLOC_STEADY = [False]


def steady_malloc() -> bool:
    """glibc only (elsewhere nothing, False): serve arrays up to :data:`MALLOC_MMAP_THRESHOLD` from the heap and keep
    up to :data:`MALLOC_TRIM_THRESHOLD` of freed memory instead of returning it to the system; set by every command
    (:func:`pkmstiff.cli.main`) and every local worker. A fresh process otherwise maps and unmaps its large temporary
    arrays afresh for every chunk, and the system zeroes each page again on first touch: at 2 mm the workspace's
    workers took 230–360k minor page faults and 0.6–0.8 s of system CPU per run, with these settings 73–91k and
    0.2–0.3 s; a whole `--jobs 1` run 175–204k faults and 1.0–1.1 s against 115–137k and 0.55–0.75 s.

    Threads allocate from the same heap (one arena, ``M_ARENA_MAX``): glibc otherwise gives a thread of its own (the
    workspace's mesh and volumes run on two threads after a parallel octree) an arena of its own, whose heap grows
    and shrinks by ``mprotect`` and ``madvise`` while the other thread takes page faults; that phase of a 2 mm
    workspace took 0.23–0.36 s with 0.13–0.28 s of system CPU, with one arena 0.19–0.20 s with 0.08–0.10 s (four
    runs each). Our threads run compiled loops between a few large allocations: the shared arena's lock costs
    nothing measurable."""
    mallopt = _libc_function("mallopt")
    if mallopt is None:
        return False
    _MALLOC_STEADY[0] = bool(mallopt(M_MMAP_THRESHOLD, MALLOC_MMAP_THRESHOLD)) and \
        bool(mallopt(M_TRIM_THRESHOLD, MALLOC_TRIM_THRESHOLD)) and bool(mallopt(M_ARENA_MAX, 1))
    _small_pages_for_fresh_arrays()
    return _MALLOC_STEADY[0]


def _libc_function(name: str) -> Callable[..., int] | None:
    """The C library's function ``name`` (glibc's ``mallopt``, ``malloc_trim``), None where there is none."""
    import ctypes

    try:
        return getattr(ctypes.CDLL(None), name)
    except (OSError, AttributeError):
        return None


def _small_pages_for_fresh_arrays() -> bool:
    """Numpy asks the system for transparent huge pages for each array of 4 MB or more (``madvise``); where the
    system's memory is fragmented, the first touch of such a fresh array then waits while the kernel compacts memory
    for 2 MB pages. Arrays above :data:`MALLOC_MMAP_THRESHOLD` are fresh every time, so the octree's closure, mesh and
    volumes of a 2 mm workspace (arrays of 10–80 MB) took 0.71–0.84 s with 0.32–0.40 s of system CPU, and
    0.54–0.67 s with 0.14–0.18 s without huge pages (same machine and hour, alternating). Numpy's switch is private:
    where it is missing nothing changes (False)."""
    switch = _huge_page_switch()
    if switch is None:
        return False
    switch(False)
    return True


def _huge_page_switch() -> Callable[[bool], bool] | None:
    """Numpy's ``_set_madvise_hugepage`` (numpy 2: ``numpy._core``, numpy 1: ``numpy.core``), None where absent."""
    core = getattr(np, "_core", None) or getattr(np, "core", None)
    return getattr(getattr(core, "multiarray", None), "_set_madvise_hugepage", None)


def _malloc_steady() -> bool:
    return _MALLOC_STEADY[0]


def _context() -> multiprocessing.context.BaseContext:
    if sys.platform.startswith("linux"):
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")


#: bytes the pipe that carries the workers' results to this process holds (Linux; the system's default upper bound
#: for an unprivileged process): with the default 64 kB a task's result of a few MB crosses in many small writes and
#: reads, each a switch between a worker and this process
RESULT_PIPE_BYTES = 1 << 20


def pool(workers: int) -> ProcessPoolExecutor:
    """The process pool of ``workers`` workers, started at the first call and kept for the life of this process.

    This process's serial share of a parallel run grows with the workers (the benchmark's Amdahl fit): forking one
    costs it about 2–3 ms, mostly copying the page tables of its heap, and each task's result about 0.2–0.5 ms. Before
    forking, the heap's free memory goes back to the system (:func:`trim_heap`: fewer pages to copy; 8 forks 24 →
    18 ms measured after a section's window fit), and the result pipe holds :data:`RESULT_PIPE_BYTES` (a task of
    12,288 points ≈ 0.27 → 0.2 ms, a 1.3 MB result ≈ 0.8 → 0.65 ms of this process's CPU, 8 workers)."""
    p = _POOLS.get(workers)
    if p is None:
        ctx = _context()
        forked = ctx.get_start_method() == "fork"
        if forked:
            trim_heap()
        p = _POOLS[workers] = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init,
                                                  initargs=(not forked,))
        _widen_result_pipe(p)
    return p


def _widen_result_pipe(p: ProcessPoolExecutor) -> bool:
    """Give ``p``'s result pipe :data:`RESULT_PIPE_BYTES` (Linux only; elsewhere, or where the pool keeps its queue
    otherwise or the system refuses, it stays as it is: False)."""
    try:
        import fcntl
    except ImportError:  # not on Windows
        return False
    reader = getattr(getattr(p, "_result_queue", None), "_reader", None)
    set_size = getattr(fcntl, "F_SETPIPE_SZ", None)
    if reader is None or set_size is None:
        return False
    try:
        return fcntl.fcntl(reader.fileno(), set_size, RESULT_PIPE_BYTES) >= RESULT_PIPE_BYTES
    except (OSError, ValueError):
        return False


def trim_heap() -> bool:
    """glibc only (elsewhere nothing, False): return the heap's free memory to the system (``malloc_trim``)."""
    malloc_trim = _libc_function("malloc_trim")
    return malloc_trim is not None and bool(malloc_trim(0))


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
    result_files.clear()
    for c in _CLIENTS.values():
        c.close()
    _CLIENTS.clear()
    _CLUSTERS.clear()


atexit.register(shutdown)


# ------------------------------------------------------------------------------------------------------------ dask
@dataclass
class _Cluster:
    """What this process has measured of one Dask cluster (per address, kept for the life of the process)."""

    #: fixed costs paid so far (s): "connect", "query" (workers, and which are warm), "round trips", "plugin"
    costs: dict[str, float] = field(default_factory=dict)
    round_trip: float | None = None
    threads: dict[str, int] | None = None  # worker threads per worker address, at the last look
    warm: set[str] = field(default_factory=set)  # worker addresses known warm (a worker never cools down)
    registered: bool = False  # PreloadPlugin registered with the scheduler (it keeps it for workers that join)
    use: list[str] | None = None  # the workers the current plan's tasks go to (None: any)

    def paid(self, name: str, t0: float) -> None:
        self.costs[name] = self.costs.get(name, 0.0) + time.perf_counter() - t0

    def text(self) -> str:
        parts = ", ".join(f"{k} {v:.2f}" for k, v in self.costs.items())
        return f"fixed costs {sum(self.costs.values()):.2f} s" + (f" ({parts})" if parts else "")


_CLIENTS: dict[str, Any] = {}
_CLUSTERS: dict[str, _Cluster] = {}
_OPEN = [0]  # depth of nested :func:`connected` blocks


def _address(scheduler: Any) -> str:
    return scheduler if isinstance(scheduler, str) else str(getattr(scheduler, "scheduler", scheduler).address)


def address(scheduler: Any) -> str:
    """The address of a Dask ``scheduler`` (an address or a client), e.g. for a cost line."""
    return _address(scheduler)


def _cluster(scheduler: Any) -> _Cluster:
    return _CLUSTERS.setdefault(_address(scheduler), _Cluster())


#: seconds a connection to a Dask scheduler may take (distributed's default); a plain TCP probe first
#: (:data:`PROBE_TIMEOUT_S`) answers at once for an address where nothing listens instead of after this wait
CONNECT_TIMEOUT_S = 30.0
PROBE_TIMEOUT_S = 5.0


def _reachable(scheduler: Any) -> None:
    """Raise :class:`ResourceError` at once if nothing accepts TCP connections at a ``tcp://host:port`` or
    ``host:port`` scheduler address (distributed itself retries a refused connection until its timeout). Other
    protocols (tls://, ucx://, inproc://) are left to distributed."""
    import socket
    from urllib.parse import urlsplit

    if not isinstance(scheduler, str):
        return
    address = scheduler if "://" in scheduler else f"tcp://{scheduler}"
    parts = urlsplit(address)
    if parts.scheme != "tcp" or not parts.hostname:
        return
    try:
        port = parts.port or 8786
    except ValueError:
        raise ResourceError(f"scheduler: expected host:port, found {scheduler!r}") from None
    try:
        socket.create_connection((parts.hostname, port), timeout=PROBE_TIMEOUT_S).close()
    except OSError as exc:
        raise ResourceError(f"scheduler: nothing accepts connections at {scheduler!r} "
                            f"(probed for up to {PROBE_TIMEOUT_S:g} s: {exc})") from None


def client(scheduler: Any) -> Any:
    """A ``distributed.Client`` for ``scheduler`` (an address or a client), kept per address while the outermost
    :func:`connected` block runs (the time to connect counts as a fixed cost of the cluster)."""
    t0 = time.perf_counter()
    try:
        from distributed import Client
    except ImportError:
        raise ResourceError("scheduler: Dask execution needs dask.distributed (pip install 'pkmstiff[dask]')") from None
    if isinstance(scheduler, Client):
        return scheduler
    c = _CLIENTS.get(scheduler)
    if c is None or c.status not in ("running", "connecting", "newly-created"):
        _reachable(scheduler)
        try:
            c = _CLIENTS[scheduler] = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ResourceError(f"scheduler: cannot connect to the Dask scheduler {scheduler!r}: {exc}") from None
        _cluster(scheduler).paid("connect", t0)
    return c


@contextmanager
def connected(scheduler: Any) -> Iterator[None]:
    """Keep one client to ``scheduler`` (an address) for the enclosed work, nested blocks included (a report's
    sections share it), and close it at the end of the outermost block; a client passed in by the caller stays open.
    What was measured of the cluster (round trip, warm workers, the plugin) stays known for the process."""
    _OPEN[0] += 1
    try:
        yield
    finally:
        _OPEN[0] -= 1
        if not _OPEN[0] and isinstance(scheduler, str) and scheduler in _CLIENTS:
            _CLIENTS.pop(scheduler).close()


def _dask_workers(scheduler: Any) -> tuple[dict[str, int], list[str]]:
    """(worker threads per worker address, addresses of the warm workers) of the cluster; asks only the workers not
    yet known warm whether they are."""
    c, rec = client(scheduler), _cluster(scheduler)
    t0 = time.perf_counter()
    threads = {a: max(1, int(w.get("nthreads", 1))) for a, w in c.scheduler_info().get("workers", {}).items()}
    # a worker warming up is not asked (the scheduler knows its tasks): its warm-up thread, at the lowest priority,
    # holds the interpreter lock for seconds on a busy host, and the worker could not answer meanwhile
    warming = {a for a, keys in c.processing().items() if any(str(k).startswith(_WARM_UP_KEY) for k in keys)}
    unknown = [a for a in threads if a not in rec.warm and a not in warming]
    if unknown:
        rec.warm.update(a for a, warm in c.run(_is_warm, workers=unknown).items() if warm)
    rec.paid("query", t0)
    return threads, [a for a in threads if a in rec.warm]


def _noop() -> None:
    return None


def round_trip(scheduler: Any) -> float:
    """Seconds to submit an empty task to the cluster and collect its result (best of three, measured once per
    address and process): the scheduler's overhead per task."""
    rec = _cluster(scheduler)
    if rec.round_trip is None:
        warm = [a for a in rec.threads or {} if a in rec.warm]
        if not warm:  # a cold worker answers late (it imports pkmstiff): not a measurement of the scheduler
            return ROUND_TRIP_SECONDS
        c, best = client(scheduler), float("inf")
        t0 = time.perf_counter()
        for _ in range(3):
            t = time.perf_counter()
            c.submit(_noop, pure=False, workers=warm, allow_other_workers=False).result()
            best = min(best, time.perf_counter() - t)
        rec.paid("round trips", t0)
        rec.round_trip = best
    return rec.round_trip


def _register_preload(scheduler: Any) -> None:
    """Register :class:`PreloadPlugin` once per cluster (it then also warms workers that join later; on workers that
    are not warm yet this waits for their warm-up)."""
    rec = _cluster(scheduler)
    if not rec.registered:
        t0 = time.perf_counter()
        client(scheduler).register_plugin(_preload_plugin()())
        rec.registered = True
        rec.paid("plugin", t0)


def _warm_in_background(scheduler: Any, cold: Sequence[str]) -> None:
    """One warm-up task of the lowest CPU priority per cold worker, not waited for: on a host shared with this
    process (a local cluster) it does not slow down the work that stays here."""
    from distributed import fire_and_forget

    c = client(scheduler)
    for addr in cold:
        fire_and_forget(c.submit(_warm_up_quietly, workers=[addr], allow_other_workers=False, pure=False,
                                 key=f"{_WARM_UP_KEY}-{addr}-{time.time_ns()}"))


_WARM_UP_KEY = "pkmstiff-warm-up"


def _warm_up_quietly() -> None:
    """:func:`warm_up` in a thread of nice 19 (Linux gives each thread its own nice value; elsewhere at the
    worker's priority): imports and compiled kernels are the process's, so the worker is warm afterwards."""

    def run() -> None:
        try:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 19)
        except (AttributeError, OSError):  # pragma: no cover - not Linux
            pass
        warm_up()

    t = threading.Thread(target=run, name="pkmstiff-warm-up")
    t.start()
    t.join()


def _dask_plan(items: int, item_seconds: float, scheduler: Any, granule: int) -> Plan:
    """The plan on a Dask cluster (the model is :func:`_on_dask_seconds`'s). The work stays here unless the cluster,
    with this process working beside it, finishes it sooner, fixed costs included; the text says why, with the round
    trip and the fixed costs measured. Without connecting, work stays here when what this process knows already says
    so: before it has measured the cluster, work shorter than the fixed costs of a first connection
    (:data:`DASK_FIXED_SECONDS`, plus :data:`DASK_IMPORT_SECONDS` if dask.distributed is not imported yet) plus one
    task (no number of workers could finish it sooner); afterwards, while all its workers were warm at the last look,
    work that the measured cluster would not finish sooner."""
    work = items * max(item_seconds, 0.0)
    address = _address(scheduler)
    rec = _CLUSTERS.get(address)

    def here(why: str, note: str = "") -> Plan:
        return Plan(items, 1, min(items, 1), items, item_seconds, f"serial: {why}", note)

    if not items:
        return here("no work")
    if rec is None or rec.threads is None:
        fixed = DASK_FIXED_SECONDS + (DASK_IMPORT_SECONDS if "distributed" not in sys.modules else 0.0)
        if work < fixed + MIN_TASK_SECONDS or work < 2 * MIN_TASK_SECONDS:
            return here(f"here ≈ {work:.2f} s, less than a Dask task of ≥ {MIN_TASK_SECONDS:.1f} s plus the fixed "
                        f"costs of a first connection (≈ {fixed:.2f} s); not connected to {address}")
    elif len(rec.warm) == len(rec.threads):
        rtt = rec.round_trip if rec.round_trip is not None else ROUND_TRIP_SECONDS
        best = _on_dask_seconds(items, item_seconds, granule, rec.threads, list(rec.threads), rtt, rec.registered)
        if best is None or best[0] >= work:
            on_dask = "too little for two tasks" if best is None else f"≈ {best[0]:.2f} s"
            return here(f"here ≈ {work:.2f} s, on Dask {on_dask} as measured before by this process; not connected "
                        f"to {address}", f"{rtt * 1e3:.0f} ms per task measured, {rec.text()}")
    rec = _cluster(scheduler)
    rec.threads, warm = _dask_workers(scheduler)
    rtt = round_trip(scheduler)
    least = max(MIN_TASK_SECONDS, DASK_OVERHEAD_FACTOR * rtt)
    cold = [a for a in rec.threads if a not in warm]
    best = _on_dask_seconds(items, item_seconds, granule, rec.threads, warm, rtt, rec.registered)

    def note() -> str:
        return f"{rtt * 1e3:.0f} ms per task measured, {rec.text()}"

    if best is None or best[0] >= work:
        if cold:
            _warm_in_background(scheduler, cold)
        if best is None:
            return here(f"here ≈ {work:.2f} s, too little for two Dask tasks of ≥ {least:.2f} s", note())
        if not warm:
            return here(f"the Dask workers are still cold (they warm up in the background for the next run): here "
                        f"≈ {work:.2f} s, on Dask ≈ {best[0]:.2f} s with their warm-up", note())
        return here(f"here ≈ {work:.2f} s, on Dask ≈ {best[0]:.2f} s with this process working beside it", note())
    t, use, size, tasks = best
    if len(use) == len(rec.threads):
        _register_preload(scheduler)  # waits until every worker is warm (warm ones answer at once)
        rec.warm.update(use)
        rec.use = None
    else:
        _warm_in_background(scheduler, cold)
        rec.use = list(use)
    k = sum(rec.threads[a] for a in use)
    return Plan(items, k, tasks, size * granule, item_seconds, f"Dask ({k} workers at {address}) and this process",
                f"≈ {t:.2f} s there against ≈ {work:.2f} s here, {note()}")


def _on_dask_seconds(items: int, item_seconds: float, granule: int, threads: dict[str, int], warm: Sequence[str],
                     rtt: float, registered: bool) -> tuple[float, list[str], int, int] | None:
    """(seconds, workers used, granules per task, tasks) of the quickest way to run the work on the cluster, None if
    it makes fewer than two tasks. This process works beside the cluster (:func:`run_tasks`), so ``k`` worker threads
    finish ``tasks`` tasks of ``s`` seconds in about ``F + ⌈tasks / (k + 1)⌉ (s + r)`` seconds: ``r`` the round trip
    of an empty task, ``F`` the fixed costs still to pay (registering the plugin, :data:`DASK_PLUGIN_SECONDS`; the
    warm-up of cold workers, :data:`COLD_WORKER_SECONDS`, if they are waited for; those already paid do not count);
    tasks last ≥ :data:`MIN_TASK_SECONDS` and ≥ :data:`DASK_OVERHEAD_FACTOR` round trips. The ways: the warm workers
    now (the cold ones warm up in the background), or all once warm."""
    least = max(MIN_TASK_SECONDS, DASK_OVERHEAD_FACTOR * rtt)
    plugin = 0.0 if registered else DASK_PLUGIN_SECONDS
    options = [(list(warm), plugin)]
    if len(warm) < len(threads):
        options.append((list(threads), plugin + COLD_WORKER_SECONDS))
    best = None
    for use, fixed in options:
        k = sum(threads[a] for a in use)
        size, tasks = _task_size(items, item_seconds, granule, k + 1, least) if k else (0, 0)
        if tasks >= 2:
            t = fixed + math.ceil(tasks / (k + 1)) * (size * granule * item_seconds + rtt)
            if best is None or t < best[0]:
                best = (t, use, size, tasks)
    return best


def _preload_plugin() -> type:
    """The class :class:`PreloadPlugin`, a ``distributed`` ``WorkerPlugin`` made at the first use: importing
    dask.distributed costs 0.3–0.9 s, which a command that does not use a cluster should not pay."""
    global _PLUGIN
    if _PLUGIN is None:
        from distributed.diagnostics.plugin import WorkerPlugin

        class PreloadPlugin(WorkerPlugin):
            """Dask worker plugin: :func:`warm_up` once per worker (machines are then kept per worker by
            :class:`Shared`)."""

            name = "pkmstiff-preload"

            def setup(self, worker: Any) -> None:
                warm_up()

        PreloadPlugin.__module__, PreloadPlugin.__qualname__ = __name__, "PreloadPlugin"  # pickled by this name
        _PLUGIN = PreloadPlugin
    return _PLUGIN


_PLUGIN: type | None = None


def __getattr__(name: str) -> Any:
    if name == "PreloadPlugin":
        return _preload_plugin()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
              meanwhile: Callable[[], None] | None = None, meanwhile_last: bool = False) -> list[T]:
    """``[fn(*args) for args in payloads]`` in order: in this process (serial plan), in the local pool or on the Dask
    cluster, this process taking tasks too (:func:`_run_on_dask`). ``progress(k)`` is called after each finished task
    (any order) with the number finished. ``meanwhile()`` runs in this process once the tasks are submitted (first,
    for a serial plan): work of its own that would otherwise make the workers wait. With ``meanwhile_last`` (local
    pool) it runs once every task has started (as many are left as there are workers): this process's work then
    shares the cores with the workers' last tasks, and all end together instead of a worker idling while the other
    finishes its last task. ``fn`` must be a pure function of its arguments: on Dask a task may run twice (here and
    on a worker), either result is taken."""
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
        return _run_on_dask(fn, payloads, p, scheduler, progress, meanwhile)
    futures = [submit(p.workers, fn, *args) for args in payloads]
    if not meanwhile_last:
        _meanwhile(meanwhile)
    if progress or meanwhile_last:
        from concurrent.futures import as_completed

        started = len(futures) - p.workers  # once this many have finished, every task has started
        if meanwhile_last and started <= 0:
            _meanwhile(meanwhile)
        for k, _ in enumerate(as_completed(futures), 1):
            if progress:
                progress(k)
            if meanwhile_last and k == started:
                _meanwhile(meanwhile)
    return [result(f, p.workers) for f in futures]


def submit(workers: int, fn: Callable[..., T], *args: Any) -> Future:
    """``fn(*args)`` as one task in the local pool of ``workers`` workers, not waited for (a command that schedules
    tasks of its own, such as a report's whole evaluations and figures); collect it with :func:`result`."""
    try:
        return pool(workers).submit(result_files.call, result_files.directory(), fn, *args)
    except BrokenProcessPool as exc:
        _POOLS.pop(workers, None)
        raise ResourceError(f"local worker pool broke: {exc}") from None


def result(future: Future, workers: int) -> Any:
    """The result of a task of :func:`submit` (its exception raised here; a dead worker as one line)."""
    try:
        return result_files.restore(future.result())
    except BrokenProcessPool as exc:
        _POOLS.pop(workers, None)
        raise ResourceError(f"a local worker died ({exc}); rerun with fewer --jobs or a larger memory budget") from None


@contextmanager
def meanwhile_work(clock: Callable[[], float] = time.thread_time) -> Iterator[None]:
    """Count the CPU time of the enclosed work (by ``clock``; default this thread's only, so the pool's own threads
    are not counted) as work done here while the workers run (:func:`meanwhile_cpu_seconds`)."""
    c0 = clock()
    try:
        yield
    finally:
        _MEANWHILE_CPU[0] += clock() - c0


def _meanwhile(meanwhile: Callable[[], None] | None) -> None:
    if meanwhile is not None:
        with meanwhile_work():
            meanwhile()


#: a task on Dask that has run this many times its estimated length (plus a round trip) is taken over by this process
LATE_FACTOR = 2.0


def _run_on_dask(fn: Callable[..., T], payloads: Sequence[tuple], p: Plan, scheduler: Any,
                 progress: Callable[[int], None] | None, meanwhile: Callable[[], None] | None) -> list[T]:
    """The tasks on the cluster and in this process at once: the cluster's workers take tasks from the front (one per
    worker thread in flight, the next sent when one finishes), this process from the back; when none is left to
    start, this process takes over a task that has run :data:`LATE_FACTOR` times its estimated length (a slow or
    lost worker) or that failed there (it then raises the task's error itself). So the run never takes much longer
    than this process alone would. Results in task order, whoever computed them (``fn`` is pure)."""
    c, rec = client(scheduler), _cluster(scheduler)
    where = {"workers": rec.use, "allow_other_workers": False} if rec.use else {}
    n = len(payloads)
    out: list[Any] = [None] * n
    done = [False] * n
    running: dict[int, tuple[Any, float]] = {}  # task -> (future, time sent)
    left = [0, n]  # tasks [front, back) not started anywhere
    lock = threading.Condition()
    late = LATE_FACTOR * p.task_items * p.item_seconds + (rec.round_trip or 0.0)

    def send() -> None:  # under the lock
        if left[0] < left[1]:
            i = left[0]
            left[0] += 1
            f = c.submit(fn, *payloads[i], pure=False, **where)
            running[i] = (f, time.monotonic())
            f.add_done_callback(lambda f, i=i: finished(i, f))

    def finished(i: int, f: Any) -> None:  # in a thread of the client
        try:
            value, ok = (f.result(), True) if f.status == "finished" else (None, False)
        except Exception:  # noqa: BLE001 - a result lost on its way here: this process computes the task
            value, ok = None, False
        with lock:
            running.pop(i, None)
            if ok and not done[i]:
                out[i], done[i] = value, True
            if f.status != "cancelled":
                send()
            lock.notify_all()

    try:
        with lock:
            for _ in range(max(p.workers, 1)):
                send()
        _meanwhile(meanwhile)
        reported = 0
        while True:
            with lock:
                i = None
                while i is None:
                    if left[0] < left[1]:
                        left[1] -= 1
                        i = left[1]
                        break
                    todo = [j for j in range(n) if not done[j]]
                    if not todo:
                        break
                    now = time.monotonic()
                    lost = [j for j in todo if j not in running]  # failed on the cluster
                    over = [j for j in todo if j in running and now - running[j][1] > late]
                    if lost or over:
                        i = (lost or over)[0]
                        break
                    wait = min(running[j][1] + late - now for j in todo)
                    count = sum(done)
                    if progress and count > reported:
                        break
                    lock.wait(timeout=max(wait, 1e-3))
                count = sum(done)
            if progress and count > reported:
                reported = count
                progress(count)
            if i is None:
                if count == n:
                    return out
                continue
            value = fn(*payloads[i])
            with lock:
                if not done[i]:
                    out[i], done[i] = value, True
                f = running.pop(i, (None, 0.0))[0]
            if f is not None:
                f.cancel()
    finally:
        with lock:
            pending = [f for f, _ in running.values()]
            left[0] = left[1]  # nothing more is sent
        for f in pending:
            f.cancel()


__all__ = [
    "DASK_OVERHEAD_FACTOR",
    "MIN_LOCAL_TASK_SECONDS",
    "MIN_TASK_SECONDS",
    "TASKS_PER_WORKER",
    "Plan",
    "PreloadPlugin",
    "Shared",
    "address",
    "client",
    "connected",
    "meanwhile_cpu_seconds",
    "meanwhile_work",
    "plan",
    "pool",
    "resolve_workers",
    "result",
    "round_trip",
    "run_tasks",
    "shutdown",
    "split",
    "start_workers",
    "submit",
    "worker_pids",
]
