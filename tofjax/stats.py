"""Statistics of phases and amplitudes, public: the circular (wrap-safe) statistics and masked means
that the Monte Carlo's definitions rest on, for measured frames (``measurements``) and user code, and
the statistics of a phasor in circular Gaussian noise that the analytic path uses.

- :func:`circular_stats` (mean phase, phase standard deviation, number of valid frames per row),
- :func:`masked_mean_std` (mean and ddof-1 standard deviation over valid frames),
- :func:`wrap_angle` (to (-pi, pi]), :func:`unwrap_along_sweep` (§5.4),
- :func:`wrapped_phase_variance` (E[theta^2] of the wrapped phase against the first-order phase
  variance v = s^2 / A^2: v (1 + v) at high SNR, pi^2 / 3 at none) and :func:`rician_mean` (E|Z|);
- several modulation frequencies (thesis §2.2, Eq 2.7): :func:`extended_range_m`,
  :func:`unwrap_frequencies` (the distance where the frequencies agree), :func:`fusion_weights` and
  :func:`fused_std` (the fused distance's weights and noise).
"""

from ._depth import circular_stats, masked_mean_std, unwrap_along_sweep, wrap_angle
from ._multifrequency import extended_range_m, fused_std, fusion_weights, unwrap_frequencies
from ._rician import mean_abs as rician_mean, phase_variance as wrapped_phase_variance

__all__ = ["circular_stats", "extended_range_m", "fused_std", "fusion_weights", "masked_mean_std", "rician_mean",
           "unwrap_along_sweep", "unwrap_frequencies", "wrap_angle", "wrapped_phase_variance"]
