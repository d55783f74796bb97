"""Progress on stderr for long loops: a tqdm bar on a terminal, otherwise one plain line every
:data:`PROGRESS_INTERVAL_S` seconds (a log file or a CI console gets readable lines, not bar redraws)."""

from __future__ import annotations

import sys
import time
from typing import Callable, Iterable, Iterator, TypeVar

T = TypeVar("T")

#: seconds between two progress lines when stderr is not a terminal
PROGRESS_INTERVAL_S = 10.0


def progress(items: Iterable[T], enabled: bool, desc: str, unit: str, total: int | None = None) -> Iterable[T]:
    """``items`` with progress reporting (``total`` for an iterable without ``len``); ``enabled=False``: unchanged."""
    if not enabled:
        return items
    n = len(items) if total is None else total  # type: ignore[arg-type]
    if sys.stderr.isatty():
        from tqdm import tqdm

        return tqdm(items, total=n, desc=desc, unit=unit, leave=False)
    return _lines(items, n, desc, unit)


def _lines(items: Iterable[T], n: int, desc: str, unit: str) -> Iterator[T]:
    t0 = last = time.perf_counter()
    k = 0
    for k, item in enumerate(items):
        now = time.perf_counter()
        if now - last >= PROGRESS_INTERVAL_S:
            last = now
            print(f"{desc}: {100 * k / max(n, 1):.0f} % ({k}/{n} {unit}s), {now - t0:.0f} s", file=sys.stderr,
                  flush=True)
        yield item


def callback(total: int, enabled: bool, desc: str, unit: str) -> Callable[[int], None] | None:
    """The same reporting as :func:`progress` for work that finishes out of order (parallel tasks): call it with the
    number of finished items; None when disabled."""
    if not enabled or total == 0:
        return None
    it = iter(progress(range(total), True, desc, unit))
    done = 0

    def step(k: int) -> None:
        nonlocal done
        while done < k:
            next(it, None)
            done += 1
        if done == total:
            next(it, None)  # ends the bar

    return step
