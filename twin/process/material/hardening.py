"""A sheet material's hardening law: true flow stress as a function of true plastic strain.

Three laws, each with its named parameters (stresses in MPa, strains dimensionless):

* `hollomon`: σ = K·ε^n (`k_mpa`, `n`);
* `swift`: σ = K·(ε0 + ε)^n (`k_mpa`, `eps0`, `n`);
* `voce`: σ = σ0 + Q·(1 - exp(-b·ε))^m (`sigma0_mpa`, `q_mpa`, `b`, optional `m`, default 1: Voce's law; the
  thesis's AA5086-H111 law has m = 1/2, `twin.process.force.isf`).

A law is data (`models/materials/library.toml`, a user's materials file): `HardeningLaw.from_mapping` validates
a table and names the offending key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from twin.errors import InputError

#: The parameters of each law: required, then optional (with its default).
LAW_PARAMETERS: dict[str, tuple[tuple[str, ...], dict[str, float]]] = {
    "hollomon": (("k_mpa", "n"), {}),
    "swift": (("k_mpa", "eps0", "n"), {}),
    "voce": (("sigma0_mpa", "q_mpa", "b"), {"m": 1.0}),
}
#: A stress parameter above this is a value in Pa typed where MPa was expected [MPa].
PA_SUSPECT_MPA = 5000.0


@dataclass(frozen=True)
class HardeningLaw:
    """A hardening law (module docstring).

    Attributes:
        kind: `hollomon`, `swift` or `voce`.
        k_mpa: Strength coefficient K [MPa] (hollomon, swift).
        n: Hardening exponent n [-] (hollomon, swift), in (0, 1].
        eps0: Pre-strain ε0 [-] (swift), > 0.
        sigma0_mpa: Initial flow stress σ0 [MPa] (voce).
        q_mpa: Saturation stress increase Q [MPa] (voce).
        b: Saturation rate b [-] (voce).
        m: Exponent of the saturation term [-] (voce; 1: Voce's law), in (0, 1].
    """

    kind: str
    k_mpa: float | None = None
    n: float | None = None
    eps0: float | None = None
    sigma0_mpa: float | None = None
    q_mpa: float | None = None
    b: float | None = None
    m: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in LAW_PARAMETERS:
            raise InputError(f"hardening kind {self.kind!r}: expected one of {sorted(LAW_PARAMETERS)}")
        required, optional = LAW_PARAMETERS[self.kind]
        allowed = (*required, *optional)
        for name in ("k_mpa", "n", "eps0", "sigma0_mpa", "q_mpa", "b", "m"):
            value = getattr(self, name)
            if value is None:
                if name in required:
                    raise InputError(f"hardening {self.kind!r} needs {name}; its parameters are {list(allowed)}")
                if name in optional:
                    object.__setattr__(self, name, optional[name])
                continue
            if name not in allowed:
                raise InputError(f"hardening {self.kind!r} takes no {name}; its parameters are {list(allowed)}")
            problem = parameter_problem(name, value)
            if problem:
                raise InputError(f"hardening {name} = {value!r}: {problem}")
            object.__setattr__(self, name, float(value))

    @classmethod
    def from_mapping(cls, table: Mapping[str, Any]) -> HardeningLaw:
        """A law from a table `{kind = ..., <parameters>}` (a TOML inline table).

        Raises:
            InputError: Unknown kind, a missing, foreign or bad parameter (the message names it).
        """
        kind = table.get("kind")
        if kind not in LAW_PARAMETERS:
            raise InputError(f"hardening kind = {kind!r}: expected one of {sorted(LAW_PARAMETERS)}")
        required, optional = LAW_PARAMETERS[kind]
        unknown = sorted(set(table) - {"kind", *required, *optional})
        if unknown:
            raise InputError(f"hardening {kind!r} takes no {unknown}; its parameters are {[*required, *optional]}")
        return cls(kind=kind, **{name: table[name] for name in (*required, *optional) if name in table})

    def parameters(self) -> dict[str, float]:
        """The law's own parameters, by name (stresses [MPa])."""
        required, optional = LAW_PARAMETERS[self.kind]
        return {name: float(getattr(self, name)) for name in (*required, *optional)}

    def formula(self) -> str:
        """The law with its numbers, in words, e.g. `σ = 400·ε^0.17 MPa`."""
        p = self.parameters()
        if self.kind == "hollomon":
            return f"σ = {p['k_mpa']:g}·ε^{p['n']:g} MPa"
        if self.kind == "swift":
            return f"σ = {p['k_mpa']:g}·({p['eps0']:g} + ε)^{p['n']:g} MPa"
        power = "" if p["m"] == 1.0 else f"^{p['m']:g}"
        return f"σ = {p['sigma0_mpa']:g} + {p['q_mpa']:g}·(1 - exp(-{p['b']:g}·ε)){power} MPa"

    def stress_mpa(self, strain: float | np.ndarray) -> Any:
        """True flow stress [MPa] at true plastic strain `strain` [-] (a number or an array, >= 0).

        Raises:
            InputError: A negative or non-finite strain.
        """
        eps = np.asarray(strain, dtype=float)
        if not np.all(np.isfinite(eps)) or np.any(eps < 0):
            raise InputError(f"strain = {strain!r}: expected finite values >= 0")
        p = self.parameters()
        if self.kind == "hollomon":
            sigma = p["k_mpa"] * eps ** p["n"]
        elif self.kind == "swift":
            sigma = p["k_mpa"] * (p["eps0"] + eps) ** p["n"]
        else:
            sigma = p["sigma0_mpa"] + p["q_mpa"] * (1.0 - np.exp(-p["b"] * eps)) ** p["m"]
        return float(sigma) if np.ndim(sigma) == 0 else sigma


def parameter_problem(name: str, value: Any) -> str | None:
    """What is wrong with a hardening parameter's value, or None.

    Args:
        name: The parameter (`LAW_PARAMETERS`).
        value: Its value as given.
    """
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return "expected a finite number"
    if value <= 0:
        return "expected a number > 0"
    if name.endswith("_mpa") and value > PA_SUSPECT_MPA:
        return "looks like Pa; expected MPa"
    if name in ("n", "m") and value > 1:
        return "expected an exponent in (0, 1]"
    return None


#: The strains over which a law is read as a power law (`power_law_equivalent`): a SPIF wall's sine-law strains
#: from about 25° to 70° [-].
WALL_STRAINS = (0.1, 1.2)


def power_law_equivalent(
    law: HardeningLaw | None, yield_strength_mpa: float | None, tensile_strength_mpa: float
) -> tuple[float, float] | None:
    """A power law σ = K·ε^n for a material: (K [MPa], n [-]), or None when neither a law nor R_p0.2 is known.

    A law is read by least squares in log-log over `WALL_STRAINS`. Without one, Hollomon's law through the 0.2 %
    proof strength (σ = R_p0.2 at ε = 0.002) and the tensile strength (Considère: the engineering maximum
    R_m = K n^n e^-n at ε = n) gives n from R_m / R_p0.2 = (n / (0.002 e))^n, then K = R_p0.2 / 0.002^n.

    Args:
        law: The material's hardening law, or None.
        yield_strength_mpa: R_p0.2 [MPa], or None.
        tensile_strength_mpa: R_m [MPa].
    """
    if law is not None:
        strain = np.linspace(*WALL_STRAINS, 50)
        n, log_k = np.polyfit(np.log(strain), np.log(law.stress_mpa(strain)), 1)
        return float(np.exp(log_k)), float(n)
    if yield_strength_mpa is None or not 0.0 < yield_strength_mpa < tensile_strength_mpa:
        return None
    from scipy.optimize import brentq  # here: the CLI's parser imports this module and must not import scipy

    def gap(n: float) -> float:  # rises from < 0 at n = 0.002 e to its value at n = 1
        return n * math.log(n / (0.002 * math.e)) - math.log(tensile_strength_mpa / yield_strength_mpa)

    if gap(1.0) < 0.0:
        return None
    n = float(brentq(gap, 0.002 * math.e, 1.0, xtol=1e-12))
    return yield_strength_mpa / 0.002**n, n
