"""What an "exposure" or "integration time" counts (docs/model.md, "Exposure definition").

The model integrates each phase image for ``integration_time_s`` (thesis §3.2: one exposure per
phase). Data sheets and camera SDKs often state the exposure of a whole frequency (all N phase
images of one modulation frequency) or of a frame (every phase image of every frequency): a factor
of N or N x (number of frequencies) in the light collected per phase image, 4-8x for common cameras.
The configuration (``scene.integration_time_per``) and the sweep files' metadata
(``integration_time_per``) say which one their numbers count; everything inside the model runs per
phase image, converted here. Read-out and idle time between the phase images are not exposure and
are not counted in any of the three.
"""

from __future__ import annotations

from ._schema import EXPOSURE_DEFINITIONS


def phase_images_per_count(per: str, n_phases: int, n_frequencies: int = 1) -> int:
    """How many phase images one stated integration time covers: 1 (``"phase_image"``), N
    (``"frequency"``) or N x frequencies (``"frame"``)."""
    if per not in EXPOSURE_DEFINITIONS:
        raise ValueError(f"integration_time_per = {per!r} is not allowed: expected one of "
                         + ", ".join(f'"{d}"' for d in EXPOSURE_DEFINITIONS))
    return {"phase_image": 1, "frequency": n_phases, "frame": n_phases * n_frequencies}[per]


def phase_image_time_s(integration_time_s, per: str, n_phases: int, n_frequencies: int = 1):
    """The integration time of one phase image, for a stated time ``integration_time_s`` that
    counts ``per`` (the exposure is assumed split equally between the phase images it covers)."""
    return integration_time_s / phase_images_per_count(per, n_phases, n_frequencies)
