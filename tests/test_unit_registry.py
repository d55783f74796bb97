"""The process's one pint registry (pkmstiff.units.ureg) when several threads ask for it first."""

from __future__ import annotations

import threading

from pkmstiff import units


def test_threads_asking_first_share_one_registry_and_convert(monkeypatch):
    """Eight threads released at once into the first call: one registry for all, and each thread's conversion of a
    unit of the field (N/µm, made of its registry's quantities) is right."""
    monkeypatch.setattr(units, "_UREG", [])
    units._si_factor.cache_clear()
    start = threading.Barrier(8)
    got: list[tuple[int, float]] = []

    def ask() -> None:
        start.wait()
        reg = units.ureg()
        got.append((id(reg), units.to_unit(1.0e6, "N/um")))  # 1e6 N/m = 1 N/µm

    threads = [threading.Thread(target=ask) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    units._si_factor.cache_clear()  # its factors belong to this test's registry
    assert len({r for r, _ in got}) == 1 and len(got) == 8
    assert all(abs(v - 1.0) < 1e-12 for _, v in got)  # one conversion factor: exact up to rounding
