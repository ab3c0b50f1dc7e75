"""Cameras, lux meters and a virtual stage.

- :class:`VirtualCamera` renders frames with tofjax's Monte Carlo model at the stage's current
  position and the lux meter's current reading; every ROI pixel is an independent realisation of
  the centre pixel (the model has no spatial structure).
- :class:`measurements.RoyaleCamera` (in :mod:`measurements._royale`) drives a pmd Royale camera.
- :class:`ManualLuxMeter` asks the operator for the reading (thesis §5.5.2 used a handheld meter);
  :class:`VirtualLuxMeter` returns a set value.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import tofjax as tj

from ._interfaces import Frames, LuxMeterError, StageLimitError


class VirtualStage:
    """A stage that moves instantly (for virtual campaigns); same interface as :class:`AptStage`."""

    def __init__(self, position_m: float = 1.0, travel_m=(0.0, 10.0)):
        self._position, self.travel_m, self.counts_per_mm = float(position_m), tuple(travel_m), 1.0

    def enable(self) -> None: ...

    def home(self) -> None:
        self._position = self.travel_m[0]

    def move_to(self, position_m: float) -> float:
        lo, hi = self.travel_m
        if not lo <= position_m <= hi:
            raise StageLimitError(f"stage position {float(position_m):g} m is outside the travel: allowed {lo:g} <= value "
                                  f"<= {hi:g} m; nothing moved")
        self._position = float(position_m)
        return self._position

    def position_m(self) -> float:
        return self._position

    def stop(self) -> None: ...

    def close(self) -> None: ...


class VirtualLuxMeter:
    """Reads a set illuminance (lx)."""

    def __init__(self, value_lx: float = 0.0):
        self.value_lx = float(value_lx)

    def read_lx(self) -> float:
        return self.value_lx


class ManualLuxMeter:
    """Asks the operator to type the lux meter's reading (re-asks until it is a number >= 0).

    Without an operator (standard input closed or not a terminal that answers) it raises
    :class:`LuxMeterError` instead of waiting or failing with a traceback.
    """

    def __init__(self, ask=input, tell=print):
        self.ask, self.tell = ask, tell

    def read_lx(self) -> float:
        while True:
            try:
                text = self.ask("illuminance on the target [lx]: ").strip()
            except EOFError:
                raise LuxMeterError("--lux manual needs an operator to type each reading, but standard input is "
                                    "closed; run it at a terminal, or use --lux virtual with --lux-value") from None
            try:
                value = float(text)
            except ValueError:
                value = math.nan
            if math.isfinite(value) and value >= 0:
                return value
            self.tell(f"{text!r} is not a number >= 0; type the lux meter's reading in lx")


class VirtualCamera:
    """A camera rendered by tofjax's Monte Carlo (module docstring).

    **Arguments:** ``params`` (the camera model), ``stage`` and ``lux_meter`` (read at every grab),
    ``roi`` (width, height) in pixels, ``seed``, ``distance_offset_m`` (stage reading to target distance).
    """

    model = "tofjax virtual camera"
    serial = "virtual-0"
    amplitude_quantity = "amplitude_lsb"

    def __init__(self, params: tj.Params, stage, lux_meter, roi=(3, 3), seed: int = 0, distance_offset_m: float = 0.0):
        self.params, self.stage, self.lux, self.roi = params, stage, lux_meter, tuple(roi)
        self.offset = float(distance_offset_m)
        self._key = jax.random.key(seed)
        self._grabs = 0

    def open(self) -> None: ...

    def close(self) -> None: ...

    def set_integration_time(self, seconds: float) -> None:
        self.params = eqx.tree_at(lambda p: p.scene.integration_time_s, self.params, jnp.asarray(seconds, dtype=float))

    def set_modulation_frequency(self, hz: float) -> None:
        self.params = eqx.tree_at(lambda p: p.illumination_waveform.modulation_frequency_hz, self.params,
                                  jnp.asarray(hz, dtype=float))

    @property
    def modulation_frequency_hz(self) -> float:
        return float(self.params.illumination_waveform.modulation_frequency_hz)

    @property
    def depth_wrap_m(self) -> float:
        """The unambiguity range: the model's depth is wrapped into [0, c / 2 f)."""
        return tj.optics.SPEED_OF_LIGHT_M_PER_S / (2.0 * self.modulation_frequency_hz)

    def grab(self, n: int) -> Frames:
        width, height = self.roi
        distance = self.stage.position_m() + self.offset
        p = eqx.tree_at(lambda q: q.scene.illuminance_lx, self.params, jnp.asarray(self.lux.read_lx(), dtype=float))
        key = jax.random.fold_in(self._key, self._grabs)
        self._grabs += 1
        frames = n * width * height
        r = tj.simulate(p, tj.Sweep("distance", [distance]), key, frames, keep_frames=frames)
        shape = (n, height, width)
        return Frames(np.asarray(r.depth_m[0]).reshape(shape), np.asarray(r.amplitude_lsb[0]).reshape(shape),
                      np.asarray(r.valid[0]).reshape(shape))


