"""The friction's lag signed by the controller's planned joints (`twin.sim.online`): a measured joint that shakes
about a steady planned motion no longer turns the correction back and forth; each interface passes the planned
joints it reports (RSI's `ASPos`, EGM's `planned.joints`), and one not finite is rejected like a bad axis."""

from __future__ import annotations

import numpy as np
import pytest
from test_online_rsi import parse_rkorr

from twin.apps.export.krl_rsi import ETHERNET
from twin.apps.online.cycle import ServedCycle
from twin.apps.online.egm import egm_messages, read_planned
from twin.apps.online.rsi import parse_rob
from twin.errors import InputError
from twin.robot.description import load_robot
from twin.sim.online import OnlineCompensator, OnlineSettings
from twin.sim.spec import TwinSpec

CYCLE_S = 0.004
F_N = np.array([300.0, -100.0, 1800.0])
SHAKE_RAD = 2e-5  # the measured joints' back-and-forth about the plan each cycle: 5 mrad/s, 25 x the tanh's width


def _joints(n: int, shake_rad: float = SHAKE_RAD) -> tuple[np.ndarray, np.ndarray]:
    """The planned joints of n cycles, joints 2, 3 and 5 (the ones with friction) moving steadily at 2 mrad/s, and
    the measured ones shaking about them by `shake_rad` each cycle [rad], each shape (n, dof)."""
    q0 = np.asarray(load_robot("tx200").q_home_rad, dtype=float)
    speed = np.array([0.0, 2e-3, -2e-3, 0.0, 2e-3, 0.0])
    planned = q0 + np.outer(CYCLE_S * np.arange(n), speed)
    return planned, planned + shake_rad * (-1.0) ** np.arange(n)[:, None]


def _corrections(planned_given: bool, shake_rad: float = SHAKE_RAD, n: int = 400) -> np.ndarray:
    """The correction each cycle [m] over `_joints`, the compensator given the plan or the measured joints alone."""
    comp = OnlineCompensator(TwinSpec(), OnlineSettings(max_rate_mm_s=1000.0))
    out = np.zeros((n, 3))
    for k, (q_plan, q_meas) in enumerate(zip(*_joints(n, shake_rad), strict=True)):
        comp.step(CYCLE_S * k, CYCLE_S * k, F_N, q_meas, q_plan if planned_given else None)
        out[k] = comp.correction_m
    return out


def test_a_shaking_measured_joint_does_not_turn_the_friction_term_when_the_plan_is_given() -> None:
    """With the plan: the correction moves by under 1 um from one cycle to the next (the Jacobian's drift along the
    motion); with the measured joints alone the friction's term flips each cycle and the correction swings by more
    than 0.1 mm every cycle."""
    planned, measured = _corrections(True)[-100:], _corrections(False)[-100:]
    assert np.abs(np.diff(planned, axis=0)).max() < 1e-6
    assert np.abs(np.diff(measured, axis=0)).max() > 1e-4


def test_the_planned_joints_friction_term_is_the_steady_motions() -> None:
    """Given the plan, the correction is the one of a robot that follows the plan without shaking (the Jacobian at
    the measured joints moves it by far less than a micrometre)."""
    np.testing.assert_allclose(_corrections(True)[-1], _corrections(False, shake_rad=0.0)[-1], atol=1e-6)


def test_rsi_reads_the_set_point_axes_and_names_a_bad_one() -> None:
    packet = ('<Rob Type="KUKA"><AIPos A1="1" A2="2" A3="3" A4="4" A5="5" A6="6"/>'
              '<ASPos A1="1.5" A2="2" A3="3" A4="4" A5="5" A6="6.5"/><IPOC>9</IPOC></Rob>')
    rob = parse_rob(packet.encode(), 6)
    assert rob.axes_deg == (1.0, 2.0, 3.0, 4.0, 5.0, 6.0) and rob.planned_deg == (1.5, 2.0, 3.0, 4.0, 5.0, 6.5)
    assert parse_rob(packet.replace('<ASPos A1="1.5" A2="2" A3="3" A4="4" A5="5" A6="6.5"/>', "").encode(),
                     6).planned_deg is None
    with pytest.raises(InputError, match=r"ASPos needs A1\.\.A6"):
        parse_rob(packet.replace('A6="6.5"', 'A6="x"').encode(), 6)
    assert '<ELEMENT TAG="DEF_ASPos" TYPE="DOUBLE" INDX="INTERNAL" />' in ETHERNET  # the context sends them


def test_egm_reads_the_planned_joints_where_the_message_has_them() -> None:
    pb = egm_messages()
    msg, planned = pb.EgmRobot(), np.zeros(6)
    assert read_planned(msg, planned) is None
    msg.planned.joints.joints.extend([1.0, 2.0, 3.0])
    assert read_planned(msg, planned) is None  # fewer than the robot's
    msg.planned.joints.joints.extend([4.0, 5.0, 6.0])
    np.testing.assert_array_equal(read_planned(msg, planned), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0])


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_planned_axes_not_finite_are_rejected_and_the_correction_held(bad: float) -> None:
    spec = TwinSpec()
    robot = load_robot("tx200")
    cycle = ServedCycle(OnlineCompensator(spec), robot, spec.build().R_base_sheet)
    axes = np.degrees(np.asarray(robot.q_home_rad))
    for k in range(50):
        cycle.put_force(*F_N, CYCLE_S * k)
        before = cycle.step(CYCLE_S * k, axes, axes).copy()
    cycle.put_force(*F_N, CYCLE_S * 50)
    planned = axes.copy()
    planned[2] = bad
    np.testing.assert_array_equal(cycle.step(CYCLE_S * 50, axes, planned), before)
    assert cycle.rejected == 1


def test_the_rsi_server_signs_the_friction_by_the_packets_set_points() -> None:
    """A fake KUKA on 127.0.0.1 sends shaking actual axes (`AIPos`) and steady set-points (`ASPos`): the server's
    last `RKorr` is a direct compensator's given both, not one given the actual axes alone."""
    import socket
    import threading

    from twin.apps.online.rsi import RsiServer

    spec = TwinSpec()
    twin = spec.build()
    robot = twin.robot
    server = RsiServer(OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=1000.0)), robot)
    report: dict[str, object] = {}
    n = 120
    thread = threading.Thread(target=lambda: report.setdefault("r", server.serve(twin.R_base_sheet, n, 2.0)))
    thread.start()
    planned, measured = _joints(n)

    def axes(tag: str, q: np.ndarray) -> str:
        a = np.degrees(robot.controller_angles(q))  # 10 decimals: the server reads back q within 1e-12 rad
        return f"<{tag} " + " ".join(f'A{i + 1}="{v:.10f}"' for i, v in enumerate(a)) + "/>"

    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.settimeout(0.5)
    try:
        for k in range(n):  # bounded: n packets, each answered or timed out
            packet = (f'<Rob Type="KUKA">{axes("AIPos", measured[k])}{axes("ASPos", planned[k])}'
                      f'<FT Fx="{F_N[0]}" Fy="{F_N[1]}" Fz="{F_N[2]}"/><IPOC>{4 * k}</IPOC></Rob>')
            client.sendto(packet.encode(), ("127.0.0.1", server.port))
            answer = client.recvfrom(4096)[0]
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    got_mm = parse_rkorr(answer)
    both, alone = (OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=1000.0)) for _ in range(2))
    for k in range(n):
        both.step(CYCLE_S * k, CYCLE_S * k, F_N, measured[k], planned[k])
        alone.step(CYCLE_S * k, CYCLE_S * k, F_N, measured[k])
    assert report["r"].cycles == n  # type: ignore[attr-defined]
    np.testing.assert_allclose(got_mm, 1e3 * twin.R_base_sheet @ both.correction_m, atol=2e-3)
    assert np.linalg.norm(got_mm - 1e3 * twin.R_base_sheet @ alone.correction_m) > 0.05
