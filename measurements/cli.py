"""``tofjax record``: registered with the ``tofjax`` command through the ``tofjax.commands`` entry
point (see :mod:`tofjax.cli`). Settings come from the options and/or a TOML campaign file
(``[campaign]`` with the same names, underscores for dashes); options win."""

from __future__ import annotations

import argparse
import tomllib
from pathlib import Path

from tofjax.cli import finite_float, positive_float, positive_int

_DEFAULTS = {"frames": 100, "roi": "3,3", "stage": "virtual", "camera": "virtual", "lux": "virtual",
             "lux_value": 0.0, "counts_per_mm": 409600.0, "travel": "0,4.5", "distance": 1.0,
             "integration_time": 2e-3, "settle": 0.0, "seed": 0, "distance_offset": 0.0}


def _pair(text: str, kind=float):
    try:
        a, b = (kind(x) for x in str(text).split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not two comma-separated numbers") from None
    return a, b


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "record", help="record a sweep on a linear translation stage (or virtually) into a tofjax-sweep CSV",
        description="Move the stage / set the exposure / read the lux meter, grab frames of a centre ROI, and append "
                    "one row of statistics per point (fsynced): an interrupted campaign leaves a valid file and "
                    "--resume continues it. Without hardware, the virtual stage, camera and lux meter run tofjax's "
                    "Monte Carlo model.")
    p.add_argument("--campaign", type=Path, help="TOML campaign file ([campaign] with the options below)")
    p.add_argument("--config", type=Path, help="camera model configuration for the virtual camera")
    p.add_argument("--sweep", choices=("distance", "integration_time", "illuminance"))
    p.add_argument("--from", dest="start", type=finite_float, help="first point (m, s or lx)")
    p.add_argument("--to", dest="stop", type=finite_float, help="last point (m, s or lx)")
    p.add_argument("--samples", type=positive_int, help="number of points")
    p.add_argument("--frames", type=positive_int, help=f"frames per point (default {_DEFAULTS['frames']})")
    p.add_argument("--roi", help="centre ROI width,height in pixels (default 3,3)")
    p.add_argument("--stage", help="virtual (default), fake (byte-exact fake APT controller) or an FTDI URL such as "
                                   "ftdi://0x0403:0xfaf0/1")
    p.add_argument("--counts-per-mm", type=positive_float, help="stage encoder counts per mm (LTS: 409600)")
    p.add_argument("--travel", help="stage travel lo,hi in m (default 0,4.5)")
    p.add_argument("--distance-offset", type=finite_float, help="target distance minus stage position, m")
    p.add_argument("--camera", choices=("virtual", "royale"), help="camera (default virtual)")
    p.add_argument("--use-case", help="Royale use case (sets the modulation frequencies)")
    p.add_argument("--lux", choices=("virtual", "manual"), help="lux meter (default virtual)")
    p.add_argument("--lux-value", type=finite_float, help="virtual lux meter reading for non-illuminance sweeps")
    p.add_argument("--distance", type=positive_float, help="target distance for non-distance sweeps, m")
    p.add_argument("--integration-time", type=positive_float, help="exposure for non-exposure sweeps, s")
    p.add_argument("--settle", type=finite_float, help="wait after every move or change, s")
    p.add_argument("--seed", type=int, help="seed of the virtual camera")
    p.add_argument("--raw-dir", type=Path, help="also save every point's frames as .npz here")
    p.add_argument("--resume", action="store_true", help="continue an interrupted recording in --out")
    p.add_argument("--out", type=Path, help="output CSV (tofjax-sweep format)")
    p.set_defaults(run=run)


def _settings(args) -> dict:
    values = dict(_DEFAULTS)
    if args.campaign is not None:
        try:
            table = tomllib.loads(args.campaign.read_text(encoding="utf-8"))
        except (OSError, tomllib.TOMLDecodeError) as err:
            raise ValueError(f"{args.campaign}: cannot read the campaign file: {err}") from None
        campaign = table.get("campaign", {})
        known = set(vars(args)) - {"command", "run", "campaign"}
        for key, value in campaign.items():
            if key not in known:
                from tofjax.schema import suggest

                raise ValueError(f"{args.campaign}: unknown campaign key {key!r}{suggest(key, sorted(known))}")
            values[key] = value
    for key, value in vars(args).items():
        if value is not None and value is not False and key not in ("command", "run", "campaign"):
            values[key] = value
    for key in ("sweep", "start", "stop", "samples", "out"):
        if values.get(key) is None:
            raise ValueError(f"record needs --{key.replace('_', '-')} (or '{key}' in the campaign file)")
    return values


def run(args) -> int:
    import tofjax as tj
    from tofjax.cli import CommandError

    from ._apt import AptStage, FtdiTransport, StageError
    from ._campaign import CampaignSettings, campaign_metadata, run_campaign
    from ._devices import CameraError, ManualLuxMeter, RoyaleCamera, VirtualCamera, VirtualLuxMeter, VirtualStage
    from ._fake_apt import FakeAptController

    v = _settings(args)
    config = tj.load_config(v["config"]) if v.get("config") else tj.Config()
    roi = _pair(v["roi"], int)
    travel = _pair(v["travel"])
    settings = CampaignSettings(v["sweep"], float(v["start"]), float(v["stop"]), int(v["samples"]), int(v["frames"]),
                                roi, float(v["distance"]), float(v["integration_time"]), float(v["lux_value"]),
                                float(v["settle"]), Path(v["raw_dir"]) if v.get("raw_dir") else None)
    if v["stage"] == "virtual":
        stage = VirtualStage(settings.distance_m, travel)
    else:
        # The fake controller here stands in for a stage in a demonstration or a test: it moves at
        # 1e10 counts/s (the real driver, bytes and all, without waiting for a 50 mm/s stage).
        transport = FakeAptController(velocity_counts_per_s=1e10) if v["stage"] == "fake" else FtdiTransport(v["stage"])
        stage = AptStage(transport, counts_per_mm=float(v["counts_per_mm"]), travel_m=travel)
    lux = ManualLuxMeter() if v["lux"] == "manual" else VirtualLuxMeter(settings.illuminance_lx)
    try:
        if v["camera"] == "royale":
            camera = RoyaleCamera(roi, v.get("use_case"))
        else:
            camera = VirtualCamera(config.params, stage, lux, roi, int(v["seed"]), float(v["distance_offset"]))
        stage.enable()
        if v["stage"] != "virtual":
            stage.home()
        camera.open()
        meta = campaign_metadata(settings, camera, stage, lux, config.params, {
            "stage_url": v["stage"], "stage_travel_m": f"{travel[0]:g},{travel[1]:g}"})
        if v["camera"] == "virtual":
            meta["source"] = "simulation"
            meta["note"] = "virtual camera: rendered by tofjax's Monte Carlo, not a measurement"
        written = run_campaign(settings, stage=stage, camera=camera, lux=lux, out=v["out"], metadata=meta,
                               resume=bool(v.get("resume")), distance_offset_m=float(v["distance_offset"]))
    except (StageError, CameraError) as err:
        raise CommandError(str(err), 1) from None
    finally:
        stage.close()
    print(f"recorded {written} points into {v['out']}")
    return 0
