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

#: Public name -> the private module that defines it (docs/api.md lists them, with an example each).
_EXPORTS = {
    # one camera, two verbs
    "Camera": "_camera", "predict": "_camera", "simulate": "_camera",
    # its parameters
    "Params": "_params", "Optics": "_params", "Pixel": "_params", "ADC": "_params", "Scene": "_params",
    "Illumination": "_params", "IlluminationWaveform": "_params", "ReferenceWaveform": "_params",
    "PhysicalConstants": "_params", "FrameSettings": "_framegeometry", "Smooth": "_smooth",
    "PixelPattern": "_pattern", "draw_pattern": "_pattern",
    # scenes
    "Sweep": "_sweep", "Returns": "_returns",
    # results
    "Result": "_result", "NoiseBreakdown": "_result", "FrameResult": "_frame", "NoisyFrames": "_frame",
    "MultiFrequencyResult": "_multifrequency",
    # configurations
    "Config": "_config", "load_config": "_config", "config_from_dict": "_config", "ConfigError": "_schema",
    "PRESETS": "_presets", "preset_config": "_presets",
    # closed-form estimates, compilation
    "cw_depth_noise": "_estimate", "pulsed_depth_noise": "_estimate", "jit": "_jit",
    "enable_compilation_cache": "_cache",
}
#: Public submodules, loaded on first use.
_SUBMODULES = ("chain", "cli", "frameio", "optics", "parallel", "plots", "processing", "progress", "renderers", "report",
               "scenes", "schema", "sensor", "stats", "sweepfile", "waveforms")


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
    from . import (  # noqa: F401
        chain, frameio, optics, parallel, plots, processing, progress, renderers, report, scenes, schema, sensor,
        stats, sweepfile, waveforms)
    from ._cache import enable_compilation_cache  # noqa: F401
    from ._camera import Camera, predict, simulate  # noqa: F401
    from ._config import Config, config_from_dict, load_config  # noqa: F401
    from ._estimate import cw_depth_noise, pulsed_depth_noise  # noqa: F401
    from ._frame import FrameResult, NoisyFrames  # noqa: F401
    from ._framegeometry import FrameSettings  # noqa: F401
    from ._jit import jit  # noqa: F401
    from ._multifrequency import MultiFrequencyResult  # noqa: F401
    from ._params import (  # noqa: F401
        ADC, Illumination, IlluminationWaveform, Optics, Params, PhysicalConstants, Pixel, ReferenceWaveform, Scene)
    from ._pattern import PixelPattern, draw_pattern  # noqa: F401
    from ._presets import PRESETS, preset_config  # noqa: F401
    from ._result import NoiseBreakdown, Result  # noqa: F401
    from ._returns import Returns  # noqa: F401
    from ._schema import ConfigError  # noqa: F401
    from ._smooth import Smooth  # noqa: F401
    from ._sweep import Sweep  # noqa: F401
