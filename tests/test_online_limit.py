"""A served session says when its correction sat at its size limit (`--max-correction-mm`): a cell whose arm bends
further than the limit lets the correction follow is told so, and a cell that stays inside it hears nothing. A fake
KUKA RSI robot on 127.0.0.1; bounded: a fixed count of packets, every socket closed."""

from __future__ import annotations

import numpy as np
from test_online_input import ROBOT, SPEC, _paced, _rob, _start, _udp

from twin.apps.online.rsi import RsiServer
from twin.apps.tasks.online import OnlineReport
from twin.sim.online import OnlineCompensator, OnlineSettings

PACKETS = 40


def _session(settings: OnlineSettings, force: tuple[float, float, float]) -> OnlineReport:
    server = RsiServer(OnlineCompensator(SPEC, settings), ROBOT)
    thread, report = _start(server, PACKETS, 0.5)
    robot = _udp()
    try:
        def send(k: int) -> bytes:
            robot.sendto(_rob(4 * k, force), ("127.0.0.1", server.port))
            return robot.recvfrom(4096)[0]

        _paced(send, PACKETS)
    finally:
        robot.close()
        thread.join(timeout=5.0)
        server.close()
    return OnlineReport("rsi", server.port, "UDP", report["r"], 2.0)


def test_a_correction_held_at_its_size_limit_is_counted_and_said() -> None:
    # a small limit a 2 kN press reaches after a few cycles of the rate limit (5 mm/s: 0.02 mm a cycle)
    session = _session(OnlineSettings(max_correction_mm=0.05, max_rate_mm_s=5.0), (0.0, 0.0, 2000.0))
    served = session.served
    assert served.cycles == PACKETS and served.limit_mm == 0.05
    assert 0 < served.at_limit < PACKETS, served.at_limit  # not from the first packet: the rate limit ramps it
    said = [line for line in session.lines() if "size limit" in line]
    assert len(said) == 1 and "0.05 mm" in said[0] and f"{served.at_limit} of the {PACKETS} cycles" in said[0], said
    assert session.record()["at_limit"] == served.at_limit and session.exit_code == 0


def test_a_correction_inside_its_limit_is_not_said_to_sit_at_it() -> None:
    session = _session(OnlineSettings(), (0.0, 0.0, 500.0))
    assert session.served.at_limit == 0 and session.served.limit_mm == OnlineSettings().max_correction_mm
    assert not any("size limit" in line for line in session.lines())
    assert np.isfinite(session.record()["limit_mm"]) and session.record()["at_limit"] == 0
