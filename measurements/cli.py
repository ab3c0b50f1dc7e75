"""``tofjax record``: registered with the ``tofjax`` command through the ``tofjax.commands`` entry
point (see :mod:`tofjax.cli`). Settings come from the options and/or a TOML campaign file
(``[campaign]`` with the same names, underscores for dashes); options win. Every setting is
validated (:mod:`measurements._settings`) and every stage position checked before anything moves;
``--check`` stops there and prints the plan."""

from __future__ import annotations

from pathlib import Path

from ._settings import OPTIONS, argparse_type


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "record", help="record a sweep on a linear translation stage (or virtually) into a tofjax-sweep CSV",
        description="Move the stage / set the exposure / read the lux meter, grab frames of a centre ROI, and append "
                    "one row of statistics per point (fsynced): an interrupted campaign leaves a valid file and "
                    "--resume continues it. Without hardware, the virtual stage, camera and lux meter run tofjax's "
                    "Monte Carlo model.")
    p.add_argument("--campaign", type=Path, help="TOML campaign file ([campaign] with the options below)")
    for opt in OPTIONS:
        if opt.kind == "bool":
            p.add_argument(opt.flag, dest=opt.key, action="store_true", default=None, help=opt.help)
        else:
            p.add_argument(opt.flag, dest=opt.key, type=argparse_type(opt), help=opt.help,
                           metavar=opt.key.upper() if opt.kind != "choice" else None,
                           choices=opt.choices if opt.kind == "choice" else None)
    p.add_argument("--check", action="store_true", help="validate everything, print the plan, record nothing")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    from tofjax.cli import add_output_options

    add_output_options(p, resume="--resume")
    p.set_defaults(run=run)


def _describe(plan, points) -> str:
    from tofjax.schema import SWEEP_AXES

    unit = SWEEP_AXES[plan["sweep"]].unit
    w, h = plan["roi"]
    return (f"plan: {plan['samples']} points of a {plan['sweep']} sweep, {points[0]:g} .. {points[-1]:g} {unit}; "
            f"{plan['frames']} frames of a {w}x{h} ROI each; stage {plan['stage']} (travel {plan['travel'][0]:g},"
            f"{plan['travel'][1]:g} m), camera {plan['camera']}, lux meter {plan['lux']}; into {plan['out']}")


def run(args) -> int:
    from tofjax.cli import CommandError, check_output_dir, check_output_file, on_interrupt

    from . import _registry as reg
    from ._settings import CampaignInputError, resolve

    try:
        plan = resolve({k: v for k, v in vars(args).items() if k not in ("command", "run")})
    except CampaignInputError as err:
        raise CommandError(str(err), 2) from None
    import tofjax as tj

    from ._campaign import CampaignSettings, campaign_metadata, check_resume, run_campaign
    from ._interfaces import DeviceError, LuxMeterError
    from ._settings import grid_metadata, points

    config = tj.load_config(plan["config"]) if plan["config"] is not None else tj.Config()
    out = plan["out"]
    resume = bool(plan["resume"]) and out.exists()
    if not resume:  # a new recording: an existing file is kept unless the user says otherwise
        check_output_file(out, plan.name("out"), args, resume_option="--resume")
    if plan["raw_dir"] is not None:
        # --resume adds the missing points' files to it
        check_output_dir(plan["raw_dir"], plan.name("raw_dir"), args, resume_option="--resume",
                         overwrite=bool(plan["resume"] or args.overwrite))
    settings = CampaignSettings(plan["sweep"], plan["start"], plan["stop"], plan["samples"], plan["frames"],
                                plan["roi"], plan["distance"], plan["integration_time"], plan["lux_value"],
                                plan["settle"], plan["raw_dir"])
    grid = grid_metadata(plan, config.values)
    if plan["resume"] and out.exists():
        try:
            check_resume(out, settings, grid)
        except ValueError as err:
            raise CommandError(str(err), 2) from None
    print(_describe(plan, points(plan)))
    if args.check:
        return 0
    ctx = reg.DeviceContext(config, plan["roi"], plan["travel"], plan["counts_per_mm"], plan["distance"],
                            plan["lux_value"], plan["seed"], plan["distance_offset"], plan["use_case"])
    stage = camera = None
    try:
        try:  # opening: an absent or misnamed device is an input problem (exit status 2)
            stage = reg.make_stage(plan["stage"], ctx)
            lux = reg.make_lux_meter(plan["lux"], ctx)
            camera = reg.make_camera(plan["camera"], ctx, stage, lux)
            stage.enable()
            if plan["stage"] != "virtual":
                stage.home()
            camera.open()
        except DeviceError as err:
            raise CommandError(str(err), 2) from None
        meta = campaign_metadata(settings, camera, stage, lux, config.params, {
            "stage_url": plan["stage"], "stage_travel_m": f"{plan['travel'][0]:g},{plan['travel'][1]:g}", **grid})
        if plan["camera"] == "virtual":
            meta["source"] = "simulation"
            meta["note"] = "virtual camera: rendered by tofjax's Monte Carlo, not a measurement"

        def done_note(done: int, total: int) -> None:  # what Ctrl-C now leaves (done: the points in the file)
            on_interrupt(f"after {done} of {total} points; every completed point is in {out}; continue with --resume"
                         if done else "before the first point was measured; nothing was recorded")

        written = run_campaign(settings, stage=stage, camera=camera, lux=lux, out=out, metadata=meta,
                               resume=bool(plan["resume"]), distance_offset_m=plan["distance_offset"],
                               progress=not args.quiet, replace=args.overwrite,
                               replace_measurement=args.force_replace_measurement, on_point=done_note)
    except DeviceError as err:  # during the recording: every completed row is in the file
        # A lux meter without its operator is an input problem (2); a device that failed, a fault (1).
        raise CommandError(f"{err} (every completed point is in {out}; --resume continues)",
                           2 if isinstance(err, LuxMeterError) else 1) from None
    finally:
        if camera is not None:
            camera.close()
        if stage is not None:
            stage.close()
    print(f"recorded {written} points into {out}")
    return 0
