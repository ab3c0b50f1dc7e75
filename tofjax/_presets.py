"""Camera presets: a named camera described by what public documents state about it, every key
with its kind and source (issue 50 item 3; docs/fitting.md, "Presets").

A preset is a partial configuration, one module per camera (``tofjax/_cameras/``). Every value it
sets says what kind of value it is, as the first word of its note:

- ``quoted``: stated in a public document (a datasheet, a paper, a vendor's documentation or SDK),
  quoted with where it stands (the note names a reference tag);
- ``derived``: computed from a stated physical argument and sourced numbers (the note gives the
  argument: a responsivity from a quantum efficiency, an illumination power bounded by IEC 60825-1
  class 1 at the product's field of view, a key that the prediction depends on only through a
  product with a fitted one);
- ``fitted``: fitted to the camera's published performance (the note names the numbers, the fit and
  the interval over which they hold).

Keys that are not the camera's, the operating point (``[scene]``), another camera's light
(``[interference]``) and the simulation's own choices (:data:`NOT_THE_CAMERA`), keep their defaults
and say so; three ``[scene]`` keys are the camera's all the same (:data:`CAMERA_IN_SCENE`: its optical
band-pass filter and the exposure of the mode it models). A key of a camera that a preset neither sets nor covers by a section's source is
*unsourced* (:meth:`Preset.unsourced`): the rendered TOML marks it, and a preset of a real camera
has none (tests/test_presets.py).

Interpretations, applied to every preset:
- A datasheet's *responsivity* in A/W is the pixel's own response: microlens and fill factor are
  already inside it. The preset therefore sets ``camera.fill_factor = 1`` so that the fill factor is
  not counted twice.
- A *demodulation (modulation) contrast* quoted at one frequency holds only there.
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Mapping
from typing import Any

from ._schema import SECTIONS, keys_of, suggest

#: The kinds of a preset's value (the first word of its note).
KINDS = ("quoted", "derived", "fitted")
UNKNOWN = "unsourced: no source for this camera; the default (the thesis' verification camera) is kept"
#: Sections and keys that are not a property of the camera: the operating point, another camera's
#: light, the sensor's temperature of the moment and the simulation's own choices.
NOT_THE_CAMERA_SECTIONS = ("scene", "interference")
NOT_THE_CAMERA = ("pixel.noise", "pixel.iterations", "pixel.temperature_c", "frame.seed", "frame.subpixel_samples",
                  "frame.mixed_spread_fraction")
#: Keys of ``[scene]`` that are a property of the camera: its band-pass filter, its mode's exposure.
CAMERA_IN_SCENE = ("scene.filter_half_width_m", "scene.integration_time_s", "scene.integration_time_per")
_NOT_THE_CAMERA_NOTE = ("not the camera's: the operating point or the simulation's choice (set it to your "
                        "measurement's; default: the thesis' §5.5.1)")


def quoted(values: Mapping[str, tuple[Any, str]]) -> dict[str, tuple[Any, str]]:
    """``values`` (dotted key -> (value, note)) with every note marked ``quoted``."""
    return {key: (value, f"quoted: {note}") for key, (value, note) in values.items()}


def camera_key(dotted: str) -> bool:
    """Whether ``dotted`` is a property of the camera (not :data:`NOT_THE_CAMERA`)."""
    if dotted in CAMERA_IN_SCENE:
        return True
    return dotted.partition(".")[0] not in NOT_THE_CAMERA_SECTIONS and dotted not in NOT_THE_CAMERA


@dataclasses.dataclass(frozen=True)
class Preset:
    """A camera described by its publications (module docstring).

    - ``name``: what ``tofjax config --preset NAME`` takes;
    - ``title``: the camera;
    - ``references``: tag -> full citation;
    - ``values``: dotted key -> (value, note); the note starts with its kind (:data:`KINDS`) and a
      colon, and names a reference tag;
    - ``section_sources``: section -> note (with its kind) for every key of the section the preset
      does not set (the thesis preset: its tables);
    - ``product``: whether the preset is a product one can buy (a reference camera on a sensor, built
      from its datasheet and stated typical parts, is not: it has no published performance to meet);
    - ``unpublished``: for a product whose maker publishes no performance anywhere the sources reach,
      why (its docs page says the same); empty: its published performance is in ``fitting/validation``;
    - ``unmet``: the rows of the camera's published specification or characterisation
      (``fitting/validation/``) that the preset does not meet, each with the physical reason:
      ``"<file>:<column>:line <n>"`` (the row's line in the file) -> reason (tests/test_presets.py holds every other row to
      its bound, and every measured value to a factor 2).
    """

    name: str
    title: str
    references: Mapping[str, str]
    values: Mapping[str, tuple[Any, str]]
    section_sources: Mapping[str, str] = dataclasses.field(default_factory=dict)
    unmet: Mapping[str, str] = dataclasses.field(default_factory=dict)
    product: bool = True
    unpublished: str = ""

    def __post_init__(self):
        for dotted, (_, note) in self.values.items():
            if kind_of(note) is None:
                raise ValueError(f"preset {self.name}: the note of {dotted} must start with one of "
                                 + ", ".join(f"'{k}:'" for k in KINDS) + f", got {note!r}")
        for section, note in self.section_sources.items():
            if kind_of(note) is None:
                raise ValueError(f"preset {self.name}: the note of [{section}] must start with one of "
                                 + ", ".join(f"'{k}:'" for k in KINDS) + f", got {note!r}")

    def raw(self) -> dict[str, dict[str, Any]]:
        """The preset as a partial nested configuration (what a TOML file would hold)."""
        out: dict[str, dict[str, Any]] = {}
        for dotted, (value, _) in self.values.items():
            section, _, name = dotted.partition(".")
            out.setdefault(section, {})[name] = value
        return out

    def notes(self) -> dict[str, str]:
        """Dotted key -> the note of its value (its kind first), not the camera's, or unsourced."""
        out = {}
        for section in SECTIONS:
            for key in keys_of(section):
                dotted = f"{section}.{key.name}"
                if dotted in self.values:
                    out[dotted] = self.values[dotted][1]
                elif not camera_key(dotted):
                    out[dotted] = _NOT_THE_CAMERA_NOTE
                else:
                    out[dotted] = self.section_sources.get(section, UNKNOWN)
        return out

    def kinds(self) -> dict[str, str]:
        """Dotted key of the camera -> its kind (:data:`KINDS`) or ``"unsourced"``."""
        return {dotted: kind_of(note) or "unsourced" for dotted, note in self.notes().items() if camera_key(dotted)}

    def unsourced(self) -> list[str]:
        """The camera's keys without a source (module docstring)."""
        return [dotted for dotted, kind in self.kinds().items() if kind == "unsourced"]


def kind_of(note: str) -> str | None:
    """The kind a note starts with (:data:`KINDS`), or ``None``."""
    head = note.partition(":")[0].strip()
    return head if head in KINDS else None


#: The presets' modules in ``tofjax/_cameras/``, in the order ``tofjax config --preset`` lists them.
CAMERAS = ("thesis", "pmd_pico_flexx", "kinect_v2", "azure_kinect", "basler_blaze_101", "lucid_helios2",
           "ti_opt8241_cdk", "melexis_mlx75027")


def _load() -> dict[str, Preset]:
    out = {}
    for module in CAMERAS:
        p = importlib.import_module(f"._cameras.{module}", __package__).PRESET
        out[p.name] = p
    return out


PRESETS: dict[str, Preset] = _load()


def preset(name: str) -> Preset:
    """The preset called ``name``; a ``ValueError`` naming the allowed names otherwise."""
    if not isinstance(name, str) or name not in PRESETS:
        raise ValueError(f"preset = {name!r} is not known: allowed " + ", ".join(repr(p) for p in PRESETS)
                         + (suggest(name, PRESETS) if isinstance(name, str) else ""))
    return PRESETS[name]


def preset_config(name: str):
    """The validated :class:`tofjax.Config` of a preset (its values over the defaults)."""
    from ._config import config_from_dict

    return config_from_dict(preset(name).raw(), where=f"preset {name}")


def preset_text(name: str) -> str:
    """The full TOML of a preset: every key with its meaning and range, and then its source or
    the mark that the sources leave it unknown."""
    from ._config import render_toml

    p = preset(name)
    head = [f"# tofjax camera configuration, preset {p.name!r}: {p.title}.", "# References:"]
    head += [f"#   [{tag}] {citation}" for tag, citation in p.references.items()]
    kinds = p.kinds()
    counts = ", ".join(f"{sum(k == kind for k in kinds.values())} {kind}" for kind in (*KINDS, "unsourced"))
    head.append(f"# Every key of the camera says what it is ({counts}): quoted from a public document, derived from "
                "a stated argument, or fitted to the camera's published performance; 'unsourced' keys keep the thesis "
                "camera's value and are guesses for this camera. [scene] and [interference] are the operating point, "
                "not the camera.")
    return render_toml(preset_config(name).values, notes=p.notes(), header=head)
