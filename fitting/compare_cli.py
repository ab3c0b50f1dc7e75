"""``tofjax compare``: registered with the ``tofjax`` command through the ``tofjax.commands``
entry point (see :mod:`tofjax.cli`)."""

from __future__ import annotations

import time
from pathlib import Path


def register(subparsers) -> None:
    from tofjax.cli import add_output_options

    p = subparsers.add_parser(
        "compare", help="put measured sweeps beside the model, without fitting (thesis Table 4.27)",
        description="The thesis' analyze-LTS-data function (§4.4.2, Table 4.27): per file the measured depth against "
                    "the real distance with the model's expected depth (wiggling) and error, amplitude, depth noise "
                    "(absolute and relative) and the model/measured ratio per point; rows the model saturates or "
                    "cannot measure are flagged. Writes comparison.csv, comparison.md, comparison.html (figures "
                    "embedded) and one PNG per file. Depth-only, amplitude-only and multi-frequency files work. A file "
                    "that states bounds (format tofjax-sweep/4, a datasheet's promise) gets every bound checked: met "
                    "or not, with its margin (bounds.csv, and a section of the report).")
    p.add_argument("sweeps", nargs="+", type=Path, metavar="SWEEP.csv", help="tofjax-sweep files")
    p.add_argument("--config", type=Path, help="camera configuration TOML (default: built-in defaults)")
    p.add_argument("--out", type=Path, required=True, help="output directory")
    p.add_argument("--check", action="store_true", help="validate the files and the output, compare nothing")
    add_output_options(p)
    p.set_defaults(run=run)


def run(args) -> int:
    from tofjax.cli import check_output_dir, enable_compilation_cache, on_interrupt, output_dir, untouched_note

    check_output_dir(args.out, "--out", args)
    # Before JAX starts: a comparison is one short analytic program per camera, where compilation is
    # most of the time (the faster-compiling CPU emitters: 10.1 -> see docs/fitting.md).
    enable_compilation_cache(fast_compile=True, notice=False)
    import tofjax as tj

    from ._compare import bound_lines, compare_measurements, write_comparison
    from ._data import read_measurement

    config = tj.load_config(args.config) if args.config else tj.Config()
    measurements = [read_measurement(p, config) for p in args.sweeps]  # every file checked before any work
    if args.check:
        print(f"plan: compare {sum(m.data.n_rows for m in measurements)} rows of {len(measurements)} file(s) with the "
              f"model; into {args.out}")
        return 0
    on_interrupt(untouched_note(args.out))
    t0 = time.perf_counter()
    comparisons = compare_measurements(measurements)
    source = str(args.config) if args.config else "built-in defaults"
    with output_dir(args.out, "tofjax compare", args) as folder:
        written = write_comparison(comparisons, folder.staging, title="Measured vs model (tofjax compare)",
                                   preamble=[f"tofjax {tj.__version__}; configuration: {source}."])
    for c in comparisons:
        parts = []
        for name, text in (("depth_std_m", "depth noise"), ("amplitude_mean_lsb", "amplitude")):
            s = c.summary(name)
            if s["rows"]:
                parts.append(f"{text} model/measured median {s['median_ratio']:.3f}, {s['within']}/{s['rows']} within 30 %")
        flagged = sum(bool(f) for f in c.flags)
        if parts or not c.bounds:
            print(f"{c.path}: " + ("; ".join(parts) or "no comparable rows")
                  + (f"; {flagged} rows flagged" if flagged else ""))
        for line in bound_lines(c):
            print(f"{c.path}: {line}")
    print(f"wrote {len(written)} files to {args.out} in {time.perf_counter() - t0:.1f} s: "
          + ", ".join(p.name for p in written))
    return 0
