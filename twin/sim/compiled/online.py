"""The online compensator's cycle, compiled (`twin.sim.online.OnlineCompensator.step`).

One call per controller cycle on arrays allocated once: the filtered force and its rate, the watchdog's clock,
the spike count and run, the correction, the joints of the last cycle, the progress along an offline command
(`state`, slots below). The chain is the twin's (`chain.chain_eval`), so this file is one of the kernel sources
whose change drops the cached kernels.

On top of an offline command the force that command assumed is looked up by *position* along it, not by time: a
controller re-times its path (it stops at sharp corners, ramps its speed) by rules the PC beside it does not know,
but it reports its joints every cycle, and the twin's forward kinematics of them, less the correction the
compensator itself added, less a slowly followed offset (the twin's kinematic error), is where along the command
the robot is (`twin.sim.compiled.progress`: one segment index that only moves forward, in bounded work per cycle).
"""

from __future__ import annotations

import math

from numba import njit

from twin.sim.compiled.chain import chain_eval
from twin.sim.compiled.progress import SEGMENT, TRACK_SIZE, progress

#: Status codes of a cycle (`twin.sim.online.STATUS` names them).
NO_SENSOR, TRACKING, SPIKE, HOLDING, RAMPING = range(5)
#: Slots of the state vector: a sample seen, its stamp, spikes rejected, filtered force (3), its rate (3), the
#: correction (3), spikes in a row, joints seen, the progress along an offline command (`progress`'s track, its
#: `TRACK_SIZE` slots: the segment, the offset of the reported tip from it (3), that progress started), the time of
#: the last call, a call seen; the travel's last anchor point (2, sheet plane) and direction (2), a direction found,
#: the side force's share of the normal force (slowly filtered), that share seen; the last turn of the travel (the
#: in-plane force's change expected there [N] (2; `_travel`), the filtered in-plane force at it (2), its time, its
#: state: 0 over, 1 fed forward, 2 shown by the force and waiting to be read), the sheet's friction force along the
#: travel as a share of the normal force (slowly filtered), that share seen; the planned tip of the last cycle (2);
#: how much of the expected change the cell's turns have turned, less 1 (zeros start at 1); the cycles the reported
#: tip was lost on the offline command (`progress`); at the last turn, the planned tip (2) and the wall's push across
#: the new travel [N] (2; zeros at a reversal).
HAVE, T_LAST, SPIKES, F, DF, CORR, RUN, HAVE_Q, TRACK = 0, 1, 2, 3, 6, 9, 12, 13, 14
T_CALL, HAVE_T = TRACK + TRACK_SIZE, TRACK + TRACK_SIZE + 1
ANCHOR, DIRECTION, HAVE_DIR, SIDE, HAVE_SIDE = 21, 23, 25, 26, 27
TURN_U, TURN_F, TURN_T, TURNING, FRICTION, HAVE_FRICTION, PREV, TURN_GAIN = 28, 30, 32, 33, 34, 35, 36, 38
LOST, TURN_P, TURN_WALL = 39, 40, 42
STATE_SIZE = 44
#: The travel's direction is taken over this much of the tool's planned travel [m]: a joint's vibration (um) does
#: not turn it, a pass's reversal does within a tenth of a millimetre.
TRAVEL_STEP_M = 1e-4
#: Time constant of the side force's share [s]: the kind of contact (a wall on one side, walls on both), not the
#: loop's own swing (a few Hz).
SIDE_TAU_S = 1.0
#: The share is read only while the tool presses the sheet this hard [N] (below it, the tool is off the sheet or
#: only touching it).
SIDE_MIN_FZ_N = 100.0
#: A turn of the planned travel's direction by more than this is a turn whose friction is fed forward (cosine): a
#: pyramid's corner turns by 90 deg, a groove's reversal by 180; a spiral's 0.1 mm steps by a fraction of a degree.
COS_TURN = math.cos(math.radians(45.0))
#: A turn by less than this is a corner (cosine): the wall that pushes the tool across its travel turns with it,
#: as a pyramid's does at its corner; past it a reversal, whose walls stay where they are (a groove's).
COS_CORNER = math.cos(math.radians(135.0))
#: Past a corner the new side's wall pushes across the new travel as the tool moves into it: that push is fed in
#: proportion to the planned travel since the turn, whole after this much of it [m] (the friction turns at once).
#: Chosen among 0.25, 0.5, 1 and 2 mm on the development robots' pyramids (the TX200's and the KR 210's, both sheet
#: laws), not on the IRB 6640's; CHANGELOG.
WALL_BUILD_M = 5e-4
#: Where the controller reports its planned joints (no vibration in them), a turn is seen in the plan's first step
#: of at least this much in a cycle [m] (2.5 mm/s in 4 ms; a joint quantum of 1e-4 deg, RSI's, moves a tip at 1.5 m
#: by 2.6 um, which cannot turn such a step by 45 deg), not after `TRAVEL_STEP_M` of it (~20 ms out of a stop).
TURN_STEP_M = 1e-5
#: This long after a turn, what the filtered force has shown of it is read [s] (a sensor at 30 Hz behind a 10 Hz
#: filter shows a reversed friction within ~0.1 s), and the turn is over: fed forward no longer.
TURN_SETTLE_S = 0.3
#: Weight of each turn's reading in the share of mu u the cell's turns turn (the turn gain; three turns: 7/8) [-],
#: and its bounds: a groove's end wall that pushed before the reversal turns less than the friction (a tool that
#: left the sheet, none), a plough front that builds after it more.
TURN_ADAPT = 0.5
TURN_GAIN_MAX = 1.5
#: The rate limit's clock: the correction moves at most the rate times the controller time since the last call,
#: and that time counts at most this many cycles (a controller that stalled does not earn a jump).
MAX_GAP_CYCLES = 4.0
#: Time constant of the offset of the reported tip from the command, across the path [s]: slow against a pass's
#: step to the next (a groove's 0.5 mm down at a turn, in ~0.1 s), fast against the twin's kinematic error, which
#: changes over the workspace (mm over tens of mm).
OFFSET_TAU_S = 1.0


@njit(cache=True)
def _follow(state, at, seen, value, cycle):  # type: ignore[no-untyped-def]
    """Follow `value` slowly in `state[at]` (its first value taken whole, `state[seen]` set; then low-passed with
    `SIDE_TAU_S`): the side force's and the friction's shares of the normal force."""
    if state[seen] == 0.0:
        state[at], state[seen] = value, 1.0
    else:
        state[at] += (1.0 - math.exp(-cycle / SIDE_TAU_S)) * (value - state[at])


@njit(cache=True)
def _travel(state, t, x0, x1, turn_feed, planned, corners):  # type: ignore[no-untyped-def]
    """Follow the planned tip (x0, x1) [m]: the travel's direction over each `TRAVEL_STEP_M` (or, `planned`, a turn
    of it in one cycle's step of `TURN_STEP_M`), and a turn of it by more than `COS_TURN` recorded (the in-plane
    force's change expected there: the friction's turned, and where `corners` and the turn is a corner
    (`COS_CORNER`) the filtered force's to the new side's steady one, its friction along the new travel and the
    wall's push across it; the filtered force there; the time). `corners`: False on top of an offline command,
    whose assumed force turns at the corner by position already."""
    if state[HAVE_Q] == 0.0:
        state[ANCHOR], state[ANCHOR + 1], state[PREV], state[PREV + 1] = x0, x1, x0, x1
    s0, s1 = x0 - state[PREV], x1 - state[PREV + 1]
    state[PREV], state[PREV + 1] = x0, x1
    step = math.sqrt(s0 * s0 + s1 * s1)
    m0, m1 = x0 - state[ANCHOR], x1 - state[ANCHOR + 1]
    moved = math.sqrt(m0 * m0 + m1 * m1)
    if (planned and state[HAVE_DIR] != 0.0 and step >= TURN_STEP_M
            and s0 * state[DIRECTION] + s1 * state[DIRECTION + 1] < COS_TURN * step):
        m0, m1, moved = s0, s1, step  # the plan turned: seen in its first step
    elif moved < TRAVEL_STEP_M:
        return
    n0, n1 = m0 / moved, m1 / moved
    d0, d1 = state[DIRECTION], state[DIRECTION + 1]
    turn = n0 * d0 + n1 * d1
    if turn_feed > 0.0 and state[HAVE_DIR] != 0.0 and state[HAVE_FRICTION] != 0.0 and turn < COS_TURN:
        mu = state[FRICTION] * abs(state[F + 2])
        if corners and turn > COS_CORNER:  # a corner: from the force at the turn to the next side's steady one
            across = -state[F] * d1 + state[F + 1] * d0  # the wall's push, along the old travel's left normal
            w0 = (-mu * n0 - across * n1) - state[F]  # -mu d_new + s a_new, less the in-plane force at the turn
            w1 = (-mu * n1 + across * n0) - state[F + 1]
            state[TURN_WALL], state[TURN_WALL + 1] = -across * n1, across * n0  # s a_new: built as the tool moves
        else:  # the friction turned: -mu d_new - (-mu d_old)
            w0, w1 = mu * (d0 - n0), mu * (d1 - n1)
            state[TURN_WALL], state[TURN_WALL + 1] = 0.0, 0.0
        state[TURN_U], state[TURN_U + 1] = w0, w1
        state[TURN_P], state[TURN_P + 1] = x0, x1
        state[TURN_F], state[TURN_F + 1], state[TURN_T], state[TURNING] = state[F], state[F + 1], t, 1.0
    state[DIRECTION], state[DIRECTION + 1], state[HAVE_DIR] = n0, n1, 1.0
    state[ANCHOR], state[ANCHOR + 1] = x0, x1


@njit(cache=True)
def _turned_force(state, t, cycle):  # type: ignore[no-untyped-def]
    """The sheet's force the filtered force has not yet turned with the travel [N] (in-plane, 2 values).

    The sheet's friction opposes the tool's travel, -mu d. At a turn of the planned travel from d_old to d_new it
    changes by mu (d_old - d_new), at once where the tool turns. At a corner the new side's force is taken as a
    side's steady one, -mu d_new + s a_new (a, the travel's left normal; s, the wall's push across the travel at the
    turn): the change from the force at the turn, whose part along d_old may have built up toward the corner
    (`_travel`); its wall's part, s a_new, is met as the tool moves into the new side and is fed in proportion to
    the planned travel since the turn (`WALL_BUILD_M`). Either is u [N]. The filtered force shows it only after the
    sensor's sample, its latency and the filter. Of k u (k, the turn gain: 1 at first) what the filtered force has
    not yet shown, measured by its change since the turn along u, is added to it, until it has shown it all. `TURN_SETTLE_S` after the turn the share of u
    it has shown is read into k (`TURN_ADAPT`): the along-travel force of a real cell is not only friction (a
    groove's end wall pushes before the reversal and not after), and its turns teach the compensator how much of it
    turns. Between turns, mu's share of the normal force is followed slowly (`SIDE_TAU_S`) from the filtered force
    along the travel, while the tool presses the sheet (`SIDE_MIN_FZ_N`)."""
    fz = abs(state[F + 2])
    if state[TURNING] != 0.0:
        gain = 1.0 + state[TURN_GAIN]
        u0, u1 = state[TURN_U], state[TURN_U + 1]
        uu = u0 * u0 + u1 * u1
        seen = gain if uu <= 0.0 else ((state[F] - state[TURN_F]) * u0 + (state[F + 1] - state[TURN_F + 1]) * u1) / uu
        if t - state[TURN_T] < TURN_SETTLE_S:
            if state[TURNING] == 1.0 and seen < gain:
                left = gain - max(seen, 0.0)
                p0, p1 = state[PREV] - state[TURN_P], state[PREV + 1] - state[TURN_P + 1]
                unbuilt = gain * (1.0 - min(math.sqrt(p0 * p0 + p1 * p1) / WALL_BUILD_M, 1.0))
                return left * u0 - unbuilt * state[TURN_WALL], left * u1 - unbuilt * state[TURN_WALL + 1]
            state[TURNING] = 2.0  # shown: the rest is the filtered force's; read at TURN_SETTLE_S
            return 0.0, 0.0
        if uu > 0.0:
            state[TURN_GAIN] += TURN_ADAPT * (min(max(seen, 0.0), TURN_GAIN_MAX) - gain)
        state[TURNING] = 0.0
    if state[HAVE_DIR] != 0.0 and fz >= SIDE_MIN_FZ_N:
        share = max(-(state[F] * state[DIRECTION] + state[F + 1] * state[DIRECTION + 1]) / fz, 0.0)
        _follow(state, FRICTION, HAVE_FRICTION, share, cycle)
    return 0.0, 0.0


@njit(cache=True)
def online_cycle(chain, params, k_inv, friction, c_tool, assumed_p, assumed_f, state, q_prev, t, sample_t, f, q, q_ref, planned, p, jac, g):  # type: ignore[no-untyped-def]
    """One cycle on preallocated arrays (`OnlineCompensator.step`); returns the status.

    `c_tool`: the tool's own bending compliance at the tip, sheet frame [m/N], (3, 3) (zeros: a rigid tool; constant
    while the tool is held down). `assumed_p`, `assumed_f`: an offline command's tool tips (sheet frame [m], (n, 3))
    and the force it assumed at each ([N], (n, 3)); n = 0: a nominal command. `q_ref`: the joints whose motion
    signs the friction's lag (the controller's planned joints where it reports them, `planned` True, else `q`)."""
    omega, latency, spike, max_corr, max_rate = params[1], params[2], params[3], params[4], params[5]
    stale, hold, gain, spike_run, side_share = params[6], params[7], params[8], params[9], params[10]
    cycle, turn_feed, w0 = params[0], params[11], params[12]
    if side_share > 0.0 or turn_feed > 0.0:  # the travel in the sheet plane, from the planned tip (`q_ref`)
        chain_eval(chain, q_ref, p, jac, g)
        _travel(state, t, p[0], p[1], turn_feed, planned, assumed_p.shape[0] == 0)
    status = TRACKING
    if sample_t == sample_t and (state[HAVE] == 0.0 or sample_t > state[T_LAST]):  # a new sample (not NaN)
        if state[HAVE] == 0.0:
            for i in range(3):
                state[F + i], state[DF + i] = f[i], 0.0
            state[HAVE], state[T_LAST] = 1.0, sample_t
        else:
            jump = 0.0
            for i in range(3):
                jump += (f[i] - state[F + i]) ** 2
            if math.sqrt(jump) > spike and state[RUN] < spike_run:
                state[SPIKES] += 1.0
                state[RUN] += 1.0
                status = SPIKE
            elif math.sqrt(jump) > spike:  # a run of them: the level changed; start the filter there
                for i in range(3):
                    state[F + i], state[DF + i] = f[i], 0.0
                state[RUN], state[T_LAST] = 0.0, sample_t
            else:
                state[RUN] = 0.0
                dt = sample_t - state[T_LAST]
                alpha = 1.0 - math.exp(-omega * dt)
                for i in range(3):
                    step = alpha * (f[i] - state[F + i])
                    state[F + i] += step
                    state[DF + i] += alpha * (step / dt - state[DF + i])
                state[T_LAST] = sample_t
    n_assumed = assumed_p.shape[0]
    w_at, i_at = 0.0, 0
    if n_assumed > 0:  # on top of an offline command: where along it the robot is, every cycle (no gap to catch up)
        chain_eval(chain, q, p, jac, g)
        # the commanded tip the joints report, less the correction this compensator added to it
        w_at, lost = progress(assumed_p, state[TRACK:TRACK + TRACK_SIZE], p[0] - state[CORR],
                              p[1] - state[CORR + 1], p[2] - state[CORR + 2], 1.0 - math.exp(-cycle / OFFSET_TAU_S))
        i_at = int(state[TRACK + SEGMENT])
        if lost:
            state[LOST] += 1.0
    target0, target1, target2 = 0.0, 0.0, 0.0
    if state[HAVE] == 0.0:
        status = NO_SENSOR
    else:
        age = t - state[T_LAST]
        if age <= stale:
            ahead = latency + max(age, 0.0)
            if n_assumed == 0:
                chain_eval(chain, q, p, jac, g)
            fp0 = state[F] + state[DF] * ahead
            fp1 = state[F + 1] + state[DF + 1] * ahead
            fp2 = state[F + 2] + state[DF + 2] * ahead
            ff0, ff1 = 0.0, 0.0
            if turn_feed > 0.0:  # the friction's turn the filtered force has not shown yet
                ff0, ff1 = _turned_force(state, t, cycle)
                if state[TURNING] == 1.0:  # the turn is fed forward: its rate in the filtered force is not
                    u0, u1 = state[TURN_U], state[TURN_U + 1]  # extrapolated past it as well
                    along = (state[DF] * u0 + state[DF + 1] * u1) * ahead / (u0 * u0 + u1 * u1)
                    fp0, fp1 = fp0 - along * u0, fp1 - along * u1
                fp0, fp1 = fp0 + ff0, fp1 + ff1
            if n_assumed > 0:  # only the force the command did not assume, there
                fp0 -= (1.0 - w_at) * assumed_f[i_at, 0] + w_at * assumed_f[i_at + 1, 0]
                fp1 -= (1.0 - w_at) * assumed_f[i_at, 1] + w_at * assumed_f[i_at + 1, 1]
                fp2 -= (1.0 - w_at) * assumed_f[i_at, 2] + w_at * assumed_f[i_at + 1, 2]
            # -C F with C = J K^-1 J^T: first w = K^-1 J^T F, then -J w
            d0, d1, d2 = 0.0, 0.0, 0.0
            for j in range(k_inv.shape[0]):
                w = k_inv[j] * (jac[0, j] * fp0 + jac[1, j] * fp1 + jac[2, j] * fp2)
                if state[HAVE_Q] != 0.0 and n_assumed == 0:  # the friction's lag: -J_j s_j tau_j / K_j
                    w -= k_inv[j] * friction[j] * math.tanh((q_ref[j] - q_prev[j]) / cycle / w0)
                d0 += jac[0, j] * w
                d1 += jac[1, j] * w
                d2 += jac[2, j] * w
            d0 += c_tool[0, 0] * fp0 + c_tool[0, 1] * fp1 + c_tool[0, 2] * fp2  # the tool's own bending
            d1 += c_tool[1, 0] * fp0 + c_tool[1, 1] * fp1 + c_tool[1, 2] * fp2
            d2 += c_tool[2, 0] * fp0 + c_tool[2, 1] * fp1 + c_tool[2, 2] * fp2
            target0, target1, target2 = -gain * d0, -gain * d1, -gain * d2
            if side_share > 0.0 and state[HAVE_DIR] != 0.0:  # across the travel: a load, or the walls' reaction
                a0, a1 = -state[DIRECTION + 1], state[DIRECTION]
                if abs(state[F + 2]) >= SIDE_MIN_FZ_N:
                    share = abs((state[F] + ff0) * a0 + (state[F + 1] + ff1) * a1) / abs(state[F + 2])
                    _follow(state, SIDE, HAVE_SIDE, share, cycle)
                if state[HAVE_SIDE] != 0.0 and state[SIDE] < side_share:
                    across = (1.0 - state[SIDE] / side_share) * (target0 * a0 + target1 * a1)
                    target0 -= across * a0
                    target1 -= across * a1
            size = math.sqrt(target0 * target0 + target1 * target1 + target2 * target2)
            if size > max_corr:
                scale = max_corr / size
                target0, target1, target2 = target0 * scale, target1 * scale, target2 * scale
        elif age <= stale + hold:
            status = HOLDING
            target0, target1, target2 = state[CORR], state[CORR + 1], state[CORR + 2]
        else:
            status = RAMPING
    for j in range(q.shape[0]):
        q_prev[j] = q_ref[j]
    state[HAVE_Q] = 1.0
    # the rate limit per unit of the controller's time: calls that come faster than its cycle (a burst, a second
    # sender) move the correction no faster; a first call counts one cycle, a call back in time none
    elapsed = min(max(t - state[T_CALL], 0.0), MAX_GAP_CYCLES * cycle) if state[HAVE_T] != 0.0 else cycle
    if t == t:
        state[T_CALL], state[HAVE_T] = max(t, state[T_CALL]) if state[HAVE_T] != 0.0 else t, 1.0
    max_step = max_rate * elapsed
    s0, s1, s2 = target0 - state[CORR], target1 - state[CORR + 1], target2 - state[CORR + 2]
    size = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    if size > max_step:
        scale = max_step / size
        s0, s1, s2 = s0 * scale, s1 * scale, s2 * scale
    state[CORR] += s0
    state[CORR + 1] += s1
    state[CORR + 2] += s2
    return status
