"""The calibration problem: free parameters, data rows, and the whitened residuals.

The model side is :func:`tofjax.predict` (analytic path) in the smooth mode, so the residuals are
differentiable everywhere, including near saturation. Residual = (model - data) / sigma, for the
amplitude (LSB), the depth standard deviation (m) and the mean depth reading (m; the model's taken in
the period nearest the data's) of every row that enters the fit.

A camera that delivered a row was neither saturated nor at an ADC rail there: with
:attr:`Problem.validity` (the default) every row that enters the fit also has a one-sided residual
(:data:`VALID_MARGIN` - h) / :data:`VALID_SCALE` where its headroom h (:attr:`tofjax.Result.headroom`,
the nearest hard limit's distance as a fraction of its range, from the chain's own limit and readout
stages) falls below the margin, 0 elsewhere: a penalty that holds the solution where the hard
model measures every row, and that is 0 (with a 0 Jacobian) wherever it holds, so it changes
neither chi^2 nor the covariance of a fit that stays inside.

A file's bounds (format 4, a datasheet's promise: :class:`fitting._data.Bound`) are one-sided
constraints of the same kind: per bound row, a residual (ln(model / bound) + :data:`BOUND_MARGIN`) /
:data:`BOUND_SCALE` for an upper bound (ln(bound / model) + the margin for a lower one) where it is
positive, 0 elsewhere (with a 0 Jacobian). Near the bound that is (model - bound) / (1e-4 bound): a
bound broken by 0.01 % costs one standard deviation, and the solution is held 0.1 % inside it (so a
strict bound, ``lt``, is met too, and the hard model judges the same as the smooth one). The
logarithm keeps a bound broken 50-fold well-conditioned: the residual is linear in the log of a
power law's parameter (the depth noise goes as a power of the illumination's power), where a
difference would be quadratic in its excess. The quantity is judged as ``tofjax compare`` judges
it (:func:`fitting.check_bounds`): the depth noise, the amplitude, and the depth error as the
camera's reading (wrapped by its own frequencies) minus the true distance. A bound row also carries
the validity residual above: the specification promises a depth there. With no measured row at all
(bounds only) the problem minimises the change from the starting configuration: a residual per
free parameter, (t(theta) - t(start)) / w with t = ln and w = ln 2 for a positive parameter (a
factor 2 either way costs one standard deviation, alike at any value), t = theta and w a tenth of
its allowed interval otherwise (:data:`ANCHOR_LOG_WIDTH`, :data:`ANCHOR_LINEAR_WIDTH`), and any ``--prior``'s (theta - mean) /
sigma; with measured rows those residuals weigh 0 (:attr:`Problem.anchor_weight`, an array: the same
program) and the bounds constrain the ordinary fit.

Compiled once per structure. Files taken with the same camera (equal parameters; they differ only in
their operating points, which are per-row inputs, and in their background lamp) form a group whose
rows are concatenated into one sweep, so one :func:`tofjax.predict` evaluates the whole group. A file
under another lamp than the group's joins it with its illuminance rescaled to the group's lamp: the
model reads the illuminance only through the in-band photon irradiance, which is linear in it
(§3.1.2, Eq 3.4), so E lx of lamp L give what E k_L / k_0 lx of the group's lamp give (k: in-band
photons per lux through the filter, weighted by the sensor's spectral response). The ratio is fixed by the
filter and the response, so files under different lamps keep groups of their own when the filter's band
or the response is fitted (:data:`BAND_PARAMETERS`). The dense curves the figures draw
(:data:`DENSE_POINTS` per file) ride along as extra rows of the same call. Bounds, priors, starting
values, operating points and data are arrays, so a new data set of the same shape, or other bounds,
reuse the compiled programs; only the parameter names, the groups and the row counts are structure.

One program, :func:`linearize`, gives the residuals, their Jacobian, the model values and the dense
curves with their Jacobian at a point: the least squares (:mod:`fitting._least_squares`) steps on it,
and the covariance, the residual summary and the figures read it at the solution.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import tofjax as tj
from jaxtyping import Array, Float
from tofjax.schema import OPERATING_POINT_COLUMNS, set_leaves

from ._data import OBSERVABLES, SweepRows
from ._parameters import FreeParameter

#: Points of the dense model curve per file (the figures).
DENSE_POINTS = 160
#: The headroom (a fraction of the nearest limit's range) the validity penalty holds every used row
#: above, and the headroom shortfall that costs one standard deviation (module docstring).
VALID_MARGIN = 1e-3
VALID_SCALE = 1e-4
#: How far inside a bound the bound residual holds the model (a fraction of the bound: ln(model /
#: bound) below -BOUND_MARGIN for an upper one), and the excess over that which costs one standard
#: deviation (module docstring).
BOUND_MARGIN = 1e-3
BOUND_SCALE = 1e-4
#: A bound is active at a solution (met with equality) where the hard model lies within this fraction
#: of it: twice the hold, as the validity's edge.
BOUND_ACTIVE = 2 * BOUND_MARGIN
#: The smooth model's margin where it has no positive value for a bound that needs one (a lower bound
#: on an amplitude of 0): ln of a factor e^50, finite so that the residuals stay numbers.
NO_VALUE = 50.0
#: The width of the change residual of a positive parameter (bounds only): a factor 2 either way
#: is one standard deviation.
ANCHOR_LOG_WIDTH = float(np.log(2.0))
#: Of a parameter that may be zero or negative: this fraction of its allowed interval (or 1 in its
#: unit where the interval is open).
ANCHOR_LINEAR_WIDTH = 0.1


def nearest_period(depth, reference, period):
    """``depth`` moved by whole ``period``s to the one nearest ``reference`` (a reading wraps at the
    unambiguity range, or at the fused frequencies' extended range). Traced or host arrays (those in
    NumPy: JAX would compile each operation for each shape)."""
    if any(isinstance(x, jax.core.Tracer) for x in (depth, reference, period)):
        return depth + period * jnp.round((reference - depth) / period)
    depth, reference, period = (np.asarray(x) for x in (depth, reference, period))
    return depth + period * np.round((reference - depth) / period)


def dense_sweep(s: tj.Sweep, n: int = DENSE_POINTS) -> dict[str, np.ndarray]:
    """Operating points along a file's swept quantity (its rows' sweep ``s``), ``n`` of them,
    interpolated between its rows."""
    order = np.argsort(np.asarray(s.values))
    x = np.asarray(s.values)[order]
    grid = np.linspace(x[0], x[-1], n)
    return {name: np.interp(grid, x, np.asarray(getattr(s, name))[order]) for name in OPERATING_POINT_COLUMNS}


class Observables(eqx.Module):
    """What a sweep file's camera reports, predicted: amplitude mean and standard deviation (of the
    first frequency), the depth mean (with wiggling; wrapped into the unambiguity range, or fused
    and unwrapped over the extended range for several frequencies)
    and standard deviation (fused), and whether the hard model can measure the point (with a smooth
    relaxation: the relaxed statistics, and ``valid`` from the relaxed flags)."""

    amplitude_mean_lsb: Array
    amplitude_std_lsb: Array
    depth_mean_m: Array
    depth_std_m: Array
    valid_fraction: Array
    pixel_saturated_fraction: Array
    adc_saturated_fraction: Array
    caveats: Array  # tofjax.schema.CAVEATS bits (of any frequency)
    headroom: Array  # tofjax.Result.headroom (the smallest of any frequency)
    period_m: Array  # the depth reading's period: the unambiguity range, or the frequencies' extended range


def observables(params: tj.Params, sweep: tj.Sweep, frequencies_hz: tuple[float, ...], fusion: str,
                smooth: tj.Smooth | None, processing: tuple = ()) -> Observables:
    """:class:`Observables` of one camera: :func:`tofjax.predict`, or
    :func:`tofjax.predict` of a multi-frequency camera for several frequencies (its fused depth noise);
    ``processing``: the camera's own processing stages (what it delivers)."""
    if len(frequencies_hz) < 2:
        r = tj.predict(tj.Camera(params, smooth=smooth, processing=processing), sweep)
        return Observables(r.amplitude_mean_lsb, r.amplitude_std_lsb, r.depth_mean_m, r.depth_std_m,
                           r.valid_fraction, r.pixel_saturated_fraction, r.adc_saturated_fraction, r.caveats,
                           r.headroom, r.unambiguity_range_m)
    m = tj.predict(tj.Camera(params, smooth=smooth, frequencies_hz=frequencies_hz, fusion=fusion,
                             processing=processing), sweep)
    p = m.per_frequency
    caveats = p.caveats[0]
    for k in range(1, len(frequencies_hz)):
        caveats = caveats | p.caveats[k]
    return Observables(p.amplitude_mean_lsb[0], p.amplitude_std_lsb[0], m.depth_mean_m, m.depth_std_m,
                       m.valid_fraction, jnp.max(p.pixel_saturated_fraction, axis=0),
                       jnp.max(p.adc_saturated_fraction, axis=0), caveats, jnp.min(p.headroom, axis=0),
                       m.extended_range_m)


#: :func:`hard_observables` runs a multiple of this many operating points, so that the checks at the
#: solution (a group's rows) and the comparisons (a file's rows and dense points) share its programs.
HARD_BUCKET = 256


def hard_observables(params: tj.Params, sweep: tj.Sweep, frequencies_hz: tuple[float, ...], fusion: str,
                     processing: tuple = ()) -> Observables:
    """:func:`observables` of the hard model (no relaxation), compiled: what the camera can measure.
    ``sweep`` is 1-D; it runs padded to a multiple of :data:`HARD_BUCKET` points (copies of its last
    one), and the result (host arrays) has its own points only."""
    n = sweep.samples
    extra = -n % HARD_BUCKET
    pad = lambda x: np.concatenate([np.asarray(x), np.repeat(np.asarray(x)[-1:], extra)])  # noqa: E731
    padded = tj.Sweep.points(sweep.variable, *(pad(getattr(sweep, name)) for name in OPERATING_POINT_COLUMNS))
    obs = jax.device_get(_hard_observables(params, padded, frequencies_hz, fusion, processing))
    return jax.tree_util.tree_map(lambda x: x[:n] if np.ndim(x) else x, obs)  # the period: one number


@tj.jit
def _hard_observables(params: tj.Params, sweep: tj.Sweep, frequencies_hz: tuple[float, ...], fusion: str,
                      processing: tuple = ()) -> Observables:
    return observables(params, sweep, frequencies_hz, fusion, None, processing)


class FileGroup(eqx.Module):
    """Files taken with one camera, their rows concatenated.

    ``files`` (static) are the files' indices in the problem and ``bounds`` their row ranges in the
    group; ``params`` the camera; ``sweep`` the concatenated operating points, the data rows first
    (``n_data`` of them), then :data:`DENSE_POINTS` dense points per file; ``values`` and ``masks``
    per observable, and ``frames``, over the data rows; ``frequencies_hz`` and ``fusion`` the
    files' modulation frequencies and how their camera fused them (static); ``processing`` the
    camera's own processing stages; ``lamp_scale`` per point
    of ``sweep``, the ratio that restates a file's illuminance in lux of ``params``' lamp (module
    docstring; 1 for files under that lamp). ``sweep`` holds the files' own values (the figures' x);
    :meth:`model_sweep` the rescaled ones.
    """

    files: tuple[int, ...] = eqx.field(static=True)
    bounds: tuple[tuple[int, int], ...] = eqx.field(static=True)
    n_data: int = eqx.field(static=True)
    frequencies_hz: tuple[float, ...] = eqx.field(static=True)
    fusion: str = eqx.field(static=True)
    params: tj.Params
    sweep: tj.Sweep
    values: tuple[Array, ...]
    masks: tuple[Array, ...]
    frames: Array
    lamp_scale: Array  # per point of ``sweep``: k_L / k_0 of its file's lamp (1 under the group's lamp)
    processing: tuple = ()
    #: The bounds its files state, one slot per (quantity, upper) (static), each the tightest of its
    #: files' columns per data row (``bound_values``; ``bound_masks``: where a row states one).
    bound_slots: tuple[tuple[str, bool], ...] = eqx.field(static=True, default=())
    bound_values: tuple[Array, ...] = ()
    bound_masks: tuple[Array, ...] = ()

    def model_sweep(self, dense: bool = True) -> tj.Sweep:
        """The operating points the model runs at: the files' own, each file's illuminance in lux
        of the group's lamp (module docstring); the data rows, and with ``dense`` the dense points."""
        n = self.sweep.samples if dense else self.n_data
        d, e, t, temperature = (getattr(self.sweep, name)[:n] for name in OPERATING_POINT_COLUMNS)
        return tj.Sweep.points("distance", d, e * self.lamp_scale[:n], t, temperature)


#: Free parameters that set the filter's band or the sensor's spectral response, and with them how
#: the lamps' detected photons per lux compare: with one of them fitted, files under different lamps
#: keep groups of their own.
BAND_PARAMETERS = ("illumination.wavelength_m", "scene.filter_half_width_m", "pixel.collection_depth_m")


@tj.jit
def _photons_per_lux(params: tj.Params, lamps: tuple[str, ...]):
    """Detected in-band background photon irradiance per lux of each of ``lamps`` through ``params``'
    filter and spectral response (the model's, tofjax's ``scene_photon_irradiance``), 1/(s m^2 lx):
    one program, where its operations each compiled one."""
    return jnp.stack([tj.optics.background_photon_irradiance(lamp, 1.0, params.illumination.wavelength_m,
                                                             params.scene.filter_half_width_m, params.constants,
                                                             params.pixel.collection_depth_m) for lamp in lamps])


def _under_lamp(params: tj.Params, lamp: str) -> tj.Params:
    return eqx.tree_at(lambda p: p.scene, params, dataclasses.replace(params.scene, background=lamp))


def _same_camera(a: tj.Params, b: tj.Params) -> bool:
    leaves_a, tree_a = jax.tree_util.tree_flatten(a)
    leaves_b, tree_b = jax.tree_util.tree_flatten(b)
    return tree_a == tree_b and all(np.array_equal(np.asarray(x), np.asarray(y)) for x, y in zip(leaves_a, leaves_b, strict=True))


def _lamp_scale(group_params: tj.Params, params: tj.Params, merge_lamps: bool) -> float | None:
    """k_L / k_0 for a file with ``params`` in a group with ``group_params`` (1 under the same lamp),
    or ``None`` where it cannot join: another camera, or another lamp where lamps are not merged or
    either lamp has no photons in the band (no ratio)."""
    lamp, own = group_params.scene.background, params.scene.background
    if lamp == own:
        return 1.0 if _same_camera(group_params, params) else None
    if not merge_lamps or not _same_camera(group_params, _under_lamp(params, lamp)):
        return None
    return _lamp_ratio(group_params, lamp, own)


def _lamp_ratio(params: tj.Params, lamp: str, own: str) -> float | None:
    """k_own / k_lamp through ``params``' filter and response: lux of ``own`` restated in lux of
    ``lamp``; ``None`` where either lamp has no photons in the band (no ratio)."""
    k0, k = (float(x) for x in _photons_per_lux(params, (lamp, own)))
    return k / k0 if k0 > 0.0 and k > 0.0 and np.isfinite(k / k0) else None


#: The lamp a comparison models every file under, its illuminance restated in this lamp's lux (as a
#: group does, module docstring): files of one camera under different lamps share one program.
COMMON_LAMP = "sunlight"


def under_common_lamp(params: tj.Params) -> tuple[tj.Params, float]:
    """``params`` under :data:`COMMON_LAMP` and the factor that restates lux of their own lamp in lux of
    that one (``params`` and 1 where the lamps have no ratio: no photons of one of them in the band)."""
    if params.scene.background == COMMON_LAMP:
        return params, 1.0
    common = _under_lamp(params, COMMON_LAMP)  # the same camera by construction: nothing to compare
    scale = _lamp_ratio(common, COMMON_LAMP, params.scene.background)
    return (params, 1.0) if scale is None else (common, scale)


#: Free parameters that set the reading's period (the unambiguity range): with one of them fitted, an
#: accuracy bound beyond the range stays in the fit (:func:`wrapped_rows`).
PERIOD_PARAMETERS = ("illumination_waveform.modulation_frequency_hz",)


def reading_period(params: tj.Params, frequencies_hz) -> float:
    """The period a camera of ``params`` measuring at ``frequencies_hz`` reads depth in, m: its
    unambiguity range c / (2 f), or the extended range of its frequencies."""
    c = float(params.constants.speed_of_light_m_per_s)
    freqs = tuple(frequencies_hz) or (float(params.illumination_waveform.modulation_frequency_hz),)
    return float(tj.stats.extended_range_m(freqs, c)) if len(freqs) > 1 else c / (2.0 * freqs[0])


def wrapped_rows(r: SweepRows) -> np.ndarray:
    """Rows of ``r`` at or beyond its camera's reading period: its reading wraps there and is short by
    the period, so no parameter but the frequency meets an accuracy bound (``depth_error_m``) there."""
    return np.asarray(r.sweep.distance_m) >= reading_period(r.params, r.frequencies_hz)


def _groups(rows: list[SweepRows], merge_lamps: bool = True, keep_wrapped: bool = False) -> tuple[FileGroup, ...]:
    members: list[list[tuple[int, float]]] = []  # per group: (file, lamp scale)
    for i, r in enumerate(rows):
        for group in members:
            first = rows[group[0][0]]
            scale = _lamp_scale(first.params, r.params, merge_lamps) if (
                (first.frequencies_hz, first.fusion) == (r.frequencies_hz, r.fusion)
                and eqx.tree_equal(first.processing, r.processing) is True) else None
            if scale is not None:
                group.append((i, scale))
                break
        else:
            members.append([(i, 1.0)])
    groups = []
    slots_of = lambda i: {(b.quantity, b.upper) for b in rows[i].bounds}  # noqa: E731
    for joined in members:
        group = [i for i, _ in joined]
        cat = lambda xs: jnp.asarray(np.concatenate([np.asarray(x) for x in xs]))  # noqa: E731
        dense = [dense_sweep(rows[i].sweep) for i in group]
        columns = {name: cat([getattr(rows[i].sweep, name) for i in group] + [d[name] for d in dense])
                   for name in OPERATING_POINT_COLUMNS}
        scales = [np.full(rows[i].n_rows, k) for i, k in joined] + [np.full(DENSE_POINTS, k) for _, k in joined]
        ends = np.cumsum([rows[i].n_rows for i in group])
        groups.append(FileGroup(
            files=tuple(group), bounds=tuple((int(e - rows[i].n_rows), int(e)) for i, e in zip(group, ends, strict=True)),
            n_data=int(ends[-1]), frequencies_hz=tuple(rows[group[0]].frequencies_hz) or (
                float(rows[group[0]].params.illumination_waveform.modulation_frequency_hz),),
            fusion=rows[group[0]].fusion, params=rows[group[0]].params,
            # The swept variable only names the rows' order; the concatenated rows are operating points.
            sweep=tj.Sweep.points("distance", **columns),
            values=tuple(cat([np.where(rows[i].data[o][1], rows[i].data[o][0], 0.0) for i in group]) for o in OBSERVABLES),
            masks=tuple(cat([rows[i].data[o][1] for i in group]) for o in OBSERVABLES),
            frames=cat([np.nan_to_num(np.asarray(rows[i].frames, dtype=float)) for i in group]),
            lamp_scale=cat(scales), processing=rows[group[0]].processing,
            **_bound_arrays(sorted(set().union(*(slots_of(i) for i in group))), [rows[i] for i in group],
                            keep_wrapped)))
    return tuple(groups)


def tightest(r: SweepRows, quantity: str, upper: bool) -> tuple[np.ndarray, list[str | None]]:
    """Per row of ``r``, the tightest of its bounds on ``quantity`` from the side ``upper`` (NaN
    where none) and the column that states it (``None`` where none)."""
    values, columns = np.full(r.n_rows, np.nan), np.full(r.n_rows, None, dtype=object)
    for b in r.bounds:
        if (b.quantity, b.upper) == (quantity, upper):
            with np.errstate(invalid="ignore"):
                tighter = np.isfinite(b.values) & (np.isnan(values) | ((b.values < values) if upper else (b.values > values)))
            values[tighter], columns[tighter] = b.values[tighter], b.column
    return values, list(columns)


def _bound_arrays(slots: list[tuple[str, bool]], files: list[SweepRows], keep_wrapped: bool = False) -> dict:
    """:class:`FileGroup`'s bound fields of ``files`` (its members, in order); an accuracy bound where
    the reading wraps (:func:`wrapped_rows`) is left out unless ``keep_wrapped``: it would only add a
    constant to the sum of squares, whose rounding then hides the steps of the bounds that can be met."""
    values, masks = [], []
    for quantity, upper in slots:
        per_row = np.concatenate([np.where(wrapped_rows(r) & (quantity == "depth_error_m") & (not keep_wrapped), np.nan,
                                           tightest(r, quantity, upper)[0]) for r in files])
        values.append(jnp.asarray(np.where(np.isfinite(per_row), per_row, 1.0)))
        masks.append(jnp.asarray(np.isfinite(per_row)))
    return {"bound_slots": tuple(slots), "bound_values": tuple(values), "bound_masks": tuple(masks)}


class Problem(eqx.Module):
    """Free parameters plus prepared sweeps (build with :func:`fitting.build_problem`).

    Every file contributes one residual slot per row and observable; rows that do not enter the
    fit are masked (residual 0), so the shapes depend only on the files' row counts and a new data
    realisation does not recompile.
    """

    names: tuple[str, ...] = eqx.field(static=True)
    units: tuple[str, ...] = eqx.field(static=True)
    kinds: tuple[str, ...] = eqx.field(static=True)
    has_relative_error: bool = eqx.field(static=True)
    lower: Float[Array, " params"]
    upper: Float[Array, " params"]
    initial: Float[Array, " params"]
    prior_mean: Float[Array, " params"]
    prior_sigma: Float[Array, " params"]
    relative_error: Float[Array, ""]
    groups: tuple[FileGroup, ...]
    smooth: tj.Smooth
    #: Hold every used row where the hard model measures it (module docstring); ``False``: the data
    #: residuals only (``calibrate(..., leave_out_invalid=True)``).
    validity: bool = eqx.field(static=True, default=True)
    #: Per parameter, whether its change residual is taken in its logarithm (a positive parameter;
    #: module docstring); empty where no file states a bound (no change residuals).
    anchor_log: tuple[bool, ...] = eqx.field(static=True, default=())
    #: The change residuals' start (transformed) and width per parameter, and their weight: 1 with no
    #: measured row (bounds only), 0 otherwise (an array: both share one program).
    anchor_start: Float[Array, " params"] | None = None
    anchor_width: Float[Array, " params"] | None = None
    anchor_weight: Float[Array, ""] | None = None

    @property
    def n_params(self) -> int:
        return len(self.names)

    @property
    def n_files(self) -> int:
        return sum(len(g.files) for g in self.groups)

    @property
    def bounded(self) -> bool:
        """Whether a file states a bound (the problem has bound and change residuals)."""
        return bool(self.anchor_log)

    @property
    def bounds_only(self) -> bool:
        """Whether the problem has bounds and no measured row: it minimises the change from the start."""
        return self.bounded and float(self.anchor_weight) > 0.0

    @property
    def n_slots(self) -> int:
        """The residual vector's length: a slot per row and observable, then (with :attr:`validity`)
        a validity slot per row, a slot per bound slot and row, and (with bounds) a change and a
        prior slot per parameter."""
        data = sum(int(np.size(m)) for g in self.groups for m in g.masks)
        bounds = sum(len(g.bound_slots) * g.n_data for g in self.groups)
        return (data + (sum(g.n_data for g in self.groups) if self.validity else 0) + bounds
                + (2 * self.n_params if self.bounded else 0))

    @property
    def n_residuals(self) -> int:
        """The residuals that count as data (chi^2's degrees of freedom): the measured values, and with
        bounds only the change residuals and the priors'."""
        measured = sum(int(np.sum(np.asarray(m))) for g in self.groups for m in g.masks)
        if not self.bounds_only:
            return measured
        return measured + self.n_params + int(np.sum(np.asarray(self.prior_sigma) > 0))

    # --- the bound transforms: theta = lo + (hi - lo) sigmoid(u), lo + exp(u), or u (FreeParameter)
    def unconstrained(self, theta: Float[Array, " params"]) -> Float[Array, " params"]:
        out = []
        for i, kind in enumerate(self.kinds):
            if kind == "both":
                x = (theta[i] - self.lower[i]) / (self.upper[i] - self.lower[i])
                out.append(jnp.log(x) - jnp.log1p(-x))
            elif kind == "lower":
                out.append(jnp.log(theta[i] - self.lower[i]))
            else:
                out.append(theta[i])
        return jnp.stack(out)

    def initial_unconstrained(self) -> Float[Array, " params"]:
        return _unconstrained(self, self.initial)

    def constrained(self, u: Float[Array, " params"]) -> Float[Array, " params"]:
        out = []
        for i, kind in enumerate(self.kinds):
            if kind == "both":
                out.append(self.lower[i] + (self.upper[i] - self.lower[i]) * jax.nn.sigmoid(u[i]))
            elif kind == "lower":
                out.append(self.lower[i] + jnp.exp(u[i]))
            else:
                out.append(u[i])
        return jnp.stack(out)

    def log_abs_jacobian(self, u: Float[Array, " params"]) -> Float[Array, ""]:
        """log |d theta / d u| summed over the parameters (densities in the unconstrained space)."""
        total = jnp.asarray(0.0)
        for i, kind in enumerate(self.kinds):
            if kind == "both":
                total = total + jnp.log(self.upper[i] - self.lower[i]) - jax.nn.softplus(-u[i]) - jax.nn.softplus(u[i])
            elif kind == "lower":
                total = total + u[i]
        return total

    # --- the model
    def with_values(self, base: tj.Params, theta: Float[Array, " params"]) -> tj.Params:
        """``base`` with the free parameters set to ``theta``."""
        return set_leaves(base, {name: theta[i] for i, name in enumerate(self.names)})

    def predict_group(self, theta: Float[Array, " params"], group: FileGroup, *, dense: bool = True) -> Observables:
        """The model of ``group``'s camera at ``theta`` (smooth mode) on its data rows, and with
        ``dense`` also on its dense points (after the data rows)."""
        return observables(self.with_values(group.params, theta), group.model_sweep(dense), group.frequencies_hz,
                           group.fusion, self.smooth, group.processing)

    def _rows(self, r: Observables, group: FileGroup):
        """Per observable (:data:`~fitting._data.OBSERVABLES`), (model, uncertainty) on the data rows of
        a group's result. The model's mean reading is taken in the period nearest the measured one
        (a reading wraps at the unambiguity range), so that its residual is the difference of the
        systematic errors."""
        n = group.frames
        amp_std, depth_std = r.amplitude_std_lsb[: group.n_data], r.depth_std_m[: group.n_data]
        if self.has_relative_error:
            sigmas = tuple(self.relative_error * jnp.abs(v) for v in group.values)
        else:
            sigmas = (amp_std / jnp.sqrt(jnp.maximum(n, 1.0)), depth_std / jnp.sqrt(2.0 * jnp.maximum(n - 1.0, 1.0)),
                      depth_std / jnp.sqrt(jnp.maximum(n, 1.0)))  # standard errors of a mean, a std, a mean
        mean = nearest_period(r.depth_mean_m[: group.n_data], group.values[2], r.period_m)
        models = (r.amplitude_mean_lsb[: group.n_data], depth_std, mean)
        return tuple((m, jnp.where(mask, s, 1.0)) for m, s, mask in zip(models, sigmas, group.masks, strict=True))

    def _penalty(self, r: Observables, group: FileGroup) -> Array:
        """The validity residuals of a group's data rows (module docstring): 0 for rows that do not
        enter the fit and for rows with headroom above :data:`VALID_MARGIN`; none without
        :attr:`validity`."""
        if not self.validity:
            return jnp.zeros((0,))
        used = group.masks[0]
        for mask in group.masks[1:] + group.bound_masks:  # a bound row too: its camera promises a depth there
            used = used | mask
        short = VALID_MARGIN - r.headroom[: group.n_data]
        return jnp.where(used & (short > 0.0), short / VALID_SCALE, 0.0)

    def _hinges(self, r: Observables, group: FileGroup) -> Array:
        """The bound residuals of a group's data rows, slot by slot (module docstring): 0 where a row
        states no bound or meets it by more than :data:`BOUND_MARGIN`."""
        if not group.bound_slots:
            return jnp.zeros((0,))
        excess = [jnp.where(mask, BOUND_MARGIN - margin, 0.0) for margin, mask in
                  zip(_log_margins(r, group, hard=False), group.bound_masks, strict=True)]
        return jnp.concatenate([jnp.where(e > 0.0, e / BOUND_SCALE, 0.0) for e in excess])

    def _anchors(self, theta: Float[Array, " params"]) -> Array:
        """The change residuals of every parameter, then its prior's, times :attr:`anchor_weight`
        (module docstring); none without bounds."""
        if not self.bounded:
            return jnp.zeros((0,))
        change = (self.anchor_transform(theta) - self.anchor_start) / self.anchor_width
        sigma = jnp.where(self.prior_sigma > 0, self.prior_sigma, 1.0)
        prior = jnp.where(self.prior_sigma > 0, (theta - self.prior_mean) / sigma, 0.0)
        return self.anchor_weight * jnp.concatenate([change, prior])

    def anchor_transform(self, theta):
        """t(theta) of the change residuals: the logarithm of a positive parameter, else the value
        (host arrays in NumPy, traced ones in JAX)."""
        xp = np if isinstance(theta, np.ndarray) else jnp
        log = xp.asarray(self.anchor_log)
        safe = xp.where(log & (theta > 0), theta, 1.0)
        return xp.where(log, xp.log(safe), theta)

    def bound_margins(self, theta: Float[Array, " params"], *, hard: bool = True) -> Array:
        """Every bound row's margin at ``theta``, group by group and slot by slot (the order of
        :func:`bound_rows`): ln(bound / model) for an upper bound, ln(model / bound) for a lower one,
        >= 0 where met; +inf where a row states none. With ``hard`` (the default) the hard model
        judges, as ``tofjax compare`` does: a row it cannot measure, or whose depth is a guess (the
        low-SNR caveat), meets no depth bound (-inf)."""
        parts = []
        for group in self.groups:
            if not group.bound_slots:
                continue
            r = observables(self.with_values(group.params, theta), group.model_sweep(dense=False), group.frequencies_hz,
                            group.fusion, None if hard else self.smooth, group.processing)
            parts += [jnp.where(mask, m, jnp.inf) for m, mask in
                      zip(_log_margins(r, group, hard=hard), group.bound_masks, strict=True)]
        return jnp.concatenate(parts) if parts else jnp.zeros((0,))

    def _split(self, per_group):
        """Per-group row arrays -> per file (in the order given), per observable."""
        out: list = [None] * self.n_files
        for group, per_obs in zip(self.groups, per_group, strict=True):
            for i, (lo, hi) in zip(group.files, group.bounds, strict=True):
                out[i] = tuple((m[lo:hi], s[lo:hi]) for m, s in per_obs)
        return tuple(out)

    def evaluate(self, theta: Float[Array, " params"]) -> tuple[tuple[tuple[Array, Array], ...], ...]:
        """Per file (in the order given) and observable: (model value, row uncertainty) on every row
        of the file (masked rows: uncertainty 1)."""
        return self._split([self._rows(self.predict_group(theta, g, dense=False), g) for g in self.groups])

    def _residuals(self, per_group, penalties, hinges=(), anchors=None) -> Float[Array, " residuals"]:
        """The data residuals of every group, then its validity residuals (:meth:`_penalty`), its
        bound residuals (:meth:`_hinges`) and the change residuals (:meth:`_anchors`)."""
        parts = []
        for group, per_obs in zip(self.groups, per_group, strict=True):
            for (m, s), v, mask in zip(per_obs, group.values, group.masks, strict=True):
                parts.append(jnp.where(mask, (m - v) / s, 0.0))
        return jnp.concatenate(parts + list(penalties) + list(hinges) + ([anchors] if anchors is not None else []))

    def residuals_theta(self, theta: Float[Array, " params"]) -> Float[Array, " residuals"]:
        results = [(self.predict_group(theta, g, dense=False), g) for g in self.groups]
        return self._residuals([self._rows(r, g) for r, g in results], [self._penalty(r, g) for r, g in results],
                               [self._hinges(r, g) for r, g in results], self._anchors(theta))

    def residuals(self, u: Float[Array, " params"]) -> Float[Array, " residuals"]:
        """Whitened residuals at unconstrained parameters ``u`` (0 for masked rows)."""
        return self.residuals_theta(self.constrained(u))

    def log_likelihood(self, theta: Float[Array, " params"]) -> Float[Array, ""]:
        """Gaussian log-likelihood, with the normalisation of parameter-dependent uncertainties."""
        total = jnp.asarray(0.0)
        for group in self.groups:
            r = self.predict_group(theta, group, dense=False)
            for (m, s), v, mask in zip(self._rows(r, group), group.values, group.masks, strict=True):
                total = total - jnp.sum(jnp.where(mask, 0.5 * ((m - v) / s) ** 2 + jnp.log(s), 0.0))
            total = total - 0.5 * jnp.sum(self._penalty(r, group) ** 2)  # the validity constraint
            total = total - 0.5 * jnp.sum(self._hinges(r, group) ** 2)  # the bounds
        return total

    def log_prior(self, u: Float[Array, " params"]) -> Float[Array, ""]:
        """Log prior density in the unconstrained space: uniform (or Gaussian) in theta within the
        bounds, times the Jacobian of the transform."""
        theta = self.constrained(u)
        sigma = jnp.where(self.prior_sigma > 0, self.prior_sigma, 1.0)
        gaussian = jnp.where(self.prior_sigma > 0, -0.5 * ((theta - self.prior_mean) / sigma) ** 2, 0.0)
        change = 0.0
        if self.bounded:  # bounds only: the change from the start (module docstring)
            change = -0.5 * jnp.sum((self.anchor_weight * (self.anchor_transform(theta) - self.anchor_start)
                                     / self.anchor_width) ** 2)
        return self.log_abs_jacobian(u) + jnp.sum(gaussian) + change

    def log_posterior(self, u: Float[Array, " params"]) -> Float[Array, ""]:
        return self.log_likelihood(self.constrained(u)) + self.log_prior(u)

    def dense_curves(self, theta: Float[Array, " params"]) -> tuple[Array, ...]:
        """Per group, ``(files, observables, DENSE_POINTS)``: amplitude, depth noise and the depth
        reading's error against the true distance (in the period nearest it) on the dense points."""
        return tuple(_curves(self.predict_group(theta, group), group) for group in self.groups)


def build_problem(parameters: tuple[FreeParameter, ...], rows: list[SweepRows], smooth: tj.Smooth | None = None,
                  relative_error: float | None = None, validity: bool = True) -> Problem:
    """Assemble the problem from free parameters and prepared sweep files (``validity``:
    :attr:`Problem.validity`)."""
    def kind(p: FreeParameter) -> str:
        return "both" if p.lower is not None and p.upper is not None else ("lower" if p.lower is not None else "none")

    def numbers(values):
        return jnp.asarray([0.0 if v is None else float(v) for v in values])

    anchors = {}
    if any(r.bounds for r in rows):
        log = tuple(p.lower is not None and p.lower >= 0.0 and p.initial > 0.0 for p in parameters)
        width = [ANCHOR_LOG_WIDTH if is_log else ANCHOR_LINEAR_WIDTH * (
            (p.upper - p.lower) if p.lower is not None and p.upper is not None else 1.0)
            for p, is_log in zip(parameters, log, strict=True)]
        start = [np.log(p.initial) if is_log else p.initial for p, is_log in zip(parameters, log, strict=True)]
        measured = any(np.any(m) for r in rows for _, m in r.data.values())
        anchors = {"anchor_log": log, "anchor_start": jnp.asarray(start), "anchor_width": jnp.asarray(width),
                   "anchor_weight": jnp.asarray(0.0 if measured else 1.0)}

    return Problem(
        names=tuple(p.name for p in parameters), units=tuple(p.unit for p in parameters),
        kinds=tuple(kind(p) for p in parameters), has_relative_error=relative_error is not None,
        lower=numbers(p.lower for p in parameters), upper=numbers(p.upper for p in parameters),
        initial=numbers(p.initial for p in parameters),
        prior_mean=numbers(p.prior[0] if p.prior else 0.0 for p in parameters),
        prior_sigma=numbers(p.prior[1] if p.prior else 0.0 for p in parameters),
        relative_error=jnp.asarray(0.0 if relative_error is None else float(relative_error)),
        groups=_groups(rows, merge_lamps=not any(p.name in BAND_PARAMETERS for p in parameters),
                       keep_wrapped=any(p.name in PERIOD_PARAMETERS for p in parameters)),
        smooth=smooth if smooth is not None else tj.Smooth(), validity=validity, **anchors,
    )


def _log_margins(r: Observables, group: FileGroup, hard: bool) -> list[Array]:
    """Per bound slot of a group, over its data rows: ln(bound / model) for an upper bound, ln(model /
    bound) for a lower one (>= 0 where met), the model judged as ``tofjax compare`` judges it: the
    depth noise, the amplitude, and the depth error |reading - distance| of the camera's reading (its
    own period's). A model value that is not positive and finite is -inf for a lower bound (and for
    an upper one where ``hard``: the hard model has no value there); with ``hard``, a row whose depth
    is a guess (the low-SNR caveat) meets no depth bound."""
    n = group.n_data
    guess = (r.caveats[:n] & tj.schema.CAVEAT_LOW_SNR) != 0
    values = {"depth_std_m": r.depth_std_m[:n], "amplitude_mean_lsb": r.amplitude_mean_lsb[:n],
              "depth_error_m": jnp.abs(r.depth_mean_m[:n] - group.sweep.distance_m[:n])}
    out = []
    for (quantity, upper), bound in zip(group.bound_slots, group.bound_values, strict=True):
        m = values[quantity]
        finite = jnp.isfinite(m)
        ok = finite & (m > 0.0)
        log_m = jnp.log(jnp.where(ok, m, 1.0))
        margin = jnp.log(bound) - log_m if upper else log_m - jnp.log(bound)
        # a zero (an exact reading) meets an upper bound and breaks a lower one; no value breaks both
        margin = jnp.where(ok, margin, jnp.where(finite & upper, jnp.inf, -jnp.inf if hard else -NO_VALUE))
        if hard:
            margin = jnp.where(~finite, -jnp.inf, margin)
            if quantity != "amplitude_mean_lsb":
                margin = jnp.where(guess, -jnp.inf, margin)
        out.append(margin)
    return out


def bound_rows(problem: Problem, rows: list[SweepRows]) -> list[dict | None]:
    """What each entry of :meth:`Problem.bound_margins` is: ``{"file", "row", "line", "column", "bound"}``
    (the file's index, the row's index and line, the tightest column there and its value), or ``None``
    where the row states no bound of that slot."""
    out: list[dict | None] = []
    for group in problem.groups:
        for quantity, upper in group.bound_slots:
            for i in group.files:
                values, columns = tightest(rows[i], quantity, upper)
                for k, (v, c) in enumerate(zip(values, columns, strict=True)):
                    out.append(None if c is None else {"file": i, "row": k, "line": rows[i].line(k), "column": c,
                                                       "bound": float(v)})
    return out


def _curves(r: Observables, group: FileGroup) -> Array:
    """``(files, observables, DENSE_POINTS)`` of a group's result (:meth:`Problem.dense_curves`)."""
    truth = group.sweep.distance_m[group.n_data:]
    error = nearest_period(r.depth_mean_m[group.n_data:], truth, r.period_m) - truth
    curves = jnp.stack([r.amplitude_mean_lsb[group.n_data:], r.depth_std_m[group.n_data:], error])
    return jnp.moveaxis(curves.reshape(len(OBSERVABLES), len(group.files), -1), 0, 1)


class Linearization(eqx.Module):
    """What :func:`linearize` returns at unconstrained parameters ``u``."""

    theta: Array  # the parameters
    dtheta_du: Array  # the bound transform's slopes (diagonal)
    residuals: Array
    jacobian: Array  # d residuals / d u
    evaluated: tuple  # Problem.evaluate(theta)
    curves: tuple  # Problem.dense_curves(theta)
    curves_jacobian: tuple  # d curves / d u


# Module-level compiled entry points: they take the problem as an argument, so every problem of
# the same structure (parameters, file groups' row counts and static settings) reuses one compilation.
@tj.jit
def linearize(problem: Problem, u) -> Linearization:
    """Residuals, model values and dense curves at ``u``, with their Jacobians: one program for the
    least-squares steps and for everything the fit reports at its solution."""
    def outputs(v):
        theta = problem.constrained(v)
        per_group, penalties, hinges, curves = [], [], [], []
        for group in problem.groups:
            r = problem.predict_group(theta, group)
            per_group.append(problem._rows(r, group))
            penalties.append(problem._penalty(r, group))
            hinges.append(problem._hinges(r, group))
            curves.append(_curves(r, group))
        residuals = problem._residuals(per_group, penalties, hinges, problem._anchors(theta))
        return (residuals, tuple(curves)), (theta, residuals, problem._split(per_group), tuple(curves))

    (jac, curves_jac), (theta, residuals, evaluated, curves) = jax.jacfwd(outputs, has_aux=True)(u)
    dtheta = jnp.diagonal(jax.jacfwd(problem.constrained)(u))
    return Linearization(theta, dtheta, residuals, jac, evaluated, curves, curves_jac)


@tj.jit
def _unconstrained(problem: Problem, theta):  # one program, where its operations each compiled one
    return problem.unconstrained(theta)


@tj.jit
def evaluate(problem: Problem, theta):
    return problem.evaluate(theta)


@tj.jit
def batched_log_posterior(problem: Problem, u_batch):
    return jax.vmap(problem.log_posterior)(u_batch)


@tj.jit
def batched_curves(problem: Problem, thetas):
    return jax.vmap(problem.dense_curves)(thetas)


@tj.jit
def batched_bound_margins(problem: Problem, thetas):
    """:meth:`Problem.bound_margins` (the hard model) at each of ``thetas``: one program for the scans
    of every parameter (:func:`fitting._bounds.intervals`)."""
    return jax.vmap(problem.bound_margins)(thetas)
