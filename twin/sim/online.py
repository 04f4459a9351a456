"""The online compensator: each controller cycle, the F/T sample and the robot's joints in, a Cartesian correction
of the tool path out, from the twin's model of the robot.

A cell's F/T sensor measures the sheet's force as it happens; the twin knows what that force does to the tool tip:
the deflection C(q) F with C(q) = J(q) K_q^-1 J(q)^T, the translational Jacobian of the tool tip at the robot's
current joints and the twin's joint stiffness (a `learn`ed model's where given), plus constant compliances in series
(the tool's own bending, a clamping frame's give along the sheet's normal: `twin.sim.giving_frame`), and the lag of
its joint friction, -sum_j J_j tanh(qdot_j / w0) tau_f,j / K_j (each joint's Coulomb friction tau_f against its
motion, its speed from the joints of successive cycles: the controller's planned joints where its interface reports
them, KUKA RSI's `ASPos`, ABB EGM's `planned.joints`; else the measured ones). The planned motion is the one the
friction opposes on average and the one `learn` signs it by; a measured joint's speed also carries the arm's own
vibration and the correction's motion, and with w0 at 2e-4 rad/s a measured joint that barely moves turns the term's
sign back and forth (what the planned sign changed on the plant: CHANGELOG). The compensator commands the tip the other way and does what a real signal
needs:

* **filtering**: a first-order low-pass on the force (`filter_hz`), so sensor noise does not reach the motors;
* **latency**: the filtered force is predicted forward by the sensor's latency plus the sample's age, from its
  filtered rate of change (`latency_s`), and by half of how much longer than a cycle the controller holds each
  correction (`period_s`: ABB EGM's path correction takes one every 48 ms; `OnlineSettings.horizon_s`);
* **spikes**: a sample further than `spike_n` from the filtered force is rejected (counted), as a broken packet;
  `spike_run` such samples in a row are a real change of level (a contact), and the next one is taken;
* **the kind of contact**: across the planned travel (its direction taken over each 0.1 mm of the planned tip's
  motion) the correction is taken in proportion to the side force's share of Fz, in full from `side_share`: a
  one-sided wall (a cone's, a pyramid's) pushes the tool sideways with a share of Fz (docs/online.md has the
  plant's), a load; a groove's walls hold it from both sides, and their reaction to where the arm puts the tool is
  not one (correcting it closes a loop through the walls' stiffness);
* **turns**: where the planned travel turns by more than 45 deg (a pyramid's corner, a groove's reversal), the
  sheet's friction along the travel (its share of Fz followed between turns) is turned with it at once, ahead of
  the filtered force, which shows it only after the sensor's sample, latency and filter; at a corner (a turn by
  less than 135 deg) the wall's push across the travel too, which the next side's wall pushes across the new
  travel as the last one did across the old: the force fed there is the next side's steady one, not a push against
  the travel that built up toward the corner, the new wall's push fed as the tool moves into it, over its first
  0.5 mm (a groove's walls, at a reversal, stay where they are); what of the
  turn the filtered force has shown since is taken off, so nothing counts twice, and how much of it the cell's
  turns turned is learned from them (`OnlineSettings.feed_turns`). On top of an offline command, whose assumed
  force turns at the corner by position, the wall is not turned again;
* **limits**: the correction's size (`max_correction_mm`, default 5 mm) and its rate (`max_rate_mm_s`) per unit
  of the controller's time (`t_s`): no correction moves faster than the rate allows since the last call, however
  often it is called (a burst moves it by the rate times the time the burst spans; a stalled controller earns at
  most a few cycles' worth);
* **watchdog**: no correction before a first sample (no start without a sensor); a sample older than `stale_s`
  holds the last correction for `hold_s`, then ramps it out at the rate limit: never a jump.

Every cycle is one compiled call (`twin.sim.compiled.online.online_cycle`) on arrays allocated when the compensator
is built: no allocation per cycle, bounded work (two chain evaluations, the planned tip's and the measured
joints', a 3x3 product; on top of an offline command, a few segments' walk along it, at most
`twin.sim.compiled.progress.LOST_SEARCH` segments where the robot cut a detour of it short).
`OnlineCompensator.step` returns a view of its own correction array; the status of the cycle is one of `STATUS`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from twin.errors import InputError
from twin.robot.model import build_model
from twin.robot.tool_bending import bending_compliance_at
from twin.sim.compiled.chain import ChainArrays, chain_arrays
from twin.sim.compiled.online import (
    CORR,
    HOLDING,
    LOST,
    NO_SENSOR,
    RAMPING,
    SPIKE,
    SPIKES,
    STATE_SIZE,
    TRACKING,
    online_cycle,
)
from twin.sim.giving_frame import frame_compliance_m_per_n
from twin.sim.online_settings import OnlineSettings
from twin.sim.spec import TwinSpec

#: What a cycle did (`OnlineCompensator.step`'s return).
STATUS = ("no_sensor", "tracking", "spike_rejected", "holding", "ramping_out")


class AssumedForces(NamedTuple):
    """What an offline-compensated command assumed, as the compensator looks it up: by position along the command.

    Attributes:
        p_sheet_m: The command's tool tips, in order, sheet frame [m], shape (n, 3).
        f_sheet_n: The force of the sheet on the tool the command assumed at each, sheet frame [N], shape (n, 3).
    """

    p_sheet_m: np.ndarray
    f_sheet_n: np.ndarray


#: Joint speed below which the friction's sign turns smoothly (tanh), as `learn` fits it [rad/s].
SPEED_SMOOTHING_RAD_S = 2e-4


class OnlineCompensator:
    """The twin's robot beside a controller: `step` once per cycle.

    Args:
        spec: The twin (its robot, placement and joint stiffness; a learned model file's spec).
        settings: Filtering, limits and watchdog.
        assumed: On top of an offline-compensated command: (the command's tool tips, sheet frame [m], shape
            (n, 3); the force that command assumed at each, sheet frame [N], shape (n, 3)), as the command and its
            compensation record hold them (`AssumedForces`). The compensator then corrects only the deflection of
            the force the command did not assume, and leaves the friction lag to the command (the twin's offline
            compensation took it). The force is looked up by where along the command the robot's reported joints
            are, not by time: the controller re-times a command (stops at corners) by rules a PC beside it does
            not know (`twin.sim.compiled.online`). None: a nominal command.
    """

    def __init__(self, spec: TwinSpec | None = None, settings: OnlineSettings | None = None,
                 assumed: AssumedForces | tuple[np.ndarray, np.ndarray] | None = None) -> None:
        spec = spec or TwinSpec()
        self.settings = settings or OnlineSettings()
        twin = spec.build()
        # the plain arm with the declared tool, rigid: its joints are the controller's; the tool's own bending is
        # a constant compliance at the tip while the tool is held down (`twin.robot.tool_bending`, at home)
        model = build_model(twin.robot, tool=None if spec.tool is None else spec.tool.rigid)
        c_base = bending_compliance_at(twin.model, twin.robot, twin.kinematics.q_home)
        self._c_tool = np.ascontiguousarray(twin.R_base_sheet.T @ c_base @ twin.R_base_sheet)
        self._c_tool[2, 2] += frame_compliance_m_per_n(spec.effects)  # a frame that gives: in series too
        if model.nv != twin.robot.dof:
            raise InputError(f"online compensation needs a plain {twin.robot.dof}-joint arm; {twin.robot.name} "
                             f"compiles to {model.nv} dofs")
        chain = chain_arrays(model, model.site(twin.robot.tool_site).id, twin.p_base_sheet_origin, twin.R_base_sheet)
        if chain is None:
            raise InputError(f"robot {twin.robot.name}: its chain is not one the compiled compensator evaluates")
        self._chain: ChainArrays = chain
        self.dof = twin.robot.dof
        self.k_inv = 1.0 / np.asarray(twin.joint_stiffness, dtype=float)
        self.friction_nm = np.asarray(twin.joint_friction, dtype=float)
        self._params = np.append(self.settings.params(), SPEED_SMOOTHING_RAD_S)
        self._state = np.zeros(STATE_SIZE)
        self._q_prev = np.zeros(self.dof)
        self._assumed_p, self._assumed_f = np.zeros((0, 3)), np.zeros((0, 3))
        if assumed is not None:
            p_a, f_a = np.ascontiguousarray(assumed[0], dtype=float), np.ascontiguousarray(assumed[1], dtype=float)
            if (p_a.ndim != 2 or p_a.shape[1:] != (3,) or f_a.shape != p_a.shape or p_a.shape[0] < 2
                    or not (np.all(np.isfinite(p_a)) and np.all(np.isfinite(f_a)))):
                raise InputError(f"assumed forces: expected the command's tool tips (n, 3) [m] and the forces it "
                                 f"assumed (n, 3) [N], finite, n >= 2; got {p_a.shape} and {f_a.shape}")
            self._assumed_p, self._assumed_f = p_a, f_a
        self._p, self._jac, self._g = np.zeros(3), np.zeros((3, self.dof)), np.zeros(self.dof)
        self.correction_m = self._state[CORR:CORR + 3]  # a view: the correction of the last cycle, sheet frame
        self.cycle_s = self.settings.cycle_s
        # compile (or load) the compiled cycle now, not in a controller's first cycle; then forget that call
        self.step(0.0, math.nan, np.zeros(3), np.asarray(twin.robot.q_home_rad, dtype=float))
        self.reset()

    def hold_each_correction(self, period_s: float) -> None:
        """The controller takes a correction every `period_s` and holds it until the next (`OnlineSettings.period_s`;
        a server whose interface fixes it sets it).

        Raises:
            InputError: A period that is not a finite number in (0, 1] s.
        """
        self.settings = replace(self.settings, period_s=period_s)
        self._params[:-1] = self.settings.params()

    def reset(self) -> None:
        """Back to the start: no sample seen, no correction."""
        self._state[:] = 0.0
        self._q_prev[:] = 0.0

    @property
    def spikes_rejected(self) -> int:
        """Samples rejected as spikes so far."""
        return int(self._state[SPIKES])

    @property
    def cycles_lost_on_command(self) -> int:
        """Cycles so far in which the robot's reported tip was lost on the offline command (a detour of it cut
        short: `twin.sim.compiled.progress`), the force it assumed taken at the nearest segment ahead."""
        return int(self._state[LOST])

    def step(self, t_s: float, sample_t_s: float, f_sheet_n: np.ndarray, q_rad: np.ndarray,
             q_planned_rad: np.ndarray | None = None) -> int:
        """One controller cycle.

        Args:
            t_s: Now, on the controller's clock [s].
            sample_t_s: Stamp of the newest F/T sample [s] (the same as last cycle's: no new sample; NaN: none yet).
            f_sheet_n: That sample: the force of the sheet on the tool, sheet frame [N], shape (3,).
            q_rad: The robot's joints now [rad], shape (dof,).
            q_planned_rad: The controller's planned joints now, without the correction [rad], shape (dof,), where
                its interface reports them: their motion signs the friction's lag (module docstring). None: the
                measured joints' motion does. Give them every cycle or never.

        Returns:
            The cycle's status (`STATUS`); the correction is in `correction_m` [m], sheet frame: add it to the
            commanded tool tip.
        """
        return int(online_cycle(self._chain, self._params, self.k_inv, self.friction_nm, self._c_tool, self._assumed_p,
                                self._assumed_f, self._state, self._q_prev,
                                float(t_s), float(sample_t_s), f_sheet_n, q_rad,
                                q_rad if q_planned_rad is None else q_planned_rad, q_planned_rad is not None,
                                self._p, self._jac, self._g))


__all__ = ["HOLDING", "NO_SENSOR", "RAMPING", "SPIKE", "STATUS", "TRACKING", "AssumedForces", "OnlineCompensator", "OnlineSettings"]
