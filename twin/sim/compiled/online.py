"""The online compensator's cycle, compiled (`twin.sim.online.OnlineCompensator.step`).

One call per controller cycle on arrays allocated once: the filtered force and its rate, the watchdog's clock,
the spike count and run, the correction, the joints of the last cycle (`state`, slots below). The chain is the
twin's (`chain.chain_eval`), so this file is one of the kernel sources whose change drops the cached kernels.
"""

from __future__ import annotations

import math

from numba import njit

from twin.sim.compiled.chain import chain_eval

#: Status codes of a cycle (`twin.sim.online.STATUS` names them).
NO_SENSOR, TRACKING, SPIKE, HOLDING, RAMPING = range(5)
#: Slots of the state vector: a sample seen, its stamp, spikes rejected, filtered force (3), its rate (3), the
#: correction (3), spikes in a row, joints seen.
HAVE, T_LAST, SPIKES, F, DF, CORR, RUN, HAVE_Q, AT = 0, 1, 2, 3, 6, 9, 12, 13, 14
STATE_SIZE = 15


@njit(cache=True)
def online_cycle(chain, params, k_inv, friction, assumed_t, assumed_f, state, q_prev, t, sample_t, f, q, p, jac, g):  # type: ignore[no-untyped-def]
    """One cycle on preallocated arrays (`OnlineCompensator.step`); returns the status."""
    omega, latency, spike, max_corr, max_step = params[1], params[2], params[3], params[4], params[5]
    stale, hold, gain, spike_run, w0 = params[6], params[7], params[8], params[9], params[10]
    cycle = params[0]
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
    target0, target1, target2 = 0.0, 0.0, 0.0
    if state[HAVE] == 0.0:
        status = NO_SENSOR
    else:
        age = t - state[T_LAST]
        if age <= stale:
            ahead = latency + max(age, 0.0)
            chain_eval(chain, q, p, jac, g, False)
            fp0 = state[F] + state[DF] * ahead
            fp1 = state[F + 1] + state[DF + 1] * ahead
            fp2 = state[F + 2] + state[DF + 2] * ahead
            n_assumed = assumed_t.shape[0]
            if n_assumed > 0:  # on top of an offline command: only the force it did not assume
                i = int(state[AT])
                while i + 1 < n_assumed - 1 and assumed_t[i + 1] <= t:
                    i += 1
                state[AT] = i
                w = 0.0
                if n_assumed > 1 and assumed_t[i + 1] > assumed_t[i]:
                    w = min(max((t - assumed_t[i]) / (assumed_t[i + 1] - assumed_t[i]), 0.0), 1.0)
                j = min(i + 1, n_assumed - 1)
                fp0 -= (1.0 - w) * assumed_f[i, 0] + w * assumed_f[j, 0]
                fp1 -= (1.0 - w) * assumed_f[i, 1] + w * assumed_f[j, 1]
                fp2 -= (1.0 - w) * assumed_f[i, 2] + w * assumed_f[j, 2]
            # -C F with C = J K^-1 J^T: first w = K^-1 J^T F, then -J w
            d0, d1, d2 = 0.0, 0.0, 0.0
            for j in range(k_inv.shape[0]):
                w = k_inv[j] * (jac[0, j] * fp0 + jac[1, j] * fp1 + jac[2, j] * fp2)
                if state[HAVE_Q] != 0.0 and n_assumed == 0:  # the friction's lag: -J_j s_j tau_j / K_j
                    w -= k_inv[j] * friction[j] * math.tanh((q[j] - q_prev[j]) / cycle / w0)
                d0 += jac[0, j] * w
                d1 += jac[1, j] * w
                d2 += jac[2, j] * w
            target0, target1, target2 = -gain * d0, -gain * d1, -gain * d2
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
        q_prev[j] = q[j]
    state[HAVE_Q] = 1.0
    s0, s1, s2 = target0 - state[CORR], target1 - state[CORR + 1], target2 - state[CORR + 2]
    size = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    if size > max_step:
        scale = max_step / size
        s0, s1, s2 = s0 * scale, s1 * scale, s2 * scale
    state[CORR] += s0
    state[CORR + 1] += s1
    state[CORR + 2] += s2
    return status
