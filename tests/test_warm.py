"""`make test`'s warm-up (twin/apps/warm.py) reaches the kernels it is there to compile: if a default changed so
that a job ran a Python loop instead, the suite would compile those kernels in every worker again."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

import twin.lab.dynamic.sheet_kernels as plant_law_1
import twin.lab.dynamic.sheet_patch_kernels as plant_law_2
import twin.sim.compiled as compiled
import twin.sim.compiled.rigid as rigid
import twin.sim.online as online
from twin.apps import warm


def test_each_warm_up_job_calls_the_kernels_it_is_there_to_compile(monkeypatch: pytest.MonkeyPatch) -> None:
    called: list[str] = []

    def counted(name: str, kernel: Callable[..., Any]) -> Callable[..., Any]:
        def call(*args: Any) -> Any:
            called.append(name)
            return kernel(*args)
        return call

    jobs = {
        warm._replay: ((compiled, "replay_loop"),),
        warm._isf: ((rigid, "isf_rigid_loop"),),
        warm._table: ((rigid, "table_rigid_loop"),),
        warm._online: ((online, "online_cycle"),),
        warm._sheets: ((plant_law_1, "force"), (plant_law_1, "fill"), (plant_law_2, "force")),
    }
    for module, name in (kernel for kernels in jobs.values() for kernel in kernels):
        monkeypatch.setattr(module, name, counted(f"{module.__name__}.{name}", getattr(module, name)))
    for job, kernels in jobs.items():
        called.clear()
        job()
        assert set(called) == {f"{module.__name__}.{name}" for module, name in kernels}, job.__name__
