"""`make test`'s warm-up (twin/apps/warm.py) reaches the kernels it is there to compile: if a default changed so
that its replay ran the Python loop, or its cycle another path, the suite would compile them in every worker again."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

import twin.sim.compiled as compiled
import twin.sim.online as online
from twin.apps import warm


def test_the_warm_up_jobs_call_the_replay_loop_and_the_online_cycle(monkeypatch: pytest.MonkeyPatch) -> None:
    called: list[str] = []

    def counted(name: str, kernel: Callable[..., Any]) -> Callable[..., Any]:
        def call(*args: Any) -> Any:
            called.append(name)
            return kernel(*args)
        return call

    for module, name in ((compiled, "replay_loop"), (online, "online_cycle")):
        monkeypatch.setattr(module, name, counted(name, getattr(module, name)))
    assert warm._replay() == "replay loop" and "replay_loop" in called
    assert warm._online() == "online cycle" and "online_cycle" in called
    assert warm._others() == "rigid drives and plant sheets"
