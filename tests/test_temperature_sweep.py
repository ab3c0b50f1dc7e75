"""The sensor's temperature as the operating point's fourth coordinate (issue 36 item 3;
docs/model.md "The temperature as a sweep axis"): sweeps, the sweep file's format 3, the fit's
operating points, the command lines."""

import equinox as eqx
import jax
import numpy as np
import pytest

import tofjax as tj
from tofjax import sweepfile as sf
from tofjax._config import config_from_dict
from tofjax._noise import AbstractThermalNoise, dark_current_factor

TEMPERATURES_C = np.array([0.0, 25.0, 47.5, 70.0])
#: A camera whose phase drifts with temperature, so that every effect of the temperature shows.
CONFIG = config_from_dict({"pixel": {"phase_drift_rad_per_c": 0.01}})


def _at(params, temperature_c):
    return eqx.tree_at(lambda p: p.pixel.temperature_c, params, temperature_c)


@pytest.fixture(scope="module")
def swept():
    """An analytic temperature sweep at 1 m, and the same points as cameras of those temperatures."""
    params = CONFIG.params
    sweep = tj.Sweep("temperature", TEMPERATURES_C)
    by_camera = [tj.predict(_at(params, t), tj.Sweep("distance", [1.0])) for t in TEMPERATURES_C]
    return jax.device_get(tj.predict(params, sweep)), jax.device_get(by_camera)


def test_each_point_is_the_camera_at_its_temperature(swept):
    """Catches a temperature that misses the dark current, the phase drift or either kTC source:
    every field of every point (noise breakdown included) equals the camera configured at that
    temperature, to 1e-12."""
    result, by_camera = swept
    assert result.sweep_variable == "temperature"
    np.testing.assert_array_equal(result.temperature_c, TEMPERATURES_C)
    for i, one in enumerate(by_camera):
        for name in ("depth_mean_m", "depth_std_m", "amplitude_mean_lsb", "amplitude_std_lsb", "tap_a_e", "code_mean",
                     "snr_db", "intensity_e", "full_well_fraction"):
            np.testing.assert_allclose(getattr(result, name)[i], getattr(one, name)[0], rtol=1e-12, err_msg=name)
        for name, value in result.noise.source_items():
            np.testing.assert_allclose(value[i], one.noise.sources[name][0], rtol=1e-12, err_msg=name)
        np.testing.assert_allclose(result.noise.dark_e[i], one.noise.dark_e[0], rtol=1e-12)


def test_closed_forms_of_the_temperature(swept):
    """kTC variances scale as the absolute temperature, the dark electrons double every
    ``dark_doubling_temperature_c``, and the depth reads longer by k (T - T_ref) c / (4 pi f) plus
    the wiggling's change (checked against the phase the mixer adds, not a fit)."""
    result, _ = swept
    pixel = CONFIG.params.pixel
    kelvin = TEMPERATURES_C + 273.15
    i25 = 1  # the pixel's own temperature
    for name in ("reset", "hold"):
        np.testing.assert_allclose(result.noise.sources[name] ** 2 / result.noise.sources[name][i25] ** 2,
                                   kelvin / kelvin[i25], rtol=1e-12)
    doubling = float(pixel.dark_doubling_temperature_c)
    np.testing.assert_allclose(result.noise.dark_e / result.noise.dark_e[i25],
                               2.0 ** ((TEMPERATURES_C - 25.0) / doubling), rtol=1e-12)
    np.testing.assert_allclose(dark_current_factor(pixel, TEMPERATURES_C), 2.0 ** ((TEMPERATURES_C - 25.0) / doubling),
                               rtol=1e-12)
    assert np.all(np.diff(result.depth_mean_m) > 0)  # the phase drifts one way: the reading grows


def test_thermal_sources_are_exactly_unchanged_at_the_pixels_temperature():
    """A sweep of another axis passes the nominal temperature to every point: the kTC variance is
    multiplied by exactly 1, so the results are what they were before the axis existed (bit for bit)."""
    params = CONFIG.params
    sources = [s for s in tj.chain.build_chain(params).noise.sources if isinstance(s, AbstractThermalNoise)]
    assert {s.name for s in sources} == {"reset", "hold"}
    charges = tj.chain.build_chain(params).expose(*tj.Sweep("distance", [1.0, 2.0]).operating_points(params))
    for source in sources:
        a, b = source.variance_e2(charges)
        np.testing.assert_array_equal(a, np.broadcast_to(source.sigma_e**2, a.shape))
        np.testing.assert_array_equal(b, a)


def test_monte_carlo_reads_each_points_temperature():
    """The Monte Carlo's draw takes each point's kTC and dark noise from its own temperature: a
    25 °C camera's sweep whose points carry 70 °C draws exactly the frames of the camera configured
    at 70 °C (same key, same point indices; the same program, the kTC variances scaled by T / T_pixel
    against computed at 70 °C), to 1e-12."""
    params = CONFIG.params
    n = 2
    given = tj.Sweep.points("distance", np.full(n, 1.0), np.full(n, 20.0), np.full(n, 2e-3), np.full(n, 70.0))
    ours = tj.simulate(params, given, jax.random.key(3), 64)
    theirs = tj.simulate(_at(params, 70.0), given, jax.random.key(3), 64)
    assert float(theirs.noise.reset_e[0]) > 1.03 * float(tj.predict(params, tj.Sweep("distance", [1.0])).noise.reset_e[0])
    for name in ("depth_mean_m", "depth_std_m", "amplitude_mean_lsb", "amplitude_std_lsb", "code_mean"):
        np.testing.assert_allclose(getattr(ours, name), getattr(theirs, name), rtol=1e-12, err_msg=name)
    np.testing.assert_array_equal(ours.temperature_c, np.full(n, 70.0))
    with pytest.raises(ValueError, match="Sweep.points: a temperature sweep needs its temperature_c column"):
        tj.Sweep.points("temperature", np.ones(n), np.ones(n), np.ones(n))


def test_sweep_file_round_trip_and_versions(swept, tmp_path):
    """A temperature sweep's file is format 3 with a ``temperature_c`` column that reads back; other
    sweeps stay version 1 (no column); an older version naming the sweep or the column is refused
    with its line and column, never misread."""
    result, _ = swept
    cols = sf.columns_from_result(result)
    assert list(cols)[:4] == ["distance_m", "integration_time_s", "illuminance_lx", "temperature_c"]
    meta = {"sweep": "temperature", "source": "simulation", "modulation_frequency_hz": "80320000.0", "n_phases": 4}
    path = sf.write_sweep(tmp_path / "warm.csv", meta, cols)
    text = path.read_text()
    assert text.startswith("# format: tofjax-sweep/3\n")
    back = sf.read_sweep(path)
    np.testing.assert_array_equal(back.columns["temperature_c"], TEMPERATURES_C)
    assert sf.needed_format({"sweep": "distance"}, sf.REQUIRED_COLUMNS) == sf.FORMAT_V1
    old = text.replace("tofjax-sweep/3", "tofjax-sweep/2", 1)
    with pytest.raises(sf.SweepFileError, match=r"warm\.csv:2: sweep = 'temperature' needs format tofjax-sweep/3"):
        sf.parse_sweep(old, "warm.csv")
    old = old.replace("# sweep: temperature", "# sweep: distance")
    header_line = 1 + next(i for i, line in enumerate(old.splitlines()) if line.startswith("distance_m,"))
    column = 1 + old.splitlines()[header_line - 1].index("temperature_c")
    with pytest.raises(sf.SweepFileError, match=rf"warm\.csv:{header_line}:{column}: column temperature_c needs "
                                                r"format tofjax-sweep/3"):
        sf.parse_sweep(old, "warm.csv")
    no_column = text.replace(",temperature_c,", ",t_c,", 1)
    with pytest.raises(sf.SweepFileError, match="missing required column temperature_c: the file's sweep is "
                                                "temperature"):
        sf.parse_sweep(no_column, "warm.csv")
    hot = text.splitlines()
    row = hot[header_line]
    cells = row.split(",")
    cells[3] = "250.0"
    hot[header_line] = ",".join(cells)
    with pytest.raises(sf.SweepFileError, match=r"column temperature_c = 250\.0 is out of range: .* as "
                                                r"pixel\.temperature_c"):
        sf.parse_sweep("\n".join(hot), "warm.csv")


def test_the_fit_reads_each_files_temperatures(swept, tmp_path):
    """A file's ``temperature_c`` column sets its rows' operating points; without it every row is at
    the file's ``# pixel.temperature_c:`` line or the configuration's; the temperature is never a
    fitted parameter."""
    from fitting._data import read_measurement
    from fitting._parameters import OPERATING_POINT, CalibrationInputError, fittable_names, make_parameters

    result, _ = swept
    cols = sf.columns_from_result(result)
    meta = {"sweep": "temperature", "source": "measurement", "modulation_frequency_hz": "80320000.0", "n_phases": 4}
    m = read_measurement(sf.write_sweep(tmp_path / "warm.csv", meta, cols), CONFIG)
    np.testing.assert_array_equal(m.sweep.temperature_c, TEMPERATURES_C)
    del cols["temperature_c"]
    plain = {**meta, "sweep": "distance", "pixel.temperature_c": "40.0"}
    m = read_measurement(sf.write_sweep(tmp_path / "plain.csv", plain, cols), CONFIG)
    np.testing.assert_array_equal(m.sweep.temperature_c, np.full(len(TEMPERATURES_C), 40.0))
    assert float(m.config.params.pixel.temperature_c) == 40.0
    del plain["pixel.temperature_c"]
    m = read_measurement(sf.write_sweep(tmp_path / "nominal.csv", plain, cols), CONFIG)
    np.testing.assert_array_equal(m.sweep.temperature_c, np.full(len(TEMPERATURES_C), 25.0))
    assert "pixel.temperature_c" in OPERATING_POINT and "pixel.temperature_c" not in fittable_names()
    with pytest.raises(CalibrationInputError, match="--fit: pixel.temperature_c is not fittable: it is an "
                                                    "operating-point column"):
        make_parameters(["pixel.temperature_c"], {"pixel.temperature_c": 25.0})


def test_command_lines(tmp_path, capsys):
    """``simulate --sweep temperature`` checks its range against ``pixel.temperature_c``'s and the
    configured range comes from ``[scene] temperature_from_c/_to_c``; ``record`` offers only the
    sweeps its devices can set."""
    from tofjax.cli import main

    assert CONFIG.sweep("temperature", samples=3).values.tolist() == [0.0, 35.0, 70.0]
    assert main(["simulate", "--sweep", "temperature", "--from", "-300", "--out", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert "--from = -300.0 is out of range for the temperature sweep: allowed -273.15 < value <= 200 [degC]" in err
    with pytest.raises(SystemExit) as exit_info:  # argparse's choices
        main(["record", "--sweep", "temperature", "--from", "0", "--to", "1", "--samples", "2",
              "--out", str(tmp_path / "r.csv")])
    assert exit_info.value.code == 2
    assert ("argument --sweep: 'temperature' is not allowed: allowed one of distance, illuminance, integration_time"
            in capsys.readouterr().err)
    with pytest.raises(ValueError, match="sweep = 'temperature' is not allowed"):
        from measurements._campaign import CampaignSettings

        CampaignSettings("temperature", 0.0, 1.0, 2)
