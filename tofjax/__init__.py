"""tofjax: a physical, differentiable performance model of a continuous-wave Time-of-Flight camera.

Importing tofjax turns on JAX's float64 mode (``jax_enable_x64``): the model's electron counts,
phases and gradients need double precision. The package imports its parts lazily (PEP 562): ``import
tofjax`` itself loads neither JAX nor NumPy, so the ``tofjax`` command starts fast; the first use of
a name such as ``tofjax.predict`` loads what it needs.
"""

from __future__ import annotations

import importlib
import os
import sys
from typing import TYPE_CHECKING

__version__ = "0.1.0"

# Float64 everywhere. JAX reads the environment variable when it is first imported; if it already
# was, switch the flag directly (before any computation of tofjax's).
if "jax" in sys.modules:
    sys.modules["jax"].config.update("jax_enable_x64", True)
else:
    os.environ["JAX_ENABLE_X64"] = "1"

#: Public name -> the private module that defines it.
_EXPORTS = {
    "background_irradiance_w_per_m2": "_background", "background_photon_irradiance": "_background",
    "Config": "_config", "config_from_dict": "_config", "default_config_text": "_config", "load_config": "_config",
    "cw_depth_noise": "_estimate", "pulsed_depth_noise": "_estimate",
    "Smooth": "_smooth", "Camera": "_camera", "predict": "_camera", "simulate": "_camera",
    "CAVEATS": "_result", "CAVEAT_NEAR_LIMIT": "_result", "CAVEAT_COARSE_QUANTIZATION": "_result",
    "CAVEAT_LOW_SNR": "_result", "NoiseBreakdown": "_result", "Result": "_result",
    "MultiFrequencyResult": "_multifrequency", "extended_range_m": "_multifrequency",
    "simulate_multifrequency": "_multifrequency", "unwrap_frequencies": "_multifrequency",
    "predict_multifrequency": "_multifrequency", "fused_std": "_multifrequency", "fusion_weights": "_multifrequency",
    "phase_image_time_s": "_exposure", "phase_images_per_count": "_exposure",
    "lens": "_optics", "spot_area_m2": "_optics",
    "ADC": "_params", "AbstractWaveform": "_params", "Optics": "_params", "Illumination": "_params",
    "IlluminationWaveform": "_params", "Params": "_params", "PhysicalConstants": "_params", "Pixel": "_params",
    "ReferenceWaveform": "_params", "Scene": "_params",
    "ConfigError": "_schema", "Sweep": "_sweep",
    "fourier_coefficients": "_waveforms", "phase_steps": "_waveforms", "waveform": "_waveforms",
    "waveform_mean": "_waveforms",
    "Chain": "_chain", "build_chain": "_chain",
    "AbstractNoiseSource": "_noise", "NoiseBudget": "_noise", "NOISE_SOURCES": "_noise",
    "get_leaf": "_leaves", "set_leaves": "_leaves", "jit": "_jit", "enable_compilation_cache": "_cache",
    "SPEED_OF_LIGHT_M_PER_S": "_constants",
    "PRESETS": "_presets", "Preset": "_presets", "preset_config": "_presets", "preset_text": "_presets",
    "FrameSettings": "_framegeometry", "frame_shape": "_framegeometry", "frame_rays": "_framegeometry",
    "scene_returns": "_framegeometry", "depth_returns": "_framegeometry", "pixel_etendue_m2_sr": "_framegeometry",
    "FrameResult": "_frame", "FLAGS": "_flags", "FrameQuality": "_frame", "predict_frame": "_frame", "noise_image": "_frame",
    "render_frame": "_frame", "sample_frame": "_frame", "prepare_frame": "_frame", "PreparedFrame": "_frame",
    "NoisyFrames": "_frame", "sharded_map": "_frame", "prepare_camera": "_frame", "PreparedCamera": "_frame",
    "Returns": "_returns", "save_returns": "_returns", "load_returns": "_returns",
    "PixelPattern": "_pattern", "draw_pattern": "_pattern", "mean_pattern": "_pattern",
}
#: Public submodules, loaded on first use.
_SUBMODULES = ("plots", "progress", "report", "schema", "stats", "sweepfile", "cli", "scenes", "frameio")


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'tofjax' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*__all__, *_SUBMODULES])


__all__ = sorted([*_EXPORTS, "explorer", "__version__"])


def explorer(config=None, *, folder=None):
    """The interactive explorer, the thesis' GUI (§4.3) as an ipywidgets app: tabs Main, Pixel,
    Scene & Camera, Physical & ADC; live waveform and FoV previews; sweep, plot choice, Calculate;
    TOML load/save. ``config``: a :class:`Config`, a TOML path or ``None`` (defaults); ``folder``:
    the only folder it reads and writes files in (default: the working directory when it starts).

    Needs ipywidgets (``pip install "tofjax[notebooks]"``); returns a
    :class:`tofjax._explorer.Explorer`, shown when it is a cell's last expression.
    """
    from ._explorer import Explorer

    return Explorer(config, folder=folder)


if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from . import frameio, plots, progress, report, scenes, schema, stats, sweepfile  # noqa: F401
    from ._flags import FLAGS  # noqa: F401
    from ._frame import (  # noqa: F401
        FrameQuality, FrameResult, NoisyFrames, PreparedCamera, PreparedFrame, noise_image, predict_frame,
        prepare_camera, prepare_frame, render_frame, sample_frame, sharded_map)
    from ._framegeometry import (  # noqa: F401
        FrameSettings, depth_returns, frame_rays, frame_shape, pixel_etendue_m2_sr, scene_returns)
    from ._pattern import PixelPattern, draw_pattern, mean_pattern  # noqa: F401
    from ._returns import Returns, load_returns, save_returns  # noqa: F401
    from ._camera import Camera, predict, simulate  # noqa: F401
    from ._background import background_irradiance_w_per_m2, background_photon_irradiance  # noqa: F401
    from ._cache import enable_compilation_cache  # noqa: F401
    from ._chain import Chain, build_chain  # noqa: F401
    from ._constants import SPEED_OF_LIGHT_M_PER_S  # noqa: F401
    from ._config import Config, config_from_dict, default_config_text, load_config  # noqa: F401
    from ._estimate import cw_depth_noise, pulsed_depth_noise  # noqa: F401
    from ._leaves import get_leaf, set_leaves  # noqa: F401
    from ._multifrequency import (  # noqa: F401
        MultiFrequencyResult, extended_range_m, fused_std, fusion_weights, predict_multifrequency,
        simulate_multifrequency, unwrap_frequencies)
    from ._exposure import phase_image_time_s, phase_images_per_count  # noqa: F401
    from ._noise import NOISE_SOURCES, AbstractNoiseSource, NoiseBudget  # noqa: F401
    from ._optics import lens, spot_area_m2  # noqa: F401
    from ._presets import PRESETS, Preset, preset_config, preset_text  # noqa: F401
    from ._params import (  # noqa: F401
        ADC, AbstractWaveform, Illumination, IlluminationWaveform, Optics, Params, PhysicalConstants, Pixel,
        ReferenceWaveform, Scene)
    from ._result import (  # noqa: F401
        CAVEAT_COARSE_QUANTIZATION, CAVEAT_LOW_SNR, CAVEAT_NEAR_LIMIT, CAVEATS, NoiseBreakdown, Result)
    from ._schema import ConfigError  # noqa: F401
    from ._smooth import Smooth  # noqa: F401
    from ._sweep import Sweep  # noqa: F401
    from ._waveforms import fourier_coefficients, phase_steps, waveform, waveform_mean  # noqa: F401
