"""Where along an offline command the robot is, from its reported joints (`progress`), for the online compensator's
cycle (`twin.sim.compiled.online`), which looks up the force the command assumed there.

A controller re-times its path (it stops at sharp corners, ramps its speed) by rules the PC beside it does not know,
but it reports its joints every cycle: the twin's forward kinematics of them, less the correction the compensator
added, less a slowly followed offset (the twin's kinematic error), is matched to the command. The progress is one
segment index that only moves forward, a few segments per cycle at most (`MAX_ADVANCE`): bounded work, and a path
that comes back over itself (a groove's passes) is not mistaken for its return. Where the command makes a detour the
controller's motion cuts short (a learned command's hump at a groove's reversal), the tip leaves the segment it is
on while the next segment, at the detour's top, is never the nearer: the progress would stay there for the rest of
the run, and the force it looked up with it (what `lab --online` on top of such a command showed: CHANGELOG). A
tip `LOST_M` away is lost, and the progress takes the nearest of the next `LOST_SEARCH` segments; the compensator
counts such cycles (`OnlineCompensator.cycles_lost_on_command`; `lab --online` says how many).
"""

from __future__ import annotations

from numba import njit

#: Slots of the progress's state (`track`, a view of the compensator's): the segment, the offset of the reported
#: tip from the command (3), that progress started.
SEGMENT, OFFSET, STARTED = 0, 1, 4
TRACK_SIZE = 5

#: Most command segments the progress along an offline command moves in one cycle (bounded work per cycle: a
#: command sampled at 1 ms at 0.5 m/s moves ~2 segments in a 4 ms cycle).
MAX_ADVANCE = 32
#: Farther than this from its segment [m], the reported tip is lost (module docstring); the tables' runs that kept
#: their place came up to 1.8 mm from it, at corners and reversals. Then the next this many segments are searched.
LOST_M, LOST_SEARCH = 3e-3, 128


@njit(cache=True)
def _segment(path, i, x0, x1, x2):  # type: ignore[no-untyped-def]
    """Where along segment i of `path` (points i, i+1) the point x is nearest: (fraction in [0, 1], squared
    distance [m^2])."""
    a0, a1, a2 = path[i, 0], path[i, 1], path[i, 2]
    d0, d1, d2 = path[i + 1, 0] - a0, path[i + 1, 1] - a1, path[i + 1, 2] - a2
    length2 = d0 * d0 + d1 * d1 + d2 * d2
    s = 0.0
    if length2 > 0.0:
        s = min(max(((x0 - a0) * d0 + (x1 - a1) * d1 + (x2 - a2) * d2) / length2, 0.0), 1.0)
    e0, e1, e2 = x0 - a0 - s * d0, x1 - a1 - s * d1, x2 - a2 - s * d2
    return s, e0 * e0 + e1 * e1 + e2 * e2


@njit(cache=True)
def progress(path, track, x0, x1, x2, alpha):  # type: ignore[no-untyped-def]
    """Move the progress along `path` ((n, 3), n >= 2) to the reported tip x; returns (the fraction along the
    segment it stops on, the segment being in `track[SEGMENT]`; whether the tip was lost, `LOST_M` or more from the
    segment its walk reached).

    The twin's forward kinematics of the reported joints is not the command: the twin's model of the robot and its
    placement are off by millimetres, more than a groove's passes are apart. So x less an offset is matched: the
    offset starts as x less the command's first tip (a controller starts a command where it begins) and follows,
    low-passed by `alpha` per cycle, only the part of the mismatch across the path (along it, it would drift the
    progress). From the segment in `track[SEGMENT]` the progress moves forward to the next segment while that one is
    at least as near, at most `MAX_ADVANCE` of them; ties go forward (a dwell's repeated samples are passed; of a
    pass that comes back exactly over itself the return is taken at most one segment early). Still `LOST_M` away, it
    is lost: it takes the nearest of the next `LOST_SEARCH` segments, if nearer, and the offset holds until it is
    found."""
    if track[STARTED] == 0.0:
        track[OFFSET], track[OFFSET + 1], track[OFFSET + 2] = x0 - path[0, 0], x1 - path[0, 1], x2 - path[0, 2]
        track[SEGMENT], track[STARTED] = 0.0, 1.0
    y0, y1, y2 = x0 - track[OFFSET], x1 - track[OFFSET + 1], x2 - track[OFFSET + 2]
    last = path.shape[0] - 2
    i = min(int(track[SEGMENT]), last)
    s, d = _segment(path, i, y0, y1, y2)
    for _ in range(MAX_ADVANCE):
        if i >= last:
            break
        s_next, d_next = _segment(path, i + 1, y0, y1, y2)
        if d_next > d:
            break
        i, s, d = i + 1, s_next, d_next
    lost = d > LOST_M * LOST_M
    if lost:
        for j in range(i + 1, min(i + LOST_SEARCH, last) + 1):
            s_j, d_j = _segment(path, j, y0, y1, y2)
            if d_j < d:
                i, s, d = j, s_j, d_j
    track[SEGMENT] = i
    if d > LOST_M * LOST_M:  # a lost match, not the twin's kinematic error
        return s, True
    # the mismatch across the segment only
    u0, u1, u2 = path[i + 1, 0] - path[i, 0], path[i + 1, 1] - path[i, 1], path[i + 1, 2] - path[i, 2]
    r0, r1, r2 = y0 - path[i, 0] - s * u0, y1 - path[i, 1] - s * u1, y2 - path[i, 2] - s * u2
    length2 = u0 * u0 + u1 * u1 + u2 * u2
    if length2 > 0.0:
        along = (r0 * u0 + r1 * u1 + r2 * u2) / length2
        r0, r1, r2 = r0 - along * u0, r1 - along * u1, r2 - along * u2
    track[OFFSET] += alpha * r0
    track[OFFSET + 1] += alpha * r1
    track[OFFSET + 2] += alpha * r2
    return s, lost
