"""The tofjax command: config, simulate, and its error handling."""

import re
import subprocess
import sys
import tomllib

import numpy as np
import pytest

import tofjax as tj
from tofjax import sweepfile as sf
from tofjax.cli import main


def test_config_prints_the_commented_default_file(capsys, tmp_path):
    assert main(["config"]) == 0
    out = capsys.readouterr().out
    assert tomllib.loads(out) == tj.Config().values
    assert main(["config", "--out", str(tmp_path / "c.toml")]) == 0
    assert tj.load_config(tmp_path / "c.toml").values == tj.Config().values


@pytest.mark.parametrize("method", ["mc", "analytic"])
def test_simulate_writes_a_readable_sweep_file(capsys, tmp_path, method):
    out = tmp_path / "sweep.csv"
    args = ["simulate", "--sweep", "distance", "--from", "0.5", "--to", "3", "--samples", "6", "--method", method,
            "--iterations", "64", "--out", str(out)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "depth std [mm]" in printed and "unambiguity range 1.8662 m" in printed and str(out) in printed
    assert "frame: 4 phase images of 2 ms" in printed and "eye safety (an estimate against IEC 60825-1" in printed
    data = sf.read_sweep(out)
    assert data.metadata["source"] == "simulation" and data.metadata["method"] == method
    assert data.n_rows == 6 and data.n_phases == 4 and data.modulation_frequency_hz == 80.32e6
    np.testing.assert_allclose(data.columns["distance_m"], np.linspace(0.5, 3, 6))
    assert np.all(data.columns["n_frames"] == (64 if method == "mc" else 0))
    assert np.all(data.columns["depth_std_m"] > 0)
    assert tj.config_from_dict(__import__("json").loads(data.metadata["config_json"])).values == tj.Config().values


def test_simulate_uses_the_configuration(tmp_path, capsys):
    cfg = tmp_path / "cam.toml"
    cfg.write_text("[pixel]\nn_phases = 3\n[scene]\nsamples = 4\nintegration_time_from_s = 1e-3\n")
    out = tmp_path / "t.csv"
    assert main(["simulate", "--config", str(cfg), "--sweep", "integration_time", "--method", "analytic",
                 "--out", str(out)]) == 0
    # The summary's integration time is in seconds, as --from and --to take it (it was in ms).
    table = capsys.readouterr().out.splitlines()
    assert table[0].startswith("integration_time [s]") and table[2].split()[0] == "0.001"
    data = sf.read_sweep(out)
    assert data.n_phases == 3 and data.n_rows == 4 and data.sweep == "integration_time"
    np.testing.assert_allclose(data.columns["integration_time_s"], np.linspace(1e-3, 5e-3, 4))


@pytest.mark.parametrize(
    "config_text, extra, pattern",
    [
        ("[pixel]\ndemodulation_contrast = 1.7\n", [], "pixel.demodulation_contrast = 1.7 is out of range"),
        ("[pixel]\nn_phases = \n", [], "line 2, column 12: malformed TOML"),
        ("", ["--samples", "0"], "argument --samples: 0 is out of range"),
        ("", ["--from", "3", "--to", "1"], "must be less than"),
        ("", ["--from", "-1"], r"--from = -1.0 is out of range for the distance sweep: allowed 0 < value <= 1000 \[m\]$"),
    ],
)
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, config_text, extra, pattern):
    cfg = tmp_path / "cam.toml"
    cfg.write_text(config_text)
    args = ["simulate", "--config", str(cfg), "--sweep", "distance", "--method", "analytic", "--samples", "3",
            "--out", str(tmp_path / "o.csv"), *extra]
    assert _exit_code(args) == 2
    err = capsys.readouterr().err
    assert "tofjax: error:" in err and "Traceback" not in err
    assert re.search(pattern, err), err


def _exit_code(args):
    """main() returns 2 for bad values; argparse raises SystemExit(2) for bad arguments."""
    try:
        return main(args)
    except SystemExit as exc:
        return exc.code


def test_no_traceback_from_the_installed_entry_point(tmp_path):
    cfg = tmp_path / "cam.toml"
    cfg.write_text("[camera]\nk_lense = 0.8\n")
    proc = subprocess.run([sys.executable, "-m", "tofjax.cli", "simulate", "--config", str(cfg), "--sweep", "distance",
                           "--out", str(tmp_path / "x.csv")], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip() == ('tofjax: error: ' + str(cfg) + ': unknown key camera.k_lense (did you mean "k_lens"?)')
    assert not (tmp_path / "x.csv").exists()
    # A command ends without the interpreter's teardown (tofjax.cli.entry_point): what it printed into a
    # pipe (block-buffered, a table shorter than the buffer) still arrives whole, its file complete.
    proc = subprocess.run([sys.executable, "-m", "tofjax.cli", "simulate", "--sweep", "distance", "--samples", "5",
                           "--method", "analytic", "--quiet", "--out", str(tmp_path / "y.csv")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.startswith("distance [m]") and "eye safety" in proc.stdout
    assert sf.read_sweep(tmp_path / "y.csv").n_rows == 5


def test_tofjax_alone_prints_its_help(capsys):
    """Without a command: the help on standard output and status 0 (it was an error, status 2)."""
    assert main([]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("usage: tofjax") and all(c in out for c in ("simulate", "render", "calibrate")) and err == ""


def test_help_imports_neither_jax_nor_matplotlib():
    """`tofjax --help` and every subcommand's help answer without importing JAX or matplotlib (about
    0.2 s instead of 1.6: `tofjax record`'s option table had pulled JAX in through tofjax.schema)."""
    script = """
import contextlib, io, sys
from tofjax.cli import main
for sub in ([], ["simulate"], ["render"], ["record"], ["calibrate"], ["compare"], ["config"]):
    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
        main([*sub, "--help"])
print(sorted(m for m in ("jax", "matplotlib", "equinox") if m in sys.modules))
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_run_sweep_refuses_unknown_methods_and_fuses_frequencies_analytically():
    from tofjax._run import run_sweep

    config = tj.Config()
    sweep = config.sweep("distance", samples=3)
    with pytest.raises(ValueError, match="method = 'fast' is not allowed"):
        run_sweep(config, sweep, "fast")
    dual = config.replace("illumination_waveform.extra_modulation_frequencies_hz", [60.24e6])
    fused = run_sweep(dual, sweep, "analytic").multifrequency  # analytic fusion of both frequencies
    per = np.asarray(fused.per_frequency.depth_std_m)
    np.testing.assert_allclose(np.asarray(fused.depth_std_m), (per[0] ** -2 + per[1] ** -2) ** -0.5, rtol=1e-12)
    run = run_sweep(config, sweep, "analytic")
    assert run.result.method == "analytic" and run.multifrequency is None and run.elapsed_s > 0


#: The libraries of the extras [fit] (emcee, corner) and [record] (pyusb, pyftdi, thorlabs-apt-protocol).
_EXTRA_MODULES = ("emcee", "corner", "usb", "pyftdi", "thorlabs_apt_protocol")


def test_the_base_install_needs_no_extra_and_a_command_names_the_one_it_needs(tmp_path):
    """The base dependencies leave out [fit] and [record] (which [test] brings); with their libraries
    unimportable, the model and the simulate command run, and calibrate --mcmc and an APT stage say
    in one line which extra to install, exit 2, before any work."""
    from pathlib import Path

    project = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())["project"]
    base = " ".join(project["dependencies"])
    extras = project["optional-dependencies"]
    for name in ("emcee", "corner", "pyusb", "pyftdi", "thorlabs-apt-protocol"):
        assert name not in base
        assert any(name in d for d in extras["fit"] + extras["record"])
    assert "tofjax[fit,record,notebooks,hdf5,mujoco,open3d]" in extras["test"]
    assert "mujoco" not in base and "open3d" not in base  # the renderers are extras (tofjax.renderers)
    example = Path(__file__).parents[1] / "fitting" / "examples"
    script = f"""
import sys
sys.modules.update(dict.fromkeys({_EXTRA_MODULES!r}))  # None: "import emcee" raises ImportError
import tofjax as tj
from tofjax.cli import main
assert tj.predict(tj.Params(), tj.Sweep("distance", [1.0])).depth_std_m.shape == (1,)
assert main(["simulate", "--sweep", "distance", "--samples", "2", "--iterations", "8", "--out", r"{tmp_path / 's.csv'}"]) == 0
assert main(["calibrate", r"{example / 'distance.csv'}", "--fit", "pixel.demodulation_contrast", "--out", r"{tmp_path / 'cal'}", "--mcmc"]) == 2
assert main(["record", "--sweep", "distance", "--from", "1", "--to", "2", "--samples", "2", "--stage", "fake",
             "--out", r"{tmp_path / 'r.csv'}"]) == 2
import fitting
try:
    fitting.sample_posterior(None, None)
except ModuleNotFoundError as err:
    print(err, file=sys.stderr)
loaded = [m for m in {_EXTRA_MODULES!r} if sys.modules.get(m) is not None]
assert not loaded, loaded
"""
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    lines = run.stderr.splitlines()
    assert 'tofjax: error: --mcmc needs emcee, which is not installed: pip install "tofjax[fit]"' in lines
    assert ('tofjax: error: APT stages need thorlabs-apt-protocol, which is not installed: '
            'pip install "tofjax[record]"') in lines
    assert 'fitting.sample_posterior needs emcee, which is not installed: pip install "tofjax[fit]"' in lines
    assert not (tmp_path / "cal").exists() and not (tmp_path / "r.csv").exists()
