"""Checks the command line runs before any work: output paths, ``--jobs`` and the memory budget (with the cost line
printed before long work).

Every check raises a :class:`~pkmstiff.errors.ArgumentError` subclass with one line naming the option, what was expected
and what was found, so that a command fails in seconds instead of after the computation (issue 12, item 4).
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

from pkmstiff.errors import ArgumentError, ResourceError

#: default memory budget: this fraction of the available memory (MemAvailable), overridable with --memory-budget
DEFAULT_BUDGET_FRACTION = 0.5


# ------------------------------------------------------------------------------------------------------ outputs


def _nearest_existing(path: Path) -> Path:
    p = path
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def _check_parent_writable(path: Path, option: str) -> None:
    anc = _nearest_existing(path.parent if path.parent != Path("") else Path("."))
    if not anc.is_dir():
        raise ArgumentError(f"{option}: expected a path below a directory, found {str(path)!r} "
                              f"({str(anc)!r} is a file)")
    if not (os.access(anc, os.W_OK | os.X_OK) and _can_create_in(anc)):
        raise ArgumentError(f"{option}: expected a writable location, found {str(path)!r} "
                              f"({str(anc)!r} is not writable)")


def _can_create_in(directory: Path) -> bool:
    """Whether files can be created in ``directory`` beyond its permission bits (which say yes for root on /proc,
    /sys or a read-only mount): not a read-only mount, and a file system with storage (pseudo file systems such as
    proc and sysfs report no blocks). Nothing is created."""
    try:
        st = os.statvfs(directory)
    except OSError:
        return False
    return not st.f_flag & os.ST_RDONLY and st.f_blocks > 0


def _check_not_a_link_loop(p: Path, option: str) -> None:
    if os.path.islink(p) and not p.exists():
        raise ArgumentError(f"{option}: expected a directory or a new name, found {str(p)!r} (a symbolic link "
                              f"that leads nowhere or to itself)")


def check_output_dir(path: str | Path | None, option: str = "--out", force: bool = False,
                     names: tuple[str, ...] = ()) -> Path | None:
    """Check an output directory before the work: it must be a directory (or creatable) and writable; any of the
    files ``names`` that already exist there are overwritten only with ``--force``. Nothing is created."""
    if path is None:
        return None
    p = Path(path)
    if str(path).strip() == "":
        raise ArgumentError(f"{option}: expected a directory, found an empty path")
    _check_not_a_link_loop(p, option)
    if p.exists() and not p.is_dir():
        raise ArgumentError(f"{option}: expected a directory, found {str(p)!r} (an existing file)")
    if p.exists():
        if not (os.access(p, os.W_OK | os.X_OK) and _can_create_in(p)):
            raise ArgumentError(f"{option}: expected a writable directory, found {str(p)!r} (not writable)")
        clash = [n for n in names if (p / n).exists()]
        if clash and not force:
            raise ArgumentError(f"{option}: {str(p / clash[0])!r} exists ({len(clash)} output file(s) would be "
                                  f"overwritten); use --force or another directory")
    else:
        _check_parent_writable(p, option)
    return p


def check_output_file(path: str | Path | None, option: str = "--out", force: bool = False,
                      suffixes: tuple[str, ...] = ()) -> Path | None:
    """Check an output file before the work: not a directory, a known suffix, a writable parent, and not an existing
    file unless ``--force``. Nothing is created."""
    if path is None:
        return None
    p = Path(path)
    if str(path).strip() == "":
        raise ArgumentError(f"{option}: expected a file name, found an empty path")
    if p.is_dir():
        raise ArgumentError(f"{option}: expected a file name, found {str(p)!r} (a directory)")
    _check_not_a_link_loop(p, option)
    if suffixes and p.suffix.lower() not in suffixes:
        raise ArgumentError(f"{option}: expected a file name ending in {' or '.join(suffixes)}, found {str(p)!r}")
    if p.exists() and not force:
        raise ArgumentError(f"{option}: {str(p)!r} exists; use --force to overwrite it")
    _check_parent_writable(p, option)
    return p


# ---------------------------------------------------------------------------------------------------- --range


def old_range_form(command: str, option: str, found: str, axes: list[str], bounds: list[tuple[float, float]]) -> str:
    """The ``--range`` text in the one syntax (AXIS=LO:HI, ...) for an option given in an old form; prints one
    deprecation line on stderr naming the new form."""
    new = ",".join(f"{a}={lo:g}:{hi:g}" for a, (lo, hi) in zip(axes, bounds))
    print(f"pkmstiff {command}: note: {option} {found} is deprecated; write --range {new} "
          f"(one syntax AXIS=LO:HI for section, workspace and rotation-map)", file=sys.stderr)
    return new


# ------------------------------------------------------------------------------------------------ number options


def check_number(value: float | None, option: str, lo: float | None = None, hi: float | None = None, *,
                 lo_open: bool = False, unit: str = "") -> None:
    """A numeric option before any work: finite and in [lo, hi] (``lo`` excluded with ``lo_open``); None passes."""
    if value is None:
        return
    low_ok = lo is None or (value > lo if lo_open else value >= lo)
    if math.isfinite(value) and low_ok and (hi is None or value <= hi):
        return
    u = f" {unit}" if unit else ""
    if lo is not None and hi is not None:
        want = f"a number {'>' if lo_open else '>='} {lo:g} and <= {hi:g}{u}"
    elif lo is not None:
        want = f"a number {'>' if lo_open else '>='} {lo:g}{u}"
    else:
        want = f"a finite number <= {hi:g}{u}" if hi is not None else f"a finite number{u}"
    raise ArgumentError(f"{option}: expected {want}, found {value!r}")


# ------------------------------------------------------------------------------------------------------ --jobs


def check_jobs(jobs: int | None, option: str = "--jobs") -> int | None:
    """``--jobs``: a positive number of processes up to 4× the cores, or -1 (all cores); ``None`` passes."""
    if jobs is None:
        return None
    cores = os.cpu_count() or 1
    if jobs == -1 or 1 <= jobs <= 4 * cores:
        return jobs
    raise ArgumentError(f"{option}: expected -1 (all cores) or 1..{4 * cores} processes ({cores} cores here), "
                   f"found {jobs}")


def predicted_plan(items: int, seconds: float, jobs: int, scheduler: str | None, unit: str, granule: int = 1) -> str:
    """The parallel plan for the cost line, from the estimated ``seconds`` of ``items`` items (the run itself sizes its
    tasks from a measured first piece of work); with a ``scheduler`` it says why the work stays here if it does, and
    it connects (exit 2 if unreachable) before any work unless the estimate alone keeps the work here."""
    from pkmstiff.evaluation.parallel import connected, plan

    with connected(scheduler):
        p = plan(items, seconds / max(items, 1), jobs, scheduler, granule)
    return p.text(unit) if p.parallel or scheduler else "serial"


# ------------------------------------------------------------------------------------------------ memory budget


def available_memory() -> int:
    """Available memory in bytes (``MemAvailable`` of /proc/meminfo; else physical memory; else 4 GiB)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 4 << 30


def parse_budget(text: str | None) -> int:
    """``--memory-budget``: '2GB', '500 MB', '0.25' (a fraction of the available memory); None: the default."""
    if text is None:
        text = os.environ.get("PKMSTIFF_MEMORY_BUDGET") or None
    if text is None:
        return int(DEFAULT_BUDGET_FRACTION * available_memory())
    t = str(text).strip().upper().replace(" ", "").replace("IB", "B")
    units = {"KB": 1 << 10, "MB": 1 << 20, "GB": 1 << 30, "TB": 1 << 40, "B": 1}
    for suf, fac in units.items():
        if t.endswith(suf):
            try:
                val = float(t[: -len(suf)])
            except ValueError:
                break
            if 0 < val * fac < 1 << 60:  # finite and below an exabyte (inf/1e400 GB overflowed int())
                return int(val * fac)
            break
    else:
        try:
            frac = float(t)
        except ValueError:
            frac = -1.0
        if 0 < frac <= 1:  # (NaN fails both comparisons)
            return int(frac * available_memory())
    raise ArgumentError(option="--memory-budget", found=text,
                        expected="a size such as '2GB' or '500MB', or a fraction 0..1 of the available memory")


def human_bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(n) < 1024 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} TB"  # pragma: no cover


def human_seconds(s: float) -> str:
    if s < 10:
        return f"{s:.1f} s"
    if s < 120:
        return f"{s:.0f} s"
    if s < 7200:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h"


#: default time budget in CPU seconds (overridable with the environment variable PKMSTIFF_TIME_BUDGET, seconds): work
#: estimated beyond it is refused like work beyond the memory budget, since it would not end in a working day
DEFAULT_TIME_BUDGET_S = 24 * 3600.0


def time_budget() -> float:
    """The time budget (s): ``PKMSTIFF_TIME_BUDGET`` if set to a positive number, else :data:`DEFAULT_TIME_BUDGET_S`."""
    text = os.environ.get("PKMSTIFF_TIME_BUDGET", "")
    try:
        val = float(text)
    except ValueError:
        return DEFAULT_TIME_BUDGET_S
    return val if 0 < val < float("inf") else DEFAULT_TIME_BUDGET_S


def count_lines(path: str | Path) -> int:
    """Lines of a text file (newline bytes, read in 1 MiB blocks: a row count before the file is parsed); 0 when it
    cannot be read here (the reader then reports why)."""
    n = 0
    try:
        if not Path(path).is_file():
            return 0
        with open(path, "rb") as fh:
            while block := fh.read(1 << 20):
                n += block.count(b"\n")
    except OSError:
        return 0
    return n


def add_budget_argument(p) -> None:
    """The ``--memory-budget`` option of every command that estimates its cost before the work."""
    p.add_argument("--memory-budget", default=None, metavar="SIZE",
                   help="refuse above this memory estimate, e.g. 4GB or 0.8 (fraction of the available memory; "
                        f"default {DEFAULT_BUDGET_FRACTION:g})")


def announce(command: str, cost, budget: int, quiet: bool = False, plan: str | None = None) -> None:
    """Refuse a :class:`~pkmstiff.evaluation.cost.Cost` above the memory budget or the time budget (one line naming
    the option that sets the size, the estimate and the budget); otherwise print the cost line on stderr (ending with
    the parallel ``plan`` when given). The time is CPU time: a parallel run's wall time is about that divided by its
    workers (the plan says how many), a serial run's about that."""
    size = f"{cost.count:,.0f} {cost.unit}"
    opt = f"{cost.option}: " if cost.option else ""
    if cost.bytes > budget:
        raise ResourceError(f"{opt}{cost.what}: {size} need about {human_bytes(cost.bytes)}, more than the memory "
                             f"budget of {human_bytes(budget)}; {cost.advice}, or raise the budget "
                             f"(--memory-budget or PKMSTIFF_MEMORY_BUDGET)")
    limit = time_budget()
    if cost.seconds > limit:
        raise ResourceError(f"{opt}{cost.what}: {size} need about {human_seconds(cost.seconds)} of CPU time, more "
                             f"than the time budget of {human_seconds(limit)} (PKMSTIFF_TIME_BUDGET); {cost.advice}")
    if not quiet:
        print(f"pkmstiff {command}: {cost.what}: {size}, about {human_bytes(cost.bytes)} and "
              f"{human_seconds(cost.seconds)} of CPU{f'; {plan}' if plan else ''}", file=sys.stderr, flush=True)


def length_option(text: str | None, option: str) -> float | None:
    """A length with its unit (``10um``, ``0.01 mm``) -> m; None stays None."""
    from pkmstiff.errors import InputError
    from pkmstiff.units import parse_quantity

    if text is None:
        return None
    try:
        return float(parse_quantity(text, "m", positive=True))
    except InputError:
        raise ArgumentError(option=option, expected="a positive length with its unit, e.g. 10um or 0.01mm",
                            found=text) from None
