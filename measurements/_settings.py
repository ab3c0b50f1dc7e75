"""The settings of ``tofjax record``: one table of options, validated the same way whether they come
from the command line (``--roi 3,3``) or a campaign file (``[campaign] roi = [3, 3]``), and the
pre-flight checks of the whole campaign before any device moves.

Every problem is a :class:`CampaignInputError`: one line naming the option (``--roi``) or the file
and key (``lts.toml: campaign.roi``), the value and what is allowed.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from pathlib import Path
from typing import Any

from tofjax.schema import KEY_BY_DOTTED, SWEEP_AXES, in_range, suggest

from . import _registry as reg

#: The sweeps a recording makes: the stage moves the target, the camera sets its exposure, the
#: operator (or a virtual lamp) sets the background light. A sweep of the sensor's temperature needs a
#: climate chamber, which no driver here controls.
RECORDABLE_SWEEPS = tuple(name for name in SWEEP_AXES if name != "temperature")

#: Frames x ROI pixels per point the virtual camera renders in memory at once (about 100 bytes each
#: with the kept frames of the Monte Carlo: 0.4 GB).
MAX_SAMPLES_PER_POINT = 2**22
BYTES_PER_SAMPLE = 100
MAX_ROI_SIDE = 4096


class CampaignInputError(ValueError):
    """A bad recording setting: the message names the option or file and key, the value and the range."""


@dataclasses.dataclass(frozen=True)
class Option:
    """One setting: ``key`` (campaign key and argparse dest), ``flag`` (command-line option),
    ``kind`` (int, float, choice, int_pair, float_pair, path, text, stage, bool), range or choices
    (``schema`` takes the range of a configuration key), default and help."""

    key: str
    flag: str
    kind: str
    help: str
    default: Any = None
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    choices: tuple[str, ...] = ()
    schema: str | None = None

    def allowed(self) -> str:
        if self.schema is not None:
            k = KEY_BY_DOTTED[self.schema]
            return f"{k.range_text()} [{k.unit}]"
        if self.kind == "choice":
            return "one of " + ", ".join(self.choices)
        if self.kind == "stage":
            return reg.stage_allowed_text()
        if self.kind in ("path", "text"):
            return "a non-empty text"
        if self.kind == "bool":
            return "true or false"
        rng = ("" if self.lo is None else f"{self.lo:g} {'<' if self.lo_open else '<='} ") + "value" + (
            "" if self.hi is None else f" <= {self.hi:g}")
        if self.kind == "int":
            return f"an integer {rng}"
        if self.kind == "int_pair":
            return f"W,H: two integers, each {rng}"
        if self.kind == "float_pair":
            return "LO,HI: two finite numbers with LO < HI"
        return f"a number {rng}" if rng != "value" else "a finite number"


def _opt(key, flag, kind, help, default=None, **kw) -> Option:
    return Option(key, flag, kind, help, default, **kw)


OPTIONS: tuple[Option, ...] = (
    _opt("config", "--config", "path", "camera model configuration (TOML) of the virtual camera"),
    _opt("sweep", "--sweep", "choice", "the swept quantity", choices=RECORDABLE_SWEEPS),
    _opt("start", "--from", "float", "first point (m, s or lx; within the swept quantity's range)"),
    _opt("stop", "--to", "float", "last point (m, s or lx)"),
    _opt("samples", "--samples", "int", "number of points", lo=1, hi=1_000_000),
    _opt("frames", "--frames", "int", "frames per point (default 100)", 100, lo=2, hi=1_000_000),
    _opt("roi", "--roi", "int_pair", "centre ROI width,height in pixels (default 3,3)", (3, 3), lo=1,
         hi=MAX_ROI_SIDE),
    _opt("stage", "--stage", "stage", "stage: " + reg.stage_allowed_text() + " (default virtual)", "virtual"),
    _opt("counts_per_mm", "--counts-per-mm", "float", "stage encoder counts per mm (LTS: 409600)", 409600.0,
         lo=0.0, lo_open=True, hi=1e9),
    _opt("travel", "--travel", "float_pair", "stage travel lo,hi in m (default 0,4.5)", (0.0, 4.5)),
    _opt("distance_offset", "--distance-offset", "float", "target distance minus stage position, m (default 0)", 0.0,
         lo=-1e3, hi=1e3),
    _opt("camera", "--camera", "choice", "camera (default virtual)", "virtual", choices=tuple(reg.CAMERAS)),
    _opt("use_case", "--use-case", "text", "Royale use case (sets the modulation frequencies)"),
    _opt("lux", "--lux", "choice", "lux meter (default virtual)", "virtual", choices=tuple(reg.LUX_METERS)),
    _opt("lux_value", "--lux-value", "float", "virtual lux meter reading for non-illuminance sweeps, lx (default 0)",
         0.0, schema="scene.illuminance_lx"),
    _opt("distance", "--distance", "float", "target distance for non-distance sweeps, m (default 1)", 1.0,
         schema="scene.distance_m"),
    _opt("integration_time", "--integration-time", "float", "exposure for non-exposure sweeps, s (default 2e-3)",
         2e-3, schema="scene.integration_time_s"),
    _opt("settle", "--settle", "float", "wait after every move or change, s (default 0)", 0.0, lo=0.0, hi=3600.0),
    _opt("seed", "--seed", "int", "seed of the virtual camera (default 0)", 0, lo=0, hi=2**63 - 1),
    _opt("raw_dir", "--raw-dir", "path", "also save every point's frames as .npz here"),
    _opt("resume", "--resume", "bool", "continue an interrupted recording in --out", False),
    _opt("out", "--out", "path", "output CSV (tofjax-sweep format)"),
)
OPTION_BY_KEY = {o.key: o for o in OPTIONS}
REQUIRED = ("sweep", "start", "stop", "samples", "out")


class _Bad(Exception):
    """A value's problem, without its name (the caller names the option or the key)."""


def _in_range(opt: Option, x: float) -> bool:
    if opt.schema is not None:
        return in_range(KEY_BY_DOTTED[opt.schema], x)
    return (opt.lo is None or (x > opt.lo if opt.lo_open else x >= opt.lo)) and (opt.hi is None or x <= opt.hi)


def _number(value: Any, integer: bool):
    if isinstance(value, bool):
        raise _Bad("has the wrong type")
    if isinstance(value, str):
        try:
            value = int(value.strip()) if integer else float(value.strip())
        except ValueError:
            raise _Bad("is not " + ("an integer" if integer else "a number")) from None
    if integer and not isinstance(value, int):
        raise _Bad("is not an integer")
    if not integer and not isinstance(value, (int, float)):
        raise _Bad("has the wrong type")
    if not math.isfinite(value):
        raise _Bad("is not a finite number")
    return value if integer else float(value)


def parse_value(opt: Option, value: Any) -> Any:
    """``value`` (command-line text or TOML value) in canonical form, or :class:`_Bad`."""
    kind = opt.kind
    if kind == "bool":
        if not isinstance(value, bool):
            raise _Bad("has the wrong type")
        return value
    if kind in ("choice", "path", "text", "stage"):
        if not isinstance(value, str):
            raise _Bad("has the wrong type")
        if not value.strip():
            raise _Bad("is empty")
        if kind == "choice" and value not in opt.choices:
            raise _Bad("is not allowed" + suggest(value, opt.choices))
        if kind == "stage" and not reg.is_stage_name(value):
            raise _Bad("is not a stage" + suggest(value, reg.STAGES))
        return Path(value) if kind == "path" else value
    if kind in ("int_pair", "float_pair"):
        parts = value.split(",") if isinstance(value, str) else value
        if not isinstance(parts, (list, tuple)) or len(parts) != 2:
            raise _Bad("is not two comma-separated numbers")
        pair = tuple(_number(p, kind == "int_pair") for p in parts)
        if kind == "int_pair" and not all(_in_range(opt, x) for x in pair):
            raise _Bad("is out of range")
        if kind == "float_pair" and not pair[0] < pair[1]:
            raise _Bad("is reversed or empty (LO must be less than HI)")
        return pair
    x = _number(value, kind == "int")
    if not _in_range(opt, x):
        raise _Bad("is out of range")
    return x


def _fmt(value: Any) -> str:
    return repr(str(value)) if isinstance(value, Path) else repr(value)


def argparse_type(opt: Option):
    """An argparse ``type=`` for ``opt``: argparse then reports ``argument --roi: 'abc' is not ...``."""
    import argparse

    def convert(text: str):
        try:
            return parse_value(opt, text)
        except _Bad as bad:
            raise argparse.ArgumentTypeError(f"{text!r} {bad}: allowed {opt.allowed()}") from None

    convert.__name__ = opt.kind  # argparse names the type in some messages
    return convert


def _read_campaign(path: Path) -> dict[str, Any]:
    from tofjax.schema import read_toml

    raw = read_toml(path, "campaign file")
    unknown = [k for k in raw if k != "campaign"]
    if unknown:
        hint = ("; put it under [campaign]" if unknown[0] in OPTION_BY_KEY else "")
        raise CampaignInputError(f"{path}: unknown table or key {unknown[0]!r}: a campaign file holds one [campaign] "
                                 f"table{hint}")
    table = raw.get("campaign", {})
    if not isinstance(table, dict):
        raise CampaignInputError(f"{path}: campaign = {table!r} must be a table: write [campaign] and the settings "
                                 "below it")
    return table


@dataclasses.dataclass(frozen=True)
class Plan:
    """A validated recording: the settings (``values`` by key) and where each came from (``origin``:
    ``--roi`` or ``lts.toml: campaign.roi``), for messages."""

    values: dict[str, Any]
    origin: dict[str, str]

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    def name(self, key: str) -> str:
        return self.origin.get(key, OPTION_BY_KEY[key].flag)

    def fail(self, key: str, message: str) -> CampaignInputError:
        return CampaignInputError(f"{self.name(key)} = {_fmt(self.values[key])} {message}")


def resolve(cli: dict[str, Any]) -> Plan:
    """Merge defaults < campaign file < command line (``cli``: parsed options, ``None`` where absent;
    ``campaign``: the file) and check the settings together (:func:`check`)."""
    values = {o.key: o.default for o in OPTIONS}
    origin: dict[str, str] = {}
    campaign = cli.get("campaign")
    if campaign is not None:
        for key, value in _read_campaign(campaign).items():
            where = f"{campaign}: campaign.{key}"
            opt = OPTION_BY_KEY.get(key)
            if opt is None:
                raise CampaignInputError(f"{campaign}: unknown campaign key {key!r}{suggest(key, OPTION_BY_KEY)}")
            try:
                values[key] = parse_value(opt, value)
            except _Bad as bad:
                raise CampaignInputError(f"{where} = {_fmt(value)} {bad}: allowed {opt.allowed()}") from None
            origin[key] = where
    for key, value in cli.items():
        if key in OPTION_BY_KEY and value is not None and not (OPTION_BY_KEY[key].kind == "bool" and value is False):
            values[key], origin[key] = value, OPTION_BY_KEY[key].flag
    plan = Plan(values, origin)
    for key in REQUIRED:
        if values[key] is None:
            raise CampaignInputError(f"record needs {OPTION_BY_KEY[key].flag} (or '{key}' in the campaign file)")
    check(plan)
    return plan


def points(plan: Plan):
    import numpy as np

    return np.linspace(plan["start"], plan["stop"], plan["samples"])


def stage_positions(plan: Plan):
    """Every position the stage will be sent to (m)."""
    import numpy as np

    if plan["sweep"] == "distance":
        return points(plan) - plan["distance_offset"]
    return np.array([plan["distance"] - plan["distance_offset"]])


def check(plan: Plan) -> None:
    """The checks across settings, all before anything moves: the sweep's range, its order, every
    stage position within the travel, the memory of one point."""
    sweep = plan["sweep"]
    key = KEY_BY_DOTTED[SWEEP_AXES[sweep].key]
    for name in ("start", "stop"):
        x = plan[name]
        if not in_range(key, x):
            raise plan.fail(name, f"is out of range for the {sweep} sweep: allowed {key.range_text()} [{key.unit}]")
    if plan["samples"] > 1 and not plan["start"] < plan["stop"]:
        raise CampaignInputError(f"{plan.name('start')} = {plan['start']!r} must be less than {plan.name('stop')} = "
                                 f"{plan['stop']!r} (a sweep runs upwards; for one point give --samples 1)")
    lo, hi = plan["travel"]
    positions = stage_positions(plan)
    outside = (positions < lo) | (positions > hi)
    if outside.any():
        what = (f"{plan.name('start')} {plan['start']:g} .. {plan.name('stop')} {plan['stop']:g} m"
                if sweep == "distance" else f"{plan.name('distance')} = {plan['distance']:g} m")
        raise CampaignInputError(
            f"{what} needs stage positions {positions.min():g} .. {positions.max():g} m (distance minus "
            f"{plan.name('distance_offset')} {plan['distance_offset']:g} m); {int(outside.sum())} of {len(positions)} "
            f"are outside {plan.name('travel')} {lo:g},{hi:g} m; nothing moved")
    w, h = plan["roi"]
    samples = plan["frames"] * w * h
    if samples > MAX_SAMPLES_PER_POINT:
        raise CampaignInputError(
            f"{plan.name('frames')} {plan['frames']} x {plan.name('roi')} {w},{h} = {samples:,} pixel samples per "
            f"point (about {samples * BYTES_PER_SAMPLE / 1e9:.3g} GB in memory): allowed frames x W x H <= "
            f"{MAX_SAMPLES_PER_POINT:,}; take fewer frames or a smaller ROI")


def grid_metadata(plan: Plan, config_values: dict) -> dict[str, str]:
    """What a resumed recording must share with the file it continues (written as metadata)."""
    digest = hashlib.sha256(json.dumps(config_values, sort_keys=True).encode()).hexdigest()[:16]
    return {"grid_from": repr(float(plan["start"])), "grid_to": repr(float(plan["stop"])),
            "grid_samples": str(plan["samples"]), "frames": str(plan["frames"]),
            "roi": f"{plan['roi'][0]}x{plan['roi'][1]}", "camera": plan["camera"],
            "distance_offset_m": repr(float(plan["distance_offset"])), "config_sha256": digest}
