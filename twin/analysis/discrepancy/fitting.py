"""Fit a set of effect families jointly to a run's residual by `scipy.optimize.least_squares`.

The residual is measured minus predicted minus the families' changes, every stream divided by its noise and
stacked in the order of `ResidualModel.vector` (position, force, profile). Parameters with no sensitivity
(e.g. a y force scale when the sheet pushes no y force) are held at their neutral value. The uncertainty of
the others is the Gauss-Newton covariance (J^T J)^-1 scaled by the reduced chi-square of the fit. The
held-out error fits the parameters on one fold (odd passes, x < 0 of the profile) and scores them on the other,
and vice versa, linearised at the full fit (exact for the linear families).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from twin.analysis.discrepancy.context import Context
from twin.analysis.discrepancy.families.base import Delta, Family

STREAMS = ("position", "force", "profile")
UNOBSERVABLE = 1e-6  # a parameter column this much smaller than the largest is not observable


@dataclass(frozen=True)
class Fit:
    """Families fitted jointly.

    Attributes:
        names: Family names, in the order they entered.
        theta: Name -> fitted parameters.
        sigma: Name -> one standard error per parameter (nan: not observable, held neutral).
        covariance: Name -> covariance of its parameters (unobservable rows/columns zero).
        residual: Normalised residual after the fit (stacked streams).
        sse: Its sum of squares.
        heldout: Held-out sum of squares over the two folds.
    """

    names: tuple[str, ...]
    theta: dict[str, np.ndarray]
    sigma: dict[str, np.ndarray]
    covariance: dict[str, np.ndarray]
    residual: np.ndarray
    sse: float
    heldout: float


class Fitter:
    """Fits families on one context: base residual, noise, folds, and each linear family's basis cached."""

    def __init__(
        self, ctx: Context, measured: dict[str, np.ndarray], sigma: dict[str, float], folds: list[np.ndarray]
    ) -> None:
        self.ctx = ctx
        self.sigma = sigma
        self.streams = [s for s in STREAMS if s in ctx.pred]
        self.raw = {s: measured[s] - ctx.pred[s] for s in self.streams}
        self.base = self.stack(self.raw)
        self.folds = folds
        self._basis: dict[tuple[str, float | None], np.ndarray] = {}

    def stack(self, streams: dict[str, np.ndarray]) -> np.ndarray:
        """Normalised, stacked vector of per-stream arrays."""
        return np.concatenate([np.ravel(streams[s]) / self.sigma[s] for s in self.streams])

    def change(self, family: Family, theta: np.ndarray) -> np.ndarray:
        """The family's normalised, stacked change of the prediction."""
        delta: Delta = family.delta(self.ctx, np.asarray(theta, dtype=float))
        parts = []
        for s in self.streams:
            value = getattr(delta, s)
            parts.append(np.zeros(self.raw[s].size) if value is None else np.ravel(value) / self.sigma[s])
        return np.concatenate(parts)

    def basis(self, family: Family, answer: float | None = None) -> np.ndarray:
        """Columns d change / d theta of a linear family (one per parameter), cached.

        For a bilinear family, the columns of its parameters but the last, at w = `answer` (0 or 1).
        """
        key = (family.name, answer)
        if key not in self._basis:
            neutral = np.asarray(family.neutral, dtype=float)
            count = len(family.parameters) - (1 if family.bilinear else 0)
            cols = []
            for i, step in enumerate(family.scale[:count]):
                theta = neutral.copy()
                theta[i] += step
                if family.bilinear:
                    theta[-1] = answer if answer is not None else 1.0
                cols.append(self.change(family, theta) / step)
            self._basis[key] = np.column_stack(cols)
        return self._basis[key]

    def _bilinear_parts(self, family: Family, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(B at w, d change / d w, theta - neutral) of a bilinear family."""
        b0, b1 = self.basis(family, 0.0), self.basis(family, 1.0)
        shift = (theta - np.asarray(family.neutral))[:-1]
        w = float(theta[-1])
        return b0 + w * (b1 - b0), (b1 - b0) @ shift, shift

    def model(self, families: Sequence[Family], x: np.ndarray) -> np.ndarray:
        """Total normalised change of `families` at stacked parameters `x`."""
        total = np.zeros_like(self.base)
        i = 0
        for family in families:
            n = len(family.parameters)
            theta = x[i : i + n]
            if family.bilinear:
                b, _, shift = self._bilinear_parts(family, theta)
                total += b @ shift
            elif family.linear:
                total += self.basis(family) @ (theta - np.asarray(family.neutral))
            else:
                total += self.change(family, theta)
            i += n
        return total

    def fit(self, families: Sequence[Family], starts: dict[str, np.ndarray] | None = None) -> Fit:
        """Fit `families` jointly; `starts` may give starting parameters by name. A family with several starts
        of its own (`Family.starts`, e.g. a clock offset on a force that steps) is refined from each, the other
        families from their first, and the lowest sum of squares is kept."""
        starts = starts or {}
        if not families:
            sse = float(self.base @ self.base)
            return Fit((), {}, {}, {}, self.base, sse, sse)
        options = [
            [np.asarray(starts[f.name], dtype=float)] if f.name in starts else
            [np.asarray(x, dtype=float) for x in f.starts(self.ctx, self.raw)]
            for f in families
        ]
        candidates = [np.concatenate([o[0] for o in options])]
        for k, own in enumerate(options):
            for alternative in own[1:]:
                candidates.append(np.concatenate([alternative if j == k else o[0] for j, o in enumerate(options)]))
        scale = np.concatenate([f.scale for f in families])
        x, free, r = min((self._refine(families, x0) for x0 in candidates), key=lambda out: float(out[2] @ out[2]))
        jac = self.jacobian(families, x, scale)[:, free]
        dof = max(r.size - int(free.sum()), 1)
        cov_free = np.linalg.pinv(jac.T @ jac) * max(float(r @ r) / dof, 1.0)
        cov = np.zeros((x.size, x.size))
        cov[np.ix_(free, free)] = cov_free
        sd = np.where(free, np.sqrt(np.clip(np.diag(cov), 0.0, None)), np.nan)
        heldout = self.heldout(r, jac)
        theta, sigma, covariance = {}, {}, {}
        i = 0
        for f in families:
            n = len(f.parameters)
            theta[f.name], sigma[f.name] = x[i : i + n], sd[i : i + n]
            covariance[f.name] = cov[i : i + n, i : i + n]
            i += n
        return Fit(tuple(f.name for f in families), theta, sigma, covariance, r, float(r @ r), heldout)

    def _refine(self, families: Sequence[Family], x0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Least squares from `x0`: (parameters, which were free, residual)."""
        lower = np.concatenate([f.bounds[0] for f in families])
        upper = np.concatenate([f.bounds[1] for f in families])
        scale = np.concatenate([f.scale for f in families])
        neutral = np.concatenate([f.neutral for f in families])
        jac0 = self.jacobian(families, x0, scale)
        norms = np.linalg.norm(jac0, axis=0)
        weight = np.concatenate([[f.bilinear and j == len(f.parameters) - 1 for j in range(len(f.parameters))]
                                 for f in families])
        free = weight | (norms > UNOBSERVABLE * max(float(norms.max()), 1e-300))
        x0 = np.clip(np.where(free, x0, neutral), lower, upper)

        def full(z: np.ndarray) -> np.ndarray:
            x = x0.copy()
            x[free] = z
            return x

        def fun(z: np.ndarray) -> np.ndarray:
            return self.base - self.model(families, full(z))

        if all(f.linear for f in families):
            solution = least_squares(fun, x0[free], jac=lambda z: -self.jacobian(families, full(z), scale)[:, free],
                                     bounds=(lower[free], upper[free]), x_scale=scale[free], method="trf")
        else:
            solution = least_squares(fun, x0[free], bounds=(lower[free], upper[free]), x_scale=scale[free],
                                     method="trf", diff_step=1e-3 * scale[free] / np.maximum(np.abs(x0[free]), 1.0))
        return full(solution.x), free, fun(solution.x)

    def jacobian(self, families: Sequence[Family], x: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """d model / d x (analytic for linear families, central differences otherwise)."""
        cols = []
        i = 0
        for family in families:
            n = len(family.parameters)
            if family.bilinear:
                b, dw, _ = self._bilinear_parts(family, x[i : i + n])
                cols.extend([b, dw[:, None]])
            elif family.linear:
                cols.append(self.basis(family))
            else:
                for j in range(n):
                    step = np.zeros(x.size)
                    step[i + j] = 0.1 * scale[i + j]
                    cols.append(((self.model(families, x + step) - self.model(families, x - step))
                                 / (2 * step[i + j]))[:, None])
            i += n
        return np.column_stack(cols)

    def heldout(self, r: np.ndarray, jac: np.ndarray) -> float:
        """Sum over folds of the test fold's residual after refitting on the train fold (linearised)."""
        total = 0.0
        for train, test in (self.folds, self.folds[::-1]):
            jt = jac[train]
            step = np.linalg.pinv(jt.T @ jt) @ (jt.T @ r[train])  # normal equations: p is small
            total += float(np.sum((r[test] - jac[test] @ step) ** 2))
        return total
