"""The flags of a frame's pixels (:attr:`tofjax.FrameResult.flags`, ``frame.npz``'s ``flags``): one
bit per reason a pixel's distance should not be trusted. Without JAX, so that readers of a frame's
files need none."""

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
}

#: Short names of the bits (``render``'s headline numbers: ``<name>_fraction``).
FLAG_KEYS = {bit: text.split(":")[0].replace(" ", "_") for bit, text in FLAGS.items()}
