"""The user-facing TOML configuration: load, validate, build parameters, write.

A file names only what it changes; everything else keeps its default. Every value is checked
against its physical range here, before anything is traced, and a problem becomes a
:class:`tofjax.ConfigError` naming the key, the value and the allowed range (or the file, line
and column for malformed TOML).
"""

from __future__ import annotations

import dataclasses
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ._exposure import phase_images_per_count
from ._params import SECTION_CLASSES, Params
from ._schema import SECTIONS, SWEEP_AXES, SWEEPS, ConfigError, defaults, keys_of, suggest, validate
from ._sweep import Sweep


@dataclasses.dataclass(frozen=True)
class Config:
    """A validated configuration: the nested ``values`` plus helpers to build the model inputs.

    Build with :func:`load_config` or :func:`config_from_dict`; ``Config()`` is the default.
    """

    values: Mapping[str, Mapping[str, Any]] = dataclasses.field(default_factory=defaults)

    @property
    def params(self) -> Params:
        """The parameter pytree (:class:`tofjax.Params`). Integration times are per phase image
        there: a configuration that counts them per frequency or per frame
        (``scene.integration_time_per``) is converted (:meth:`phase_image_time_s`)."""
        parts = {}
        for section, cls in SECTION_CLASSES.items():
            names = {f.name for f in dataclasses.fields(cls)}
            parts[section] = cls(**{k: v for k, v in self.values[section].items() if k in names})
        t = self.values["scene"]["integration_time_s"]
        if self.phase_images_per_integration_time != 1:
            parts["scene"] = dataclasses.replace(parts["scene"], integration_time_s=self.phase_image_time_s(t))
        return Params(**parts)

    @property
    def frame(self):
        """The ``[frame]`` section as :class:`tofjax.FrameSettings` (the array's optics and fixed
        pattern, for frames (:func:`tofjax.predict`, :func:`tofjax.simulate`))."""
        from ._framegeometry import frame_settings

        return frame_settings(self.values["frame"])

    @property
    def processing(self) -> tuple:
        """The ``[processing]`` section as the camera's processing stages (:mod:`tofjax.processing`),
        in its order: calibration, spatial filter, temporal average, invalidation; ``()``: none."""
        from . import processing as proc

        v = self.values["processing"]
        stages = []
        if v["calibration"]:
            stages.append(proc.Calibration(temperature_c=v["calibration_temperature_c"]))
        if v["spatial_filter"] != "none":
            stages.append(proc.SpatialFilter(v["spatial_filter"], v["spatial_filter_size"]))
        if v["temporal_average_frames"] > 1:
            stages.append(proc.TemporalAverage(v["temporal_average_frames"]))
        if v["amplitude_threshold"] or v["flying_pixel_m"] > 0:
            stages.append(proc.Invalidation(self.values["frame"]["min_amplitude_lsb"] if v["amplitude_threshold"] else 0.0,
                                            v["flying_pixel_m"] if v["flying_pixel_m"] > 0 else None,
                                            v["flying_pixel_neighbours"]))
        return tuple(stages)

    @property
    def phase_images_per_integration_time(self) -> int:
        """Phase images one configured integration time covers (``scene.integration_time_per``)."""
        return phase_images_per_count(self.values["scene"]["integration_time_per"],
                                      self.values["pixel"]["n_phases"], len(self.modulation_frequencies_hz))

    def phase_image_time_s(self, integration_time_s):
        """A configured integration time (as ``scene.integration_time_per`` counts it) per phase image."""
        return integration_time_s / self.phase_images_per_integration_time

    @property
    def modulation_frequencies_hz(self) -> list[float]:
        """The modulation frequency followed by any extra ones (range extension, §2.2)."""
        w = self.values["illumination_waveform"]
        return [w["modulation_frequency_hz"], *w["extra_modulation_frequencies_hz"]]

    @property
    def iterations(self) -> int:
        """Monte Carlo frames per sample (``pixel.iterations``)."""
        return self.values["pixel"]["iterations"]

    def sweep(self, variable: str, start: float | None = None, stop: float | None = None,
              samples: int | None = None) -> Sweep:
        """The sweep over ``variable`` with the configured range and samples unless overridden."""
        if variable not in SWEEP_AXES:
            raise ValueError(f"sweep = {variable!r} is not allowed: expected one of "
                             + ", ".join(repr(s) for s in SWEEPS) + suggest(variable, SWEEPS))
        lo_key, hi_key = SWEEP_AXES[variable].range_keys
        scene = self.values["scene"]
        start = scene[lo_key] if start is None else start
        stop = scene[hi_key] if stop is None else stop
        samples = scene["samples"] if samples is None else samples
        if variable == "integration_time":  # the model's unit: one phase image
            start, stop = self.phase_image_time_s(start), self.phase_image_time_s(stop)
        return Sweep.linspace(variable, start, stop, samples)

    def replace(self, dotted: str, value: Any) -> Config:
        """A copy with one key changed (validated), e.g. ``replace("pixel.sbi", False)``."""
        section, _, name = dotted.partition(".")
        return config_from_dict({**{s: dict(t) for s, t in self.values.items()},
                                 section: {**self.values.get(section, {}), name: value}})

    def to_toml(self) -> str:
        """The full configuration as TOML, with a comment on every key."""
        return render_toml(self.values)


def config_from_dict(raw: Mapping[str, Any], where: str = "") -> Config:
    """Validate a (partial) nested mapping and merge it over the defaults."""
    return Config(validate(raw, where))


def _toml_position(err: tomllib.TOMLDecodeError, text: str) -> str:
    line, col = getattr(err, "lineno", None), getattr(err, "colno", None)
    if line is None:
        match = re.search(r"line (\d+), column (\d+)", str(err))
        if match:
            line, col = int(match.group(1)), int(match.group(2))
        elif "end of document" in str(err):  # tomllib names no line there: the document's last position
            lines = text.split("\n")
            line, col = len(lines), len(lines[-1]) + 1
    return f"line {line}, column {col}" if line is not None else "unknown position"


def _decode(data: bytes, path: Path, what: str) -> str:
    """UTF-8 text of a file, a leading byte-order mark dropped; binary content is named with the
    line and column of its first bad byte."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        head = data[: err.start]
        line, col = head.count(b"\n") + 1, err.start - (head.rfind(b"\n") + 1) + 1
        raise ConfigError(f"{path}: line {line}, column {col}: not a text {what}: byte 0x{data[err.start]:02x} is not "
                          "UTF-8") from None
    text = text.removeprefix("\ufeff")
    bad = next((i for i, c in enumerate(text) if c == "\x00"), None)
    if bad is not None:
        head = text[:bad]
        raise ConfigError(f"{path}: line {head.count(chr(10)) + 1}, column {bad - (head.rfind(chr(10)) + 1) + 1}: "
                          f"not a text {what}: it contains a NUL byte")
    return text


def read_toml(path: str | Path, what: str = "configuration") -> dict[str, Any]:
    """Read a TOML file (``what`` names it in messages); raises :class:`tofjax.ConfigError` with the
    file and, for malformed TOML, the line and column. A UTF-8 byte-order mark is accepted."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise ConfigError(f"{path}: {what} not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, not a {what}") from None
    except OSError as err:
        raise ConfigError(f"{path}: cannot read the {what}: {err.strerror or err}") from None
    text = _decode(data, path, what)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        msg = getattr(err, "msg", str(err))
        raise ConfigError(f"{path}: {_toml_position(err, text)}: malformed TOML: {msg}") from None


def load_config(path: str | Path) -> Config:
    """Read a TOML configuration file; raises :class:`tofjax.ConfigError` with the file name."""
    return config_from_dict(read_toml(path, "configuration file"), where=str(path))


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, float):
        text = repr(value)
        return text if any(c in text for c in ".en") else text + ".0"
    return repr(value)


_SECTION_TITLES = {
    "illumination": "Illumination unit (thesis Table 4.2)",
    "scene": "Scene, background light, nominal operating point and sweep ranges (Table 4.3)",
    "camera": "Camera and lens (Table 4.4)",
    "pixel": "PMD pixel (Table 4.5)",
    "illumination_waveform": "Emitted waveform (Table 4.6, Fig 4.2)",
    "reference_waveform": "Pixel reference (demodulation) waveform (Table 4.7)",
    "adc": "Analogue-to-digital converter (Table 4.8, Fig 4.11)",
    "interference": "Another camera's illumination in the scene (thesis §6.1.3: interference of several cameras)",
    "timing": "Frame timing: the phase images' readout and the frame rate (Appendix A; eye-safety estimate)",
    "frame": "The whole pixel array: optics off axis and fixed-pattern effects (thesis §6.1.1-6.1.2; tofjax render)",
    "processing": "The camera's own depth processing after the demodulation: calibration, filters, invalidation",
}


def render_toml(values: Mapping[str, Mapping[str, Any]], notes: Mapping[str, str] | None = None,
                header: list[str] | None = None) -> str:
    """Write a full configuration as TOML with a ``# meaning [unit]; allowed: range`` comment per key.

    ``notes`` (dotted key -> text) adds a second comment line to a key (a preset's source);
    ``header`` replaces the first comment lines. tomllib reads TOML but does not write it, and no
    writer keeps comments on a key-by-key basis for a flat schema like this one; the values are
    plain scalars and pairs, so the writer is a few lines.
    """
    lines = [*(header or ["# tofjax camera configuration."]),
             "# SI units throughout; a file may name only what it changes.", ""]
    for section in SECTIONS:
        lines.append(f"# {_SECTION_TITLES[section]}")
        lines.append(f"[{section}]")
        for key in keys_of(section):
            lines.append(f"# {key.doc} [{key.unit}]; allowed: {key.range_text()}")
            if notes and f"{section}.{key.name}" in notes:
                lines.append(f"# {notes[section + '.' + key.name]}")
            lines.append(f"{key.name} = {_toml_value(values[section][key.name])}")
        lines.append("")
    return "\n".join(lines)


def default_config_text() -> str:
    """The full default configuration file (what ``tofjax config`` prints)."""
    return render_toml(defaults())

