"""The joint servo of the dynamic twin (`twin.sim.dynamic`): its five numbers, a record light enough for a model
file (`dynamic_servo`, `TwinSpec.dynamic_servo`) to carry without the simulator.

The form (a two-mass drive under a PID on the motor angle, its gains placed at (s + ω)(s² + 2ζωs + ω²), ω a share
β of each joint's first mode, a pure delay d, an inertial feed-forward share a and a share b of the twin's own
sheet load fed forward) and its sources are in `twin.sim.dynamic`'s docstring. A model file written before b
existed was fitted with the load fed forward: it is read with b = 1 (`twin.sim.model_file`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from twin.errors import InputError

#: Largest delay the servo takes [s].
MAX_DELAY_S = 0.5


@dataclass(frozen=True)
class ServoModel:
    """The generic joint servo (`twin.sim.dynamic`'s docstring).

    Attributes:
        bandwidth_over_mode: β, each joint's loop bandwidth ω_s over its first mode sqrt(K_q / J) [-]; inf: a
            rigid servo.
        damping_ratio: ζ of the loop's complex poles [-].
        delay_s: d, pure delay of the reference (the controller's interpolation, its stops' timing) [s].
        feedforward: a, the share of the rigid joint's inertial torque J r̈ fed forward [-], in [0, 1].
        load_feedforward: b, the share of the twin's own sheet load (the quasi-static replay's) fed forward [-], in
            [0, 1]: 0, a controller that knows its arm's gravity and not the sheet's force (the integral takes it
            up); 1, a loop held on its reference while the twin's force turns.
    """

    bandwidth_over_mode: float = 0.5
    damping_ratio: float = 1.0
    delay_s: float = 0.0
    feedforward: float = 0.0
    load_feedforward: float = 0.0

    def __post_init__(self) -> None:
        checks = (("bandwidth_over_mode", 0.02, math.inf, "- (inf: rigid)"), ("damping_ratio", 0.05, 20.0, "-"),
                  ("delay_s", 0.0, MAX_DELAY_S, "s"), ("feedforward", 0.0, 1.0, "-"),
                  ("load_feedforward", 0.0, 1.0, "-"))
        for name, low, high, unit in checks:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and low <= value <= high):
                raise InputError(f"ServoModel.{name} = {value!r}: expected a number in [{low}, {high}] {unit}")

    def to_json(self) -> dict[str, float]:
        """Its five numbers by name, as a model file's `dynamic_servo` carries them."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}

    @property
    def rigid(self) -> bool:
        """Whether the motor sits on its reference (β = inf)."""
        return math.isinf(self.bandwidth_over_mode)
