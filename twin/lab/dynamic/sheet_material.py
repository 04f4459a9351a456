"""The material of the plant's sheet law 1 (`twin.lab.dynamic.sheet`): the thesis's measured flow curve and the
alloy's elastic constants, the plant's own (the twin's material library is not read)."""

from __future__ import annotations

import numpy as np

#: Thesis Eq. 1.3: the measured AA5086-H111 flow curve, sigma = S0 + Q (1 - exp(-B eps))^M [MPa].
VOCE_S0_MPA, VOCE_Q_MPA, VOCE_B, VOCE_M = 130.2, 300.37, 3.94, 0.5
#: Young's modulus [Pa] (SubsTech 5086) and Poisson's ratio [-] (ASM/MatWeb 5086-H116).
YOUNGS_MODULUS_PA, POISSON_RATIO = 71.0e9, 0.33


def voce_mpa(eps: np.ndarray | float) -> np.ndarray:
    """The thesis's AA5086-H111 flow stress [MPa] at true plastic strain `eps` [-]."""
    e = np.maximum(np.asarray(eps, dtype=float), 0.0)
    return VOCE_S0_MPA + VOCE_Q_MPA * (1.0 - np.exp(-VOCE_B * e)) ** VOCE_M


def voce_tensile_strength_mpa() -> float:
    """The Voce law's engineering tensile strength [MPa]: sigma exp(-eps) at necking, d sigma/d eps = sigma."""
    eps = np.linspace(1e-4, 1.0, 20001)
    return float(np.max(voce_mpa(eps) * np.exp(-eps)))
