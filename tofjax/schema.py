"""The configuration schema, public: every key with its default, unit, meaning and allowed range,
the validation and TOML rendering that the configuration, the calibration, the recording and the
explorer share, and the dotted-name access to parameter leaves.

- :data:`KEYS` (tuple of :class:`Key`), :data:`KEY_BY_DOTTED` (``"section.name"`` -> :class:`Key`),
  :data:`SECTIONS`, :func:`keys_of` (the keys of one section);
- :func:`in_range` (a number against a key's range), :func:`coerce` (check one value against its
  key; raises :class:`ConfigError` naming key, value and range), :func:`suggest` (a "did you mean"
  suffix), :func:`render_toml` (a full configuration as commented TOML), :func:`read_toml` (a TOML
  file read with one-line errors: file, line, column);
- :func:`float_leaf_names` (the float keys that are traced leaves of :class:`tofjax.Params`),
  :func:`get_leaf` and :func:`set_leaves` (by dotted name).
"""

from ._config import read_toml, render_toml
from ._leaves import float_leaf_names, get_leaf, set_leaves
from ._schema import KEY_BY_DOTTED, KEYS, SECTIONS, SWEEPS, ConfigError, Key, coerce, in_range, keys_of, suggest

__all__ = ["KEYS", "KEY_BY_DOTTED", "SECTIONS", "SWEEPS", "ConfigError", "Key", "coerce", "float_leaf_names",
           "get_leaf", "in_range", "keys_of", "read_toml", "render_toml", "set_leaves", "suggest"]
