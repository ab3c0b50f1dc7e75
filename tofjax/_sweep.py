"""Operating points: sweeps over distance, background illuminance or integration time (thesis
§4.2.1.3) or the sensor's temperature (§6.1.2's future work), and any batch of them (an image of
distances)."""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._params import Params
from ._schema import KEY_BY_DOTTED, OPERATING_POINT_COLUMNS, SWEEP_AXES, SWEEPS, check_array, suggest


def _f64(x):
    return jnp.asarray(x, dtype=float)


def _optional_f64(x):
    return None if x is None else jnp.asarray(x, dtype=float)


class Sweep(eqx.Module):
    """The values of one swept quantity; the others stay at the camera's nominal values unless
    given per point (as in a measured file, where each row records its operating point).

    The values may have any shape (``*b``): a 1-D sweep, or e.g. a 2-D image of distances (one
    per pixel); every result field then has that leading shape.

    **Fields:**
    - ``variable``: ``"distance"`` (m), ``"illuminance"`` (lx), ``"integration_time"`` (s) or
      ``"temperature"`` (the sensor's, °C); static (:data:`tofjax.schema.SWEEP_AXES`).
    - ``values``: the values, shape ``(*b)``, in SI units (°C for the temperature); traced, so a
      gradient with respect to e.g. the distance is available.
    - ``distance_m``, ``illuminance_lx``, ``integration_time_s``, ``temperature_c``: optional
      per-point values of the quantities that are not swept (``None``: the camera's nominal value,
      ``scene.<column>`` or ``pixel.temperature_c``), shape ``(*b)``. Use :meth:`Sweep.points` to
      build a sweep from the operating point's columns.
    """

    variable: str = eqx.field(static=True)
    values: Float[Array, "*b"] = eqx.field(converter=_f64)
    distance_m: Float[Array, "*b"] | None = eqx.field(default=None, converter=_optional_f64)
    illuminance_lx: Float[Array, "*b"] | None = eqx.field(default=None, converter=_optional_f64)
    integration_time_s: Float[Array, "*b"] | None = eqx.field(default=None, converter=_optional_f64)
    temperature_c: Float[Array, "*b"] | None = eqx.field(default=None, converter=_optional_f64)

    def __check_init__(self):
        if self.variable not in SWEEPS:
            raise ValueError(
                f"sweep = {self.variable!r} is not allowed: expected one of "
                + ", ".join(repr(s) for s in SWEEPS) + suggest(self.variable, SWEEPS)
            )
        if self.values.ndim < 1 or self.values.size < 1:
            raise ValueError(f"sweep values must be a non-empty array of at least one dimension, got shape "
                             f"{self.values.shape}")
        axis = SWEEP_AXES[self.variable]
        check_array(axis.section, axis.column, self.values)
        for axis in SWEEP_AXES.values():
            column = getattr(self, axis.column)
            if column is None:
                continue
            if column.shape != self.values.shape:
                raise ValueError(f"sweep {axis.column} has shape {column.shape}, the sweep values {self.values.shape}")
            check_array(axis.section, axis.column, column)

    @classmethod
    def points(cls, variable: str, distance_m, illuminance_lx, integration_time_s, temperature_c=None) -> Sweep:
        """A sweep whose every point sets the operating-point quantities (``temperature_c``
        ``None``: the pixel's ``temperature_c`` at every point)."""
        columns = {"distance_m": distance_m, "illuminance_lx": illuminance_lx, "integration_time_s": integration_time_s,
                   "temperature_c": temperature_c}
        if variable not in SWEEP_AXES:
            raise ValueError(f"sweep = {variable!r} is not allowed: expected one of "
                             + ", ".join(repr(s) for s in SWEEPS) + suggest(variable, SWEEPS))
        if columns[SWEEP_AXES[variable].column] is None:
            raise ValueError(f"Sweep.points: a {variable} sweep needs its {SWEEP_AXES[variable].column} column")
        return cls(variable, columns[SWEEP_AXES[variable].column], **columns)

    @classmethod
    def linspace(cls, variable: str, start: float, stop: float, samples: int) -> Sweep:
        """``samples`` equally spaced values from ``start`` to ``stop`` (both included)."""
        if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
            raise ValueError(f"samples = {samples!r} is out of range: allowed integer >= 1")
        key = KEY_BY_DOTTED.get(SWEEP_AXES[variable].key) if variable in SWEEP_AXES else None
        if key is not None and samples > 1 and not start < stop:
            raise ValueError(f"sweep from = {start!r} must be less than to = {stop!r} ({key.unit})")
        return cls(variable, np.linspace(start, stop, samples))

    @property
    def shape(self) -> tuple[int, ...]:
        """The batch shape of the operating points."""
        return tuple(self.values.shape)

    @property
    def samples(self) -> int:
        """The number of operating points."""
        return math.prod(self.values.shape)

    def operating_points(self, params: Params) -> tuple[Array, Array, Array, Array]:
        """(distance_m, illuminance_lx, integration_time_s, temperature_c), each of the sweep's
        shape: the swept values, the per-point columns given, and ``params``' nominal values
        (``scene.distance_m``, ..., ``pixel.temperature_c``) for the rest."""
        out = []
        for variable, axis in SWEEP_AXES.items():
            name = axis.column
            given = getattr(self, name)
            if variable == self.variable:
                out.append(self.values)
            elif given is not None:
                out.append(given)
            else:
                out.append(jnp.broadcast_to(getattr(getattr(params, axis.section), name), self.values.shape))
        return tuple(out)


def check_inputs(params, sweep) -> None:
    """Type checks of the public entry points' first arguments."""
    if not isinstance(params, Params):
        raise TypeError(f"params must be a tofjax.Params, got {type(params).__name__}")
    if not isinstance(sweep, Sweep):
        raise TypeError(f"sweep must be a tofjax.Sweep, got {type(sweep).__name__}")


#: The fewest points a 1-D sweep runs as (:func:`padded_samples`).
MIN_PADDED_POINTS = 16
#: Longer sweeps run unpadded (:func:`padded_samples`).
MAX_PADDED_POINTS = 4096


def padded_samples(n: int) -> int:
    """The number of operating points a 1-D sweep of ``n`` runs as in :func:`tofjax.predict`. Its
    compiled programs take the sweep's length as static, so every length would compile anew (1.5 s
    at the test suite's XLA settings, more at the default ones); padded to a power of two of at
    least 16, sweeps of 1-16 points share one program, of 17-32 the next, and so on (a session
    sweeping 10, 12 and 13 points compiles once), at a cost of microseconds. Beyond 4096 points a
    sweep runs as it is: there a long run pays for the padded points at every call, and such runs
    repeat one length."""
    if n > MAX_PADDED_POINTS:
        return n
    return max(MIN_PADDED_POINTS, 1 << (n - 1).bit_length())


def _on_device_of(array, host: np.ndarray):
    """``host`` put on the device that holds ``array``."""
    return jax.device_put(host, next(iter(array.devices())))


def pad_sweep(sweep: Sweep) -> Sweep:
    """A 1-D ``sweep`` of concrete values padded to :func:`padded_samples` points with copies of its
    last point (the points are independent; :func:`tofjax._depth.unwrap_along_sweep` runs from the
    first point, so a tail changes nothing before it); a sweep of another shape unchanged (no sweep
    order, and an image's shape is the user's)."""
    extra = padded_samples(sweep.samples) - sweep.samples
    if len(sweep.shape) != 1 or extra == 0:
        return sweep

    def pad(x):  # on the host: an array operation would compile for each new length
        if x is None:
            return None
        host = np.asarray(x)
        return _on_device_of(x, np.concatenate([host, np.repeat(host[-1:], extra)]))

    return Sweep(sweep.variable, pad(sweep.values), **{name: pad(getattr(sweep, name)) for name in OPERATING_POINT_COLUMNS})


def unpad(tree, sweep: Sweep, padded: Sweep, axis: int = 0):
    """``tree``, a result of ``padded`` (:func:`pad_sweep` of ``sweep``), with the padding cut from
    every array leaf's points axis ``axis`` (1: a multi-frequency result's per-frequency leaves, after
    the frequencies' axis); leaves of no more than ``axis`` dimensions (per call, e.g. the unambiguity
    range) kept."""
    if padded is sweep:
        return tree
    n = sweep.samples

    def cut(x):  # sliced on the host: a slice would compile for each new length
        return _on_device_of(x, np.asarray(x)[(slice(None),) * axis + (slice(n),)]) if jnp.ndim(x) > axis else x

    return jax.tree_util.tree_map(cut, tree)
