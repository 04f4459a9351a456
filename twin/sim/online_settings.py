"""The online compensator's settings (`OnlineSettings`), apart from the compensator itself (`twin.sim.online`) so
that what only needs its defaults (a program's correction limits, `twin.apps.export.krl_rsi`; the CLI's parser) does
not load the compiled cycle."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from twin.errors import InputError
from twin.robot.controller import (
    DEFAULT_MAX_CORRECTION_MM,
    DEFAULT_MAX_RATE_MM_S,
    MAX_CORRECTION_LIMIT_MM,
    MAX_RATE_MM_S,
)

#: A correction within this of its size limit sits at it [mm] (`lab --online`'s share, a server's count).
AT_LIMIT_MM = 1e-3


def _limit(value: float, option: str, high: float, default: float, expected: str, online: bool,
           number: str = "{!r}") -> float:
    """`value` as a limit of the online correction, or an `InputError` naming `option` and `expected`: a finite
    number > 0 and at most `high`; other than `default` only where there is an online correction to limit
    (`online`: a `lab` or `export` without `--online` would ignore it). `number`: how a number is shown."""
    is_number = not isinstance(value, bool) and isinstance(value, int | float)
    if not (is_number and math.isfinite(value) and 0.0 < value <= high):
        raise InputError(f"{option} {number.format(value) if is_number else repr(value)}: {expected}")
    if value != default and not online:
        raise InputError(f"{option} {value:g} without --online: it limits the online correction; expected --online "
                         "with it")
    return float(value)


def check_max_correction_mm(value: float, option: str = "--max-correction-mm", online: bool = True) -> float:
    """`value` as the correction's size limit [mm] (`_limit`): at most `MAX_CORRECTION_LIMIT_MM` (the controller's
    own limits, RSI's POSCORR, EGM's end tolerance, take it too)."""
    return _limit(value, option, MAX_CORRECTION_LIMIT_MM, DEFAULT_MAX_CORRECTION_MM,
                  f"expected the correction's size limit in mm, a finite number > 0 and at most "
                  f"{MAX_CORRECTION_LIMIT_MM:g} (default {DEFAULT_MAX_CORRECTION_MM:g})", online)


def check_max_rate_mm_s(value: float, option: str = "--max-rate-mm-s", online: bool = True) -> float:
    """`value` as the correction's rate limit [mm/s] (`_limit`): at most `MAX_RATE_MM_S`."""
    return _limit(value, option, MAX_RATE_MM_S, DEFAULT_MAX_RATE_MM_S,
                  f"expected mm/s > 0 and <= {MAX_RATE_MM_S:g} (the correction's rate limit; default "
                  f"{DEFAULT_MAX_RATE_MM_S:g})", online, "{:g}")


@dataclass(frozen=True)
class OnlineSettings:
    """What the compensator does with a real signal (module docstring).

    Attributes:
        cycle_s: The controller cycle [s] (KUKA RSI 4 or 12 ms, ABB EGM 4 ms).
        filter_hz: Cut-off of the force's first-order low-pass [Hz].
        latency_s: The sensor's latency to predict over [s] (0: none).
        period_s: How often the controller takes a correction and holds it until the next [s] (ABB EGM's path
            correction every 48 ms; at most `cycle_s`: every cycle, RSI's, EGM position guidance's, VAL3's). A
            correction held for the period is applied on average half of it after it was computed, and for a force
            that ramps the held value that errs least over the hold is the one at its middle: the force is
            predicted `horizon_s` ahead.
        spike_n: A sample this far from the filtered force is rejected [N].
        spike_run: At most this many samples in a row are rejected; the next is a new level, taken.
        max_correction_mm: Largest correction [mm].
        max_rate_mm_s: Largest rate of change of the correction [mm/s].
        stale_s: A sample older than this is stale [s].
        hold_s: A stale correction is held this long before it ramps out [s].
        gain: Share of the predicted deflection corrected [-] (1: all of it).
        side_share: Across the tool's travel, the correction is taken in full where the sheet's side force is at
            least this share of its normal force (a wall on one side: an incremental cone's or pyramid's wall
            pushes with a share of Fz, docs/online.md has the plant's), and scaled down in proportion below it, to
            nothing where the side force is nil (a groove, whose walls hold the tool from both sides: its side force
            is their reaction to where the arm puts the tool, and correcting it closes a loop through their
            stiffness) [-]. 0: taken in full everywhere.
        feed_turns: At a turn of the planned travel (a pyramid's corner, a groove's reversal), the sheet's friction
            is turned with it at once, ahead of the filtered force, which shows it only after the sensor's sample,
            latency and filter, and at a corner the wall's push across the travel with it (the next side's as the
            tool moves into it), by as much as the cell's earlier turns turned them (`twin.sim.compiled.online._turned_force`). False: the filtered force
            alone.
    """

    cycle_s: float = 0.004
    filter_hz: float = 10.0
    latency_s: float = 0.0
    period_s: float = 0.004
    spike_n: float = 1500.0
    spike_run: int = 2
    max_correction_mm: float = DEFAULT_MAX_CORRECTION_MM
    max_rate_mm_s: float = DEFAULT_MAX_RATE_MM_S
    stale_s: float = 0.1
    hold_s: float = 0.1
    gain: float = 1.0
    side_share: float = 0.1
    feed_turns: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.spike_run, int) and self.spike_run >= 0):
            raise InputError(f"online setting spike_run = {self.spike_run!r}: expected a whole number >= 0")
        if not isinstance(self.feed_turns, bool):
            raise InputError(f"online setting feed_turns = {self.feed_turns!r}: expected True or False")
        for f in fields(self):
            if f.name in ("spike_run", "feed_turns"):
                continue
            value = getattr(self, f.name)
            zero_ok = f.name in ("latency_s", "hold_s", "side_share")
            ok = math.isfinite(value) and (value >= 0.0 if zero_ok else value > 0.0)
            if not ok:
                raise InputError(f"online setting {f.name} = {value!r}: expected a finite number "
                                 f"{'>= 0' if zero_ok else '> 0'}")
        if self.period_s > 1.0:
            raise InputError(f"online setting period_s = {self.period_s!r}: expected the controller's correction "
                             "period, a finite number > 0 and at most 1 s (ABB EGM path correction: 0.048)")
        if self.side_share > 1.0:
            raise InputError(f"online setting side_share = {self.side_share!r}: expected a share of the normal "
                             "force in [0, 1] (0: the correction across the travel taken in full)")
        check_max_correction_mm(self.max_correction_mm, "online setting max_correction_mm")
        check_max_rate_mm_s(self.max_rate_mm_s, "online setting max_rate_mm_s")
        if self.gain > 1.5:
            raise InputError(f"online setting gain = {self.gain!r}: expected at most 1.5 (1: the whole deflection)")

    @property
    def horizon_s(self) -> float:
        """How far ahead the filtered force is predicted, besides the sample's age [s]: the latency and half of the
        hold beyond the cycle, latency_s + (period_s - cycle_s) / 2 (a correction taken every cycle: the latency,
        as `latency_s` has always been measured; EGM path correction, 48 ms in a 4 ms cycle: 22 ms more)."""
        return self.latency_s + 0.5 * max(self.period_s - self.cycle_s, 0.0)

    def params(self) -> np.ndarray:
        """The settings as the compiled cycle reads them (SI; its third, the horizon; its eleventh, the side
        share; its twelfth, 1.0 where turns are fed forward)."""
        return np.array([self.cycle_s, 2.0 * math.pi * self.filter_hz, self.horizon_s, self.spike_n,
                         1e-3 * self.max_correction_mm, 1e-3 * self.max_rate_mm_s, self.stale_s,
                         self.hold_s, self.gain, float(self.spike_run), self.side_share,
                         float(self.feed_turns)])


#: `--max-rate-mm-s`'s help (`lab --online`, `online`).
MAX_RATE_HELP = ("largest rate of change of the online correction [mm/s]: per second of the controller's clock and of "
                 "this computer's, not per packet (a burst of packets moves it no faster; default: a --cell's "
                 f"controller.max_rate_mm_s, else {DEFAULT_MAX_RATE_MM_S:g})")
#: `--max-correction-mm`'s help (`lab --online`, `export --online`, `online`).
MAX_CORRECTION_HELP = (f"the online correction's size limit [mm] (default: a --cell's controller.max_correction_mm, else "
                       f"{OnlineSettings.max_correction_mm:g}): the "
                       "compensator's, the exported program's (RSI's POSCORR limits, EGM position guidance's end "
                       "tolerance) and its server's alike; `lab --online` says when the correction sat at it")
