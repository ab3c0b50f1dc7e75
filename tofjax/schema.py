"""The configuration schema, public: every key with its default, unit, meaning and allowed range,
the validation and TOML rendering that the configuration, the calibration, the recording and the
explorer share, and the dotted-name access to parameter leaves.

- :data:`KEYS` (tuple of :class:`Key`), :data:`KEY_BY_DOTTED` (``"section.name"`` -> :class:`Key`),
  :data:`SECTIONS`, :func:`keys_of` (the keys of one section);
- :data:`SWEEP_AXES` (name -> :class:`SweepAxis`: the sweep axes' configuration keys, columns, units
  and labels, written once), :data:`SWEEPS` (their names), :data:`OPERATING_POINT_COLUMNS`;
- :func:`in_range` (a number against a key's range), :func:`coerce` (check one value against its
  key; raises :class:`ConfigError` naming key, value and range), :func:`suggest` (a "did you mean"
  suffix), :func:`render_toml` (a full configuration as commented TOML), :func:`read_toml` (a TOML
  file read with one-line errors: file, line, column);
- :func:`float_leaf_names` (the float keys that are traced leaves of :class:`tofjax.Params`),
  :func:`get_leaf` and :func:`set_leaves` (by dotted name);
- :func:`default_config_text` (the defaults as commented TOML), :class:`Preset` and
  :func:`preset_text` (a camera preset's sourced configuration; the presets: :data:`tofjax.PRESETS`);
- the bit tables written into results and files: :data:`CAVEATS` (``Result.caveats``; the bits
  :data:`CAVEAT_NEAR_LIMIT`, :data:`CAVEAT_COARSE_QUANTIZATION`, :data:`CAVEAT_LOW_SNR`) and
  :data:`FLAGS` (``FrameResult.flags``), with :data:`CAMERA_FLAGS` (what the camera knows: a pixel
  without them is delivered) and :data:`DIAGNOSTIC_FLAGS` (what only the truth tells), and
  :class:`NoGoodPixelsWarning` (a frame none of whose pixels is good).
"""

from typing import TYPE_CHECKING

from ._schema import (
    KEY_BY_DOTTED, KEYS, OPERATING_POINT_COLUMNS, SECTIONS, SWEEP_AXES, SWEEPS, ConfigError, Key, SweepAxis, coerce,
    in_range, keys_of, suggest)

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from ._config import default_config_text, read_toml, render_toml
    from ._leaves import float_leaf_names, get_leaf, set_leaves
    from ._flags import CAMERA_FLAGS, DIAGNOSTIC_FLAGS, FLAGS, NoGoodPixelsWarning
    from ._presets import Preset, preset_text
    from ._result import CAVEAT_COARSE_QUANTIZATION, CAVEAT_LOW_SNR, CAVEAT_NEAR_LIMIT, CAVEATS

# The keys and their checks need no JAX; the TOML and leaf helpers import it (through the parameter
# classes), on first use, so that `tofjax --help` and `tofjax record`'s option table stay light.
_LAZY = {"read_toml": "._config", "render_toml": "._config", "float_leaf_names": "._leaves", "get_leaf": "._leaves",
         "set_leaves": "._leaves", "default_config_text": "._config", "Preset": "._presets", "preset_text": "._presets",
         "CAVEATS": "._result", "CAVEAT_NEAR_LIMIT": "._result", "CAVEAT_COARSE_QUANTIZATION": "._result",
         "CAVEAT_LOW_SNR": "._result", "FLAGS": "._flags", "CAMERA_FLAGS": "._flags",
         "DIAGNOSTIC_FLAGS": "._flags", "NoGoodPixelsWarning": "._flags"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name], __name__.rpartition(".")[0]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["KEYS", "KEY_BY_DOTTED", "OPERATING_POINT_COLUMNS", "SECTIONS", "SWEEPS", "SWEEP_AXES", "SweepAxis",
           "ConfigError", "Key", "coerce", "float_leaf_names",
           "get_leaf", "in_range", "keys_of", "read_toml", "render_toml", "set_leaves", "suggest",
           "default_config_text", "Preset", "preset_text", "CAVEATS", "CAVEAT_NEAR_LIMIT", "CAVEAT_COARSE_QUANTIZATION",
           "CAVEAT_LOW_SNR", "FLAGS", "CAMERA_FLAGS", "DIAGNOSTIC_FLAGS", "NoGoodPixelsWarning"]
