"""Physical constants (thesis Table 4.1), in one place.

The thesis rounds some of them (k = 1.38e-23 J/K, h = 6.62606979e-34 J s); tofjax uses the exact
SI (CODATA 2018) values, which agree to the digits the thesis prints. Every other module takes
constants from here, or from a :class:`tofjax.PhysicalConstants` pytree built from these defaults.
"""

BOLTZMANN_J_PER_K = 1.380649e-23
ELEMENTARY_CHARGE_C = 1.602176634e-19
SPEED_OF_LIGHT_M_PER_S = 299_792_458.0
PLANCK_J_S = 6.62607015e-34
#: Maximum luminous efficacy of radiation K_m (thesis Eq 3.3), lm/W.
LUMINOUS_EFFICACY_LM_PER_W = 683.0
#: Absolute zero offset for Celsius -> kelvin.
ZERO_CELSIUS_K = 273.15
#: Long-wavelength limit of a silicon photodetector: photons beyond the 1.12 eV band gap
#: (about 1107 nm) generate no electron-hole pairs. Used to bound the background-light
#: integral when no optical filter is fitted (docs/model.md, "Background light").
SILICON_CUTOFF_M = 1.107e-6
