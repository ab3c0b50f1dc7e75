"""The flags of a frame's pixels (:attr:`tofjax.FrameResult.flags`, ``frame.npz``'s ``flags``): one
bit per reason a pixel's distance should not be trusted. Without JAX, so that readers of a frame's
files need none.

Two kinds (issue 50 item 2): what the camera itself knows and acts on (:data:`CAMERA_FLAGS`: it
saturated, its confidence is too low, its processing invalidated it), which decides whether the
camera delivers the pixel (:func:`delivered`: the depth PNG, the point cloud, "good pixels"); and
what only the scene's truth tells (:data:`DIAGNOSTIC_FLAGS`: no return, wrapped, mixed, outside the
illumination), diagnostics beside the delivered depth that never remove a pixel: a real camera
delivers a mixed pixel's biased depth, and a wrapped one's aliased depth, unless its own data reject
it."""

#: Bits of :attr:`tofjax.FrameResult.flags` (0: a good pixel). Saturation is measured (Monte Carlo: in any
#: frame; analytic: expected); low signal and low amplitude come from the expected (analytic) noise
#: and amplitude, whatever the number of frames; the rest are the scene's truth and the camera's
#: geometry. ``frame.npz`` carries this table as ``flag_names``.
FLAG_SATURATED = 1
FLAG_LOW_SIGNAL = 2
FLAG_NO_RETURN = 4
FLAG_WRAPPED = 8
FLAG_MIXED = 16
FLAG_OUTSIDE_ILLUMINATION = 32
FLAG_LOW_AMPLITUDE = 64
FLAG_INVALIDATED = 128
FLAGS = {
    FLAG_SATURATED: "saturated: the pixel or the ADC saturated (analytic: expected; Monte Carlo: in any frame)",
    FLAG_LOW_SIGNAL: "low signal: the expected phase noise exceeds frame.max_phase_noise_rad (a camera's confidence "
                     "threshold would reject it)",
    FLAG_NO_RETURN: "no return: no light of the illumination comes back, or the centre ray meets no surface (no true "
                    "distance)",
    FLAG_WRAPPED: "wrapped: the true distance is beyond the unambiguity range, so the measured one is short by a "
                  "multiple of it",
    FLAG_MIXED: "mixed: the light-weighted standard deviation of the pixel's return distances exceeds "
                "frame.mixed_spread_fraction of the unambiguity range (a flying pixel at a depth edge, or multipath)",
    FLAG_OUTSIDE_ILLUMINATION: "outside the illumination: the illumination's field of view does not reach what the "
                               "pixel sees",
    FLAG_LOW_AMPLITUDE: "low amplitude: the expected amplitude is below frame.min_amplitude_lsb",
    FLAG_INVALIDATED: "invalidated: the camera's own processing (its amplitude threshold, its flying-pixel filter; "
                      "[processing]) delivers the pixel in fewer than half its frames (analytic: with probability "
                      "below 1/2), for no reason its other flags name",
}
#: The flags the camera knows from its own data: a pixel with none of them is delivered.
CAMERA_FLAGS = FLAG_SATURATED | FLAG_LOW_SIGNAL | FLAG_LOW_AMPLITUDE | FLAG_INVALIDATED
#: The flags only the scene's truth tells: diagnostics beside the delivered depth, never removing it.
DIAGNOSTIC_FLAGS = FLAG_NO_RETURN | FLAG_WRAPPED | FLAG_MIXED | FLAG_OUTSIDE_ILLUMINATION


def delivered(flags):
    """Whether the camera delivers each pixel of ``flags`` (none of :data:`CAMERA_FLAGS`; NumPy or JAX)."""
    return (flags & CAMERA_FLAGS) == 0

#: Short names of the bits (``render``'s headline numbers: ``<name>_fraction``).
FLAG_KEYS = {bit: text.split(":")[0].replace(" ", "_") for bit, text in FLAGS.items()}

#: What to do about a frame whose every pixel carries a flag, by the flag most pixels carry
#: (:func:`no_good_pixels_line`).
_REMEDIES = {
    FLAG_SATURATED: "the scene is too close or too bright for this integration time",
    FLAG_LOW_SIGNAL: "too little light comes back: a nearer or brighter scene, a longer integration time or more "
                     "illumination power",
    FLAG_NO_RETURN: "the pixels see no surface the illumination lights",
    FLAG_WRAPPED: "the scene lies beyond the unambiguity range{range}, so every distance reads short by a multiple of "
                  "it: a nearer scene, a lower modulation frequency, or a second frequency "
                  "(illumination_waveform.extra_modulation_frequencies_hz)",
    FLAG_MIXED: "every pixel mixes distances farther apart than frame.mixed_spread_fraction of the unambiguity range",
    FLAG_OUTSIDE_ILLUMINATION: "the illumination's field of view does not reach the scene",
    FLAG_LOW_AMPLITUDE: "the amplitude is below frame.min_amplitude_lsb everywhere",
}


#: The flags in the order of what causes what, for the remedy of a tie (a black wall has no return and,
#: so, a low signal: the missing return is the cause).
_CAUSES = [FLAG_NO_RETURN, FLAG_OUTSIDE_ILLUMINATION, FLAG_WRAPPED, FLAG_SATURATED, FLAG_MIXED, FLAG_LOW_SIGNAL,
           FLAG_LOW_AMPLITUDE]


class NoGoodPixelsWarning(UserWarning):
    """A frame none of whose pixels is good (:func:`no_good_pixels`): the camera delivers none, or
    every one it delivers reads short by a multiple of the unambiguity range, so its point cloud is
    empty or wrong. :func:`tofjax.predict` and :func:`tofjax.simulate` warn so when they make such a
    frame (:func:`no_good_pixels_line` says why)."""


def no_good_pixels(flags) -> bool:
    """Whether no pixel of ``flags`` (an integer array) is good: none is delivered (:func:`delivered`),
    or every delivered one is wrapped (its distance is short by a multiple of the unambiguity range)."""
    import numpy as np

    flags = np.asarray(flags)
    return not bool(np.any(delivered(flags) & ((flags & FLAG_WRAPPED) == 0)))


def flag_fractions(flags) -> dict[int, float]:
    """Each bit of :data:`FLAGS` -> the share of the pixels of ``flags`` (an integer array) that carry it."""
    import numpy as np

    flags = np.asarray(flags)
    return {bit: float(np.mean((flags & bit) != 0)) for bit in FLAGS}


def no_good_pixels_line(fractions: dict[int, float], unambiguity_range_m: float | None = None) -> str:
    """One line saying that no pixel of a frame is good: the share of each flag that occurs
    (``fractions``: bit -> share of the pixels, :func:`flag_fractions`) and, for the flag most pixels
    carry, why and what to change (``unambiguity_range_m``: named for the wrapped flag)."""
    present = {bit: share for bit, share in fractions.items() if share > 0}
    shares = ", ".join(f"{100 * share:.1f} % {FLAG_KEYS[bit].replace('_', ' ')}" for bit, share in present.items())
    if not present:
        return "no good pixel: every pixel is flagged"
    top = max(present, key=lambda bit: (present[bit], -_CAUSES.index(bit)))
    where = "" if unambiguity_range_m is None else f" ({unambiguity_range_m:.4g} m)"
    return f"no good pixel: every pixel is flagged ({shares}); {_REMEDIES[top].format(range=where)}"
