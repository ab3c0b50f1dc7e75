"""tofjax: a physical, differentiable performance model of a continuous-wave Time-of-Flight camera.

Importing tofjax turns on JAX's float64 mode (``jax_enable_x64``): the model's electron counts,
phases and gradients need double precision.
"""

import jax as _jax

_jax.config.update("jax_enable_x64", True)

from ._background import (  # noqa: E402
    background_irradiance_w_per_m2 as background_irradiance_w_per_m2,
    background_photon_irradiance as background_photon_irradiance,
)
from ._config import (  # noqa: E402
    Config as Config,
    config_from_dict as config_from_dict,
    default_config_text as default_config_text,
    load_config as load_config,
)
from ._estimate import cw_depth_noise as cw_depth_noise, pulsed_depth_noise as pulsed_depth_noise  # noqa: E402
from ._model import Smooth as Smooth, predict as predict, simulate as simulate  # noqa: E402
from ._multifrequency import (  # noqa: E402
    MultiFrequencyResult as MultiFrequencyResult,
    extended_range_m as extended_range_m,
    simulate_multifrequency as simulate_multifrequency,
    unwrap_frequencies as unwrap_frequencies,
)
from ._optics import lens as lens, spot_area_m2 as spot_area_m2  # noqa: E402
from ._params import (  # noqa: E402
    ADC as ADC,
    AbstractWaveform as AbstractWaveform,
    Camera as Camera,
    Illumination as Illumination,
    IlluminationWaveform as IlluminationWaveform,
    Params as Params,
    PhysicalConstants as PhysicalConstants,
    Pixel as Pixel,
    ReferenceWaveform as ReferenceWaveform,
    Scene as Scene,
)
from ._result import NoiseBreakdown as NoiseBreakdown, Result as Result  # noqa: E402
from ._schema import ConfigError as ConfigError  # noqa: E402
from ._sweep import Sweep as Sweep  # noqa: E402
from ._waveforms import (  # noqa: E402
    fourier_coefficients as fourier_coefficients,
    phase_steps as phase_steps,
    waveform as waveform,
    waveform_mean as waveform_mean,
)

from . import sweepfile as sweepfile  # noqa: E402


def explorer(config=None):
    """The interactive explorer, the thesis' GUI (§4.3) as an ipywidgets app: tabs Main, Pixel,
    Scene & Camera, Physical & ADC; live waveform and FoV previews; sweep, plot choice, Calculate;
    TOML load/save. ``config``: a :class:`Config`, a TOML path or ``None`` (defaults).

    Needs ipywidgets (``pip install "tofjax[notebooks]"``); returns a
    :class:`tofjax._explorer.Explorer`, shown when it is a cell's last expression.
    """
    from ._explorer import Explorer

    return Explorer(config)


__version__ = "0.1.0"
