"""The online compensator's real-time figures for `make bench`: per-cycle compute, and the round trip of KUKA
RSI and ABB EGM on loopback at a 4 ms cycle (issue #39's targets: compute p99 <= 0.1 ms, round trip p99 <= 1 ms, no missed
cycle). Measured figures of this machine, not timed tests.
"""

from __future__ import annotations

import socket
import threading
import time
from typing import Any

import numpy as np

from twin.apps.online.rsi import RsiServer
from twin.sim.online import OnlineCompensator
from twin.sim.spec import TwinSpec

CYCLE_S = 0.004
_ROB = ('<Rob Type="KUKA"><AIPos A1="{a[0]:.4f}" A2="{a[1]:.4f}" A3="{a[2]:.4f}" A4="{a[3]:.4f}" A5="{a[4]:.4f}" '
        'A6="{a[5]:.4f}"/><FT Fx="{f[0]:.3f}" Fy="{f[1]:.3f}" Fz="{f[2]:.3f}"/><IPOC>{ipoc}</IPOC></Rob>')


def _percentiles(values_s: np.ndarray) -> dict[str, float]:
    us = 1e6 * np.asarray(values_s)
    return {"p50_us": float(np.percentile(us, 50)), "p99_us": float(np.percentile(us, 99)), "max_us": float(us.max())}


def compensator_compute(cycles: int = 15000) -> dict[str, float]:
    """`OnlineCompensator.step` timed alone, `cycles` cycles of a groove-sized force at home (first call compiled
    before)."""
    spec = TwinSpec()
    comp = OnlineCompensator(spec)
    q = np.array(spec.robot.q_home_rad)
    f = np.array([300.0, -100.0, 1800.0])
    comp.step(0.0, 0.0, f, q)
    times = np.zeros(cycles)
    for k in range(cycles):
        start = time.perf_counter()
        comp.step(CYCLE_S * k, CYCLE_S * k, f, q)
        times[k] = time.perf_counter() - start
    return {"cycles": float(cycles), **_percentiles(times)}


def _egm_message(k: int, axes_deg: np.ndarray, force_n: tuple[float, float, float]) -> bytes:
    """An `EgmRobot` as a controller sends it: header, feedback joints, planned pose moving 20 mm/s along x, the
    measured force."""
    from twin.apps.online.egm import egm_messages

    pb = egm_messages()
    msg = pb.EgmRobot()
    msg.header.seqno, msg.header.tm = k, 4 * k
    msg.feedBack.joints.joints.extend(axes_deg.tolist())
    cart = msg.planned.cartesian
    cart.pos.x, cart.pos.y, cart.pos.z = 1600.0 + 0.08 * k, 0.0, 500.0
    cart.orient.u0, cart.orient.u1, cart.orient.u2, cart.orient.u3 = 0.0, 0.0, 1.0, 0.0
    msg.measuredForce.force.extend([*force_n, 0.0, 0.0, 0.0])
    return msg.SerializeToString()


def _rob_packet(k: int, axes_deg: np.ndarray, force_n: tuple[float, float, float]) -> bytes:
    return _ROB.format(a=axes_deg, f=force_n, ipoc=4 * k).encode()


def loopback(interface: str = "rsi", cycles: int = 2500) -> dict[str, Any]:
    """A client plays the robot at a 4 ms cycle over 127.0.0.1 against the server of `interface` ("rsi": KUKA
    RSI's XML, "egm": ABB EGM's protobuf): round trip, the server's compute per cycle, late answers (round trip
    over the cycle) and lost ones (none within 2 cycles). Client and server share one process (and its GIL), as
    they would not in a cell: the figures are an upper bound."""
    from twin.apps.online.egm import EgmServer

    spec = TwinSpec()
    twin = spec.build()
    server = (EgmServer if interface == "egm" else RsiServer)(OnlineCompensator(spec), twin.robot)
    make = _egm_message if interface == "egm" else _rob_packet
    served: dict[str, Any] = {}
    thread = threading.Thread(target=lambda: served.setdefault("r", server.serve(twin.R_base_sheet, cycles, 2.0)))
    thread.start()
    axes = np.degrees(twin.robot.controller_angles(np.array(twin.robot.q_home_rad)))
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.settimeout(2 * CYCLE_S)
    trips, lost = [], 0
    try:
        start = time.perf_counter()
        for k in range(cycles):
            packet = make(k, axes, (300.0, -100.0, 1800.0 * min(1.0, k / 250)))
            sent = time.perf_counter()
            client.sendto(packet, ("127.0.0.1", server.port))
            try:
                client.recvfrom(4096)
                trips.append(time.perf_counter() - sent)
            except TimeoutError:
                lost += 1
            time.sleep(max(0.0, start + CYCLE_S * (k + 1) - time.perf_counter()))
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    trip = np.array(trips)
    return {"cycles": cycles, "seconds": cycles * CYCLE_S, "round_trip": _percentiles(trip),
            "late": int(np.sum(trip > CYCLE_S)), "lost": lost,
            "server_compute": _percentiles(1e-6 * served["r"].compute_us) if "r" in served else {}}


def online_benchmarks(smoke: bool = False) -> dict[str, Any]:
    """Both figures (a smoke run: a few hundred cycles)."""
    return {"online_compute": compensator_compute(300 if smoke else 15000),
            "online_rsi_loopback": loopback("rsi", 100 if smoke else 15000),
            "online_egm_loopback": loopback("egm", 100 if smoke else 15000)}
