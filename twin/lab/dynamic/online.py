"""Online correction in the plant's controller: the corrector it calls each cycle (`CycleCorrector`, e.g. the
twin's `OnlineCompensator`), the cycle that turns its Cartesian correction into joint offsets (`OnlineCycle`), its
log (`OnlineLog`), and the plant's F/T sensor as the controller sees it during the run (`OnlineFt`).

The F/T sensor online: the newest sample, one at a time.

The same chain as the recorded stream (`sensors.ft_reading`: its clock offset, skew and latency; the tool's
weight tared; the sign flipped to the sheet's force on the tool; cross-talk, bias, white noise, quantisation; the
sensor's orientation into the sheet frame), evaluated causally: at tick k only the physical log before k exists,
and a sample is drawn once, when its stamp comes. Its noise comes from its own generator (seeded by the caller), so
the recorded `forces.csv` stays what it is without an online corrector.
"""

from __future__ import annotations

import math
import time
from typing import NamedTuple, Protocol

import numpy as np

from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.sensors import ft_chain, physical_times
from twin.robot.kinematics import Kinematics


class OnlineFt:
    """The newest F/T sample at any tick (`sample`).

    Args:
        knobs: The plant's sensor knobs (`ft_rate_hz`, `ft_latency_s`, clock, bias, noise, quantum, cross-talk).
        rng: The generator of its noise.
        tool_mass_kg: The tool's mass (its weight is tared).
        R_world_sheet: The sheet's axes in the world.
        dt: The servo tick [s].
    """

    def __init__(self, knobs: Knobs, rng: np.random.Generator, tool_mass_kg: float, R_world_sheet: np.ndarray,
                 dt: float) -> None:
        self.knobs, self.rate, self.tool_mass_kg = knobs, knobs["ft_rate_hz"], tool_mass_kg
        self.R_world_sheet = np.asarray(R_world_sheet, dtype=float)
        self.rng, self.dt = rng, dt
        self.index, self.stamp, self.value = -1, math.nan, np.full(3, math.nan)

    def sample(self, t_s: float, k: int, ft_log: np.ndarray, R_log: np.ndarray) -> tuple[float, np.ndarray]:
        """(stamp [s], force of the sheet on the tool, sheet frame [N]) of the newest sample at tick k, time t_s,
        from the ticks logged before k (MuJoCo's F/T reading and the sensor's orientation, flattened); (NaN, NaN)
        before the first one whose state exists."""
        index = math.floor(t_s * self.rate + 1e-9)
        if index == self.index:
            return self.stamp, self.value
        stamp = index / self.rate
        knobs = self.knobs
        t_phys = float(physical_times(np.asarray(stamp), latency_s=knobs["ft_latency_s"],
                                      offset_s=knobs["ft_clock_offset_s"], skew_ppm=knobs["ft_clock_skew_ppm"]))
        x = min(t_phys / self.dt, k - 1.0)  # only the ticks logged so far
        if x < 0.0:
            return self.stamp, self.value
        i0 = math.floor(x)
        i1, w = min(i0 + 1, k - 1), x - i0
        reading = (1.0 - w) * ft_log[i0:i0 + 1] + w * ft_log[i1:i1 + 1]
        R = ((1.0 - w) * R_log[i0] + w * R_log[i1]).reshape(1, 3, 3)
        noise = self.rng.normal(0.0, knobs["ft_noise_n"], (1, 3))
        force = ft_chain(reading, R, noise, knobs, self.tool_mass_kg, self.R_world_sheet)[0]
        self.index, self.stamp, self.value = index, stamp, force
        return self.stamp, self.value


class CycleCorrector(Protocol):
    """What the controller calls each cycle when it compensates online (the twin's `OnlineCompensator`, or any
    other): the newest F/T sample, the motor angles and the controller's own set-points in (as a real controller's
    interface reports them), a Cartesian correction of the tool tip out."""

    cycle_s: float
    correction_m: np.ndarray  # the last cycle's correction, sheet frame [m], shape (3,)

    def step(self, t_s: float, sample_t_s: float, f_sheet_n: np.ndarray, q_rad: np.ndarray,
             q_planned_rad: np.ndarray | None = None) -> int:
        """One cycle (q_rad: the motor angles; q_planned_rad: the controller's set-points, as RSI's `ASPos` and EGM's
        `planned.joints` report them); returns a status code."""
        ...


class OnlineLog(NamedTuple):
    """What the online corrector did, each controller cycle.

    Attributes:
        t_s: Cycle times [s], shape (c,).
        correction_m: Its correction, sheet frame [m], shape (c, 3).
        compute_s: The wall time of its `step` [s], shape (c,).
        status: Its status code, shape (c,).
    """

    t_s: np.ndarray
    correction_m: np.ndarray
    compute_s: np.ndarray
    status: np.ndarray


class OnlineCycle:
    """The controller's online correction: every `every` ticks the corrector's cycle, its Cartesian correction
    turned into joint offsets by the controller's rigid model, dq = J(q_sp)^-1 [R_ws c; 0] (orientation held).

    The controller takes a correction every `correction_period_ms` (knob; held in between) and, with
    `correction_along_path` 0, drops its part along the path (the direction of the set-points' motion, the last
    one kept while they stand): ABB's EGM path correction reads the sensor at multiples of 24 ms and applies only
    y and z of the path frame ("nor corrections in x (which is the path direction)", EGM application manual
    3HAC073318 rev. K, EGMActMove); RSI's IPO_FAST and EGM's position guidance take every 4 ms, all axes."""

    def __init__(self, online: tuple[CycleCorrector, OnlineFt], kin: Kinematics, q_sp: np.ndarray,
                 R_ws: np.ndarray, dt: float, n_tick: int) -> None:
        self.corrector, self.ft = online
        self.every = max(1, round(self.corrector.cycle_s / dt))
        period = 1e-3 * self.ft.knobs["correction_period_ms"]
        self.hold = self.every * max(1, round(period / (self.every * dt)))  # ticks between corrections taken
        self.along_path = self.ft.knobs["correction_along_path"] == 1.0
        self.kin, self.q_sp, self.R_ws = kin, q_sp, R_ws
        count = (n_tick + self.every - 1) // self.every
        self.t, self.c, self.s = np.zeros(count), np.zeros((count, 3)), np.zeros(count)
        self.status = np.zeros(count, dtype=np.int64)
        self.twist = np.zeros(kin.jacobian(q_sp[0]).shape[0])  # [translation; rotation held at 0]
        self.held = np.zeros(q_sp.shape[1])
        self.direction = np.zeros(3)  # the path's direction, sheet frame

    def run(self, k: int, t: float, q_motor: np.ndarray, ft_log: np.ndarray, R_log: np.ndarray) -> np.ndarray:
        """The corrector's cycle at tick k; returns the joint offsets to hold until the next cycle [rad]."""
        stamp, f = self.ft.sample(t, k, ft_log, R_log)
        i = k // self.every
        start = time.perf_counter()
        self.status[i] = self.corrector.step(t, stamp, f, q_motor, self.q_sp[k])
        self.s[i] = time.perf_counter() - start
        self.t[i], self.c[i] = t, self.corrector.correction_m
        if k % self.hold:
            return self.held
        J = self.kin.jacobian(self.q_sp[k])
        correction = self.c[i]
        if not self.along_path:
            last = len(self.q_sp) - 1
            v = self.R_ws.T @ (J[:3] @ (self.q_sp[min(k + 1, last)] - self.q_sp[max(k - 1, 0)]))
            speed = float(np.linalg.norm(v))
            if speed > 1e-9:
                self.direction = v / speed
            correction = correction - float(correction @ self.direction) * self.direction
        self.twist[:3] = self.R_ws @ correction
        self.held = np.linalg.lstsq(J, self.twist, rcond=None)[0]  # a 6-joint arm's solve; a redundant one's least norm
        return self.held

    def log(self) -> OnlineLog:
        """What the corrector did, each cycle."""
        return OnlineLog(self.t, self.c, self.s, self.status)
