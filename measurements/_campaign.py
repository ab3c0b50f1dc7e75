"""Recording campaigns: sweep the stage, the exposure or the background light, grab frames, write
one tofjax-sweep row per point as soon as it is measured (flushed and fsynced), resumable.

Statistics of a point, over its frames and the ROI's pixels (docs/measurements.md):
- depth: wrap-safe (circular) per pixel over its valid frames; ``depth_std_m`` is the root mean
  square of the pixels' temporal standard deviations (ddof 1), ``depth_mean_m`` the circular mean
  of all valid samples in [0, d_u);
- amplitude: mean of all valid samples; ``amplitude_std_lsb`` the RMS of the pixels' temporal stds;
- ``valid_fraction``: valid samples over all samples; ``n_frames``: frames per pixel.

A camera that delivers unwrapped depth (``depth_wrap_m`` None, e.g. Royale) gets linear statistics
instead of circular ones; a camera whose amplitude-like output is a gray value writes it to the
``gray_value_mean`` / ``gray_value_std`` columns and leaves the amplitude columns empty.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import tofjax as tj
from tofjax import stats
from tofjax import sweepfile as sf
from tofjax.outputs import write_npz
from tofjax.schema import OPERATING_POINT_COLUMNS

from ._interfaces import Frames, StageLimitError
from ._settings import RECORDABLE_SWEEPS

EXTRA_COLUMNS = ("stage_position_m", "requested_value", "elapsed_s")
GRAY_COLUMNS = ("gray_value_mean", "gray_value_std")


@dataclasses.dataclass
class CampaignSettings:
    """What to record. Sweep values in SI units (m, s, lx); nominal values for the fixed quantities."""

    sweep: str
    start: float
    stop: float
    samples: int
    frames: int = 100
    roi: tuple[int, int] = (3, 3)
    distance_m: float = 1.0
    integration_time_s: float = 2e-3
    illuminance_lx: float = 0.0
    settle_s: float = 0.0
    raw_dir: Path | None = None

    def __post_init__(self):
        if self.sweep not in RECORDABLE_SWEEPS:
            raise ValueError(f"sweep = {self.sweep!r} is not allowed: expected one of {', '.join(RECORDABLE_SWEEPS)}")
        for name, ok, allowed in (("samples", self.samples >= 1, "integer >= 1"),
                                  ("frames", self.frames >= 2, "integer >= 2"),
                                  ("roi", len(self.roi) == 2 and min(self.roi) >= 1, "W,H with W, H >= 1"),
                                  ("settle_s", self.settle_s >= 0, "value >= 0")):
            if not ok:
                raise ValueError(f"{name} = {getattr(self, name)!r} is out of range: allowed {allowed}")
        if self.samples > 1 and not self.start < self.stop:
            raise ValueError(f"from = {self.start!r} must be less than to = {self.stop!r}")

    @property
    def points(self) -> np.ndarray:
        return np.linspace(self.start, self.stop, self.samples)


def point_statistics(frames: Frames, unambiguity_m: float | None) -> dict[str, float]:
    """The row statistics of one point (module docstring); ``unambiguity_m`` None: the depth is
    unwrapped already, so its statistics are linear."""
    depth, amp, valid = (np.asarray(a).reshape(a.shape[0], -1) for a in (frames.depth_m, frames.amplitude_lsb,
                                                                          frames.valid))
    n_frames = depth.shape[0]
    out = {"n_frames": float(n_frames), "valid_fraction": float(np.mean(valid))}
    if not np.any(valid):
        return out | {k: math.nan for k in ("depth_mean_m", "depth_std_m", "amplitude_mean_lsb", "amplitude_std_lsb")}
    _, amp_std = stats.masked_mean_std(jnp.asarray(amp.T), jnp.asarray(valid.T))
    if unambiguity_m is None:
        _, depth_std = stats.masked_mean_std(jnp.asarray(depth.T), jnp.asarray(valid.T))
        depth_mean = float(np.mean(depth[valid]))
    else:
        phase = 2 * np.pi * depth / unambiguity_m
        z = np.where(valid, np.exp(1j * phase), 0)
        centre = np.angle(z.sum())
        mean_phase = np.mod(centre + np.mean(np.angle(np.exp(1j * (phase - centre)))[valid]), 2 * np.pi)
        # Per pixel (rows), over its valid frames: wrap-safe phase std (ddof 1).
        _, phase_std, _ = stats.circular_stats(jnp.asarray(phase.T), jnp.asarray(valid.T))
        depth_std = np.asarray(phase_std) * unambiguity_m / (2 * np.pi)
        depth_mean = float(mean_phase / (2 * np.pi) * unambiguity_m)
    depth_std, amp_std = np.asarray(depth_std), np.asarray(amp_std)
    usable = np.isfinite(depth_std)  # pixels with at least two valid frames
    return out | {
        "depth_mean_m": depth_mean,
        "depth_std_m": float(np.sqrt(np.mean(depth_std[usable] ** 2))) if usable.any() else math.nan,
        "amplitude_mean_lsb": float(np.mean(amp[valid])),
        "amplitude_std_lsb": float(np.sqrt(np.mean(amp_std[usable] ** 2))) if usable.any() else math.nan,
    }


def _done_points(path: Path, settings: CampaignSettings) -> np.ndarray:
    data = sf.read_sweep(path, allow_empty=True)
    if data.metadata.get("sweep") != settings.sweep:
        raise ValueError(f"{path}: cannot resume: it records a {data.metadata.get('sweep')} sweep, not {settings.sweep}")
    if "requested_value" not in data.columns:
        raise ValueError(f"{path}: cannot resume: it has no requested_value column (not written by tofjax record)")
    return data.columns["requested_value"] if data.n_rows else np.array([])


def check_resume(path: Path, settings: CampaignSettings, grid: dict[str, str]) -> None:
    """Refuse to continue ``path`` with settings that differ from the ones it was recorded with
    (``grid``: :func:`measurements._settings.grid_metadata`), naming every difference; a file
    without those metadata must at least hold only points of the new grid."""
    data = sf.read_sweep(path, allow_empty=True)
    differs = [f"{key} = {data.metadata[key]} in the file, {value} now" for key, value in grid.items()
               if key in data.metadata and data.metadata[key] != value]
    done = _done_points(path, settings)
    foreign = [x for x in done if not np.any(np.isclose(settings.points, x, rtol=1e-9, atol=1e-12))]
    if foreign and not differs:
        differs.append(f"{len(foreign)} recorded point(s) (e.g. {foreign[0]:g}) are not on the new grid")
    if differs:
        raise ValueError(f"{path}: cannot resume with different settings: " + "; ".join(differs)
                         + " (record into a new --out, or resume with the original settings)")


def run_campaign(settings: CampaignSettings, *, stage, camera, lux, out: str | Path, metadata: dict,
                 resume: bool = False, progress: bool = True, distance_offset_m: float = 0.0, replace: bool = False,
                 replace_measurement: bool = False, on_point=None) -> int:
    """Record the sweep into ``out``; returns the number of rows written now.

    Every row is appended and fsynced as soon as its point is measured, so an interrupted campaign
    leaves a valid file with every completed row; ``resume`` skips the points already in it. A new
    file is created whole (its header) under a temporary name and renamed into place: an existing
    ``out`` is refused unless ``replace``, a measurement unless ``replace_measurement`` too
    (:mod:`tofjax.outputs`). ``on_point(done, total)``: called before the first point and after
    each (the points in the file, of the sweep's).
    """
    from tofjax.progress import Progress, held_interrupt

    out = Path(out)
    gray = camera.amplitude_quantity == "gray_value"
    columns = [*sf.REQUIRED_COLUMNS, *EXTRA_COLUMNS, *(GRAY_COLUMNS if gray else ())]
    done = _done_points(out, settings) if resume and out.exists() else np.array([])
    todo = [(i, x) for i, x in enumerate(settings.points) if not np.any(np.isclose(done, x, rtol=1e-9, atol=1e-12))]
    # Before anything moves: every stage position within the travel, the exposure range accepted.
    lo, hi = stage.travel_m
    positions = settings.points - distance_offset_m if settings.sweep == "distance" else \
        np.array([settings.distance_m - distance_offset_m])
    if np.any((positions < lo) | (positions > hi)):
        raise StageLimitError(f"stage positions {positions.min():g} .. {positions.max():g} m leave the travel "
                              f"{lo:g} .. {hi:g} m; nothing moved")
    if settings.sweep == "integration_time":
        for value in (settings.start, settings.stop):
            camera.set_integration_time(value)
    else:
        camera.set_integration_time(settings.integration_time_s)
    if settings.sweep != "distance":
        stage.move_to(settings.distance_m - distance_offset_m)
    if settings.raw_dir is not None:
        Path(settings.raw_dir).mkdir(parents=True, exist_ok=True)
    bar = Progress(settings.samples, "recording", unit="point", initial=settings.samples - len(todo),
                   enabled=progress)
    written, t0 = 0, time.monotonic()
    report = on_point if on_point is not None else (lambda done, total: None)
    before = settings.samples - len(todo)
    report(before, settings.samples)
    with bar, sf.SweepWriter(out, metadata, columns, append=resume and out.exists(), replace=replace,
                             replace_measurement=replace_measurement) as writer:
        for i, value in todo:
            t_int = settings.integration_time_s
            if settings.sweep == "distance":
                stage.move_to(value - distance_offset_m)
            elif settings.sweep == "integration_time":
                camera.set_integration_time(value)
                t_int = value
            elif hasattr(lux, "value_lx"):  # a virtual lamp: set it; a real one is set by the operator
                lux.value_lx = float(value)
            if settings.settle_s:
                time.sleep(settings.settle_s)
            position = stage.position_m()
            reading = lux.read_lx()
            frames = camera.grab(settings.frames)
            row = point_statistics(frames, camera.depth_wrap_m) | {
                "distance_m": position + distance_offset_m, "integration_time_s": t_int, "illuminance_lx": reading,
                "stage_position_m": position, "requested_value": float(value), "elapsed_s": time.monotonic() - t0,
            }
            if settings.raw_dir is not None:
                write_npz(Path(settings.raw_dir) / f"point_{i:04d}.npz",
                          {"depth_m": frames.depth_m, "amplitude_lsb": frames.amplitude_lsb, "valid": frames.valid,
                           **{k: row[k] for k in OPERATING_POINT_COLUMNS if k in row}},
                          compressed=False)
            if gray:  # a gray value is not the model's amplitude: its own columns (module docstring)
                row["gray_value_mean"], row["gray_value_std"] = row.pop("amplitude_mean_lsb"), row.pop(
                    "amplitude_std_lsb")
            with held_interrupt():  # a row in the file is a row in the interrupt's note
                writer.write_row(row)
                written += 1
                report(before + written, settings.samples)
            bar.update(1)
    return written


def campaign_metadata(settings: CampaignSettings, camera, stage, lux, params: tj.Params, extra: dict) -> dict:
    """Metadata lines of a recording (docs/measurements.md)."""
    return {
        "sweep": settings.sweep, "source": "measurement",
        "modulation_frequency_hz": repr(float(camera.modulation_frequency_hz)),
        "n_phases": params.pixel.n_phases, "created_utc": sf.utc_now(), "software": f"tofjax {tj.__version__}",
        "camera_model": getattr(camera, "model", "unknown"), "camera_serial": getattr(camera, "serial", "unknown"),
        "stage": type(stage).__name__, "stage_counts_per_mm": getattr(stage, "counts_per_mm", "n/a"),
        "lux_meter": type(lux).__name__, "roi": f"{settings.roi[0]}x{settings.roi[1]}",
        "frames": settings.frames, "scene.reflectivity": repr(float(params.scene.reflectivity)),
        **({"amplitude": "gray value (not the model's amplitude in LSB): columns gray_value_mean, gray_value_std; "
                         "amplitude columns empty",
            "modulation_frequency_source": "configuration (the camera does not report it)",
            "depth": "unwrapped by the camera (linear statistics)"} if camera.amplitude_quantity == "gray_value"
           else {}),
        **extra,
    }
