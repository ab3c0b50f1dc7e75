"""Free parameters: dotted configuration names, bounds, priors and smooth bijective transforms.

A parameter bounded on both sides is fitted as u with theta = lo + (hi - lo) sigmoid(u); bounded
below only, theta = lo + exp(u); unbounded, theta = u. The bounds are never enforced by clipping,
so the optimiser and the sampler see a smooth, unconstrained problem.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
from tofjax.schema import KEY_BY_DOTTED, SWEEP_AXES, float_leaf_names, suggest

#: Operating-point quantities: per-row inputs of a sweep file (the sensor's temperature included:
#: a file's ``temperature_c`` column, or the configured one at every row), never fitted.
OPERATING_POINT = tuple(axis.key for axis in SWEEP_AXES.values())


def fittable_names() -> tuple[str, ...]:
    """Every float configuration key that is a leaf of the parameter pytree, except the operating
    point (a per-row input of the sweep files)."""
    return tuple(name for name in float_leaf_names() if name not in OPERATING_POINT)


class CalibrationInputError(ValueError):
    """A bad calibration input: parameter name, bound, prior, initial value or data."""


@dataclasses.dataclass(frozen=True)
class FreeParameter:
    """One fitted parameter.

    **Fields:**
    - ``name``: dotted configuration key, e.g. ``pixel.demodulation_contrast``.
    - ``lower``, ``upper``: bounds (``None``: unbounded on that side).
    - ``initial``: starting value (from the configuration), strictly inside the bounds.
    - ``prior``: ``None`` (uniform within the bounds) or ``(mean, sigma)`` of a Gaussian prior.
    """

    name: str
    lower: float | None
    upper: float | None
    initial: float
    prior: tuple[float, float] | None = None

    @property
    def section(self) -> str:
        return self.name.split(".")[0]

    @property
    def field(self) -> str:
        return self.name.split(".")[1]

    @property
    def unit(self) -> str:
        return KEY_BY_DOTTED[self.name].unit

    def to_unconstrained(self, theta: float) -> float:
        lo, hi = self.lower, self.upper
        if lo is not None and hi is not None:
            x = (theta - lo) / (hi - lo)
            return math.log(x) - math.log1p(-x)
        if lo is not None:
            return math.log(theta - lo)
        return theta

    def to_constrained(self, u):
        lo, hi = self.lower, self.upper
        if lo is not None and hi is not None:
            return lo + (hi - lo) * jax.nn.sigmoid(u)
        if lo is not None:
            return lo + jnp.exp(u)
        return u

    def log_abs_jacobian(self, u):
        """log |d theta / d u|, for densities in the unconstrained space."""
        lo, hi = self.lower, self.upper
        if lo is not None and hi is not None:
            return math.log(hi - lo) - jax.nn.softplus(-u) - jax.nn.softplus(u)
        if lo is not None:
            return u
        return jnp.zeros_like(u)


def make_parameters(
    names, initial_values: dict[str, float], bounds: dict[str, tuple[float, float]] | None = None,
    priors: dict[str, tuple[float, float]] | None = None,
) -> tuple[FreeParameter, ...]:
    """Validate names, bounds, priors and initial values and build the free parameters.

    Default bounds are the configuration's validation range; overrides must lie inside it.
    """
    bounds, priors = dict(bounds or {}), dict(priors or {})
    allowed = fittable_names()
    names = list(names)
    if not names:
        raise CalibrationInputError("no parameter to fit: give at least one name with --fit")
    for option, group in (("--fit", names), ("--bounds", bounds), ("--prior", priors)):  # named as on the CLI
        for name in group:
            if name in OPERATING_POINT:
                raise CalibrationInputError(f"{option}: {name} is not fittable: it is an operating-point column of the "
                                            "sweep files (a per-row input), not a parameter")
            if name in KEY_BY_DOTTED and name not in allowed:
                kind = KEY_BY_DOTTED[name].kind
                what = {"int": "an integer", "bool": "true/false", "choice": "a choice"}.get(kind, f"a {kind}")
                raise CalibrationInputError(f"{option}: {name} is not fittable ({what}; only real-valued keys are): "
                                            "set it in the configuration instead")
            if name not in allowed:
                raise CalibrationInputError(f"{option}: unknown parameter {name!r}{suggest(name, allowed)}; fittable: "
                                            + ", ".join(allowed))
    if len(set(names)) != len(names):
        raise CalibrationInputError(f"parameter named twice in {names}")
    for name in [*bounds, *priors]:
        if name not in names:
            raise CalibrationInputError(f"bounds or prior given for {name!r}, which is not fitted (--fit)")
    out = []
    for name in names:
        key = KEY_BY_DOTTED[name]
        lo, hi = bounds.get(name, (key.lo, key.hi))
        if lo is not None and hi is not None and not lo < hi:
            raise CalibrationInputError(f"bounds of {name} are reversed or empty: lower = {lo!r}, upper = {hi!r}")
        for value, side in ((lo, "lower"), (hi, "upper")):
            if value is not None and ((key.lo is not None and value < key.lo) or (key.hi is not None and value > key.hi)):
                raise CalibrationInputError(
                    f"{side} bound of {name} = {value!r} is outside the physical range: allowed {key.range_text()}")
        initial = float(initial_values[name])
        if (lo is not None and not initial > lo) or (hi is not None and not initial < hi):
            raise CalibrationInputError(
                f"initial value of {name} = {initial!r} is not strictly inside its bounds [{lo!r}, {hi!r}]: give a "
                f"starting value with --initial {name}=VALUE (or set it in the configuration)"
                + (" (0 there means 'not given': pick a data sheet's value)" if initial == 0 else ""))
        prior = priors.get(name)
        if prior is not None and not (math.isfinite(prior[0]) and prior[1] > 0 and math.isfinite(prior[1])):
            raise CalibrationInputError(f"prior of {name} = {prior!r} needs a finite mean and a sigma > 0")
        out.append(FreeParameter(name, lo, hi, initial, prior))
    return tuple(out)
