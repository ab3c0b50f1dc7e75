"""Device conformance: every stage, camera and lux meter ``tofjax record`` can drive passes the same
checks of its interface (measurements/_interfaces.py), the registry builds every name it lists, and
the Royale camera runs end to end over a fake ``roypy`` that mimics the SDK's Python API."""

import sys

import numpy as np
import pytest

import measurements as ms
import tofjax as tj
from measurements import _registry as reg
from tofjax import sweepfile as sf
from tofjax.cli import main

ROI = (2, 2)
FRAMES = 40  # the shapes of test_measurements' campaigns: the virtual camera's program is shared


def _apt_stage():
    return ms.AptStage(ms.FakeAptController(velocity_counts_per_s=5e9), counts_per_mm=ms.COUNTS_PER_MM["lts"],
                       travel_m=(0.0, 4.5), timeout_s=0.5, move_timeout_s=5.0)


STAGES = {"virtual": lambda: ms.VirtualStage(1.0, (0.0, 4.5)), "apt-over-fake-controller": _apt_stage}


def _virtual_camera(stage):
    return ms.VirtualCamera(tj.Params(scene=tj.Scene(illuminance_lx=0.0)), stage, ms.VirtualLuxMeter(0.0), ROI, 0)


def _royale_camera(stage):
    fake = ms.FakeRoypy(distance_m=stage.position_m, depth_noise_m=0.004)
    return ms.RoyaleCamera(ROI, "MODE_5_45FPS_500", modulation_frequency_hz=80.32e6, roypy=fake)


CAMERAS = {"virtual": _virtual_camera, "royale-over-fake-roypy": _royale_camera}
LUX_METERS = {"virtual": lambda: ms.VirtualLuxMeter(250.0),
              "manual": lambda: ms.ManualLuxMeter(ask=lambda prompt: "250", tell=lambda text: None)}


@pytest.mark.parametrize("make", STAGES.values(), ids=STAGES.keys())
def test_stage_conformance(make):
    stage = make()
    assert isinstance(stage, ms.Stage)
    stage.enable()
    stage.home()
    assert stage.position_m() == pytest.approx(stage.travel_m[0], abs=1e-6)
    assert stage.move_to(1.25) == pytest.approx(1.25, abs=1e-6)
    assert stage.position_m() == pytest.approx(1.25, abs=1e-6)
    with pytest.raises(ms.StageLimitError, match="outside the travel.*nothing moved"):
        stage.move_to(stage.travel_m[1] + 0.1)
    assert stage.position_m() == pytest.approx(1.25, abs=1e-6)  # refused before moving
    assert issubclass(ms.StageLimitError, ms.DeviceError)
    stage.stop()
    stage.close()


@pytest.mark.parametrize("make", CAMERAS.values(), ids=CAMERAS.keys())
def test_camera_conformance(make):
    stage = ms.VirtualStage(1.5, (0.0, 4.5))
    camera = make(stage)
    assert isinstance(camera, ms.Camera)
    camera.open()
    assert camera.model and camera.serial and camera.model != "unknown"
    assert camera.modulation_frequency_hz > 0
    assert camera.amplitude_quantity in ("amplitude_lsb", "gray_value")
    assert camera.depth_wrap_m is None or camera.depth_wrap_m > 0
    camera.set_integration_time(1e-3)
    frames = camera.grab(FRAMES)
    for array in (frames.depth_m, frames.amplitude_lsb, frames.valid):
        assert np.shape(array) == (FRAMES, ROI[1], ROI[0])
    assert frames.valid.dtype == bool and frames.valid.all()
    depth = np.asarray(frames.depth_m)
    expected = 1.5 if camera.depth_wrap_m is None else 1.5 % camera.depth_wrap_m
    assert abs(np.median(depth) - expected) < 0.05  # the target at the stage's position
    stats = ms.point_statistics(frames, camera.depth_wrap_m)
    assert 0 < stats["depth_std_m"] < 0.05 and stats["valid_fraction"] == 1.0
    camera.close()


@pytest.mark.parametrize("make", LUX_METERS.values(), ids=LUX_METERS.keys())
def test_lux_meter_conformance(make):
    meter = make()
    assert isinstance(meter, ms.LuxMeter)
    assert meter.read_lx() == 250.0


def test_the_registry_builds_every_name_it_lists(monkeypatch):
    monkeypatch.setitem(sys.modules, "roypy", ms.FakeRoypy())
    ctx = reg.DeviceContext(tj.Config(), ROI, (0.0, 4.5), 20000.0, 1.0, 0.0, 0, 0.0, None)
    lux = {name: reg.make_lux_meter(name, ctx) for name in reg.LUX_METERS}
    assert all(isinstance(m, ms.LuxMeter) for m in lux.values())
    stages = {name: reg.make_stage(name, ctx) for name in reg.STAGES}
    assert all(isinstance(s, ms.Stage) for s in stages.values())
    for name in reg.CAMERAS:
        assert isinstance(reg.make_camera(name, ctx, stages["virtual"], lux["virtual"]), ms.Camera)
    assert reg.is_stage_name("ftdi://0x0403:0xfaf0/1") and not reg.is_stage_name("ftdi://")
    assert not reg.is_stage_name("bogus")


@pytest.mark.parametrize("fake_kwargs, call, pattern", [
    ({"cameras": 0}, "open", r"no Royale camera is connected"),
    ({"sensor": (1, 1)}, "open", r"--roi 2,2 does not fit the sensor: allowed W <= 1, H <= 1"),
    ({"use_cases": ("MODE_9_5FPS_2000",)}, "open", r"--use-case 'MODE_5_45FPS_500' is not a use case of this camera"),
    ({"exposure_limits_us": (50, 500)}, "exposure", r"2000 us is outside this use case's exposure limits: allowed "
                                                    r"50 <= value <= 500 us"),
])
def test_royale_failures_are_camera_errors(fake_kwargs, call, pattern):
    camera = ms.RoyaleCamera(ROI, "MODE_5_45FPS_500", modulation_frequency_hz=80.32e6,
                             roypy=ms.FakeRoypy(**fake_kwargs))
    with pytest.raises(ms.CameraError, match=pattern):
        camera.open()
        camera.set_integration_time(2e-3)


def test_royale_grab_names_a_camera_that_stops_delivering():
    camera = ms.RoyaleCamera(ROI, None, modulation_frequency_hz=80.32e6, timeout_s=0.05,
                             roypy=ms.FakeRoypy(frame_period_s=1.0))
    camera.open()
    with pytest.raises(ms.CameraError, match=r"delivered \d of 3 frames, then nothing for 0.05 s"):
        camera.grab(3)


def test_record_with_a_royale_camera_labels_the_gray_value_honestly(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "roypy", ms.FakeRoypy(distance_m=lambda: 1.0))
    out = tmp_path / "royale.csv"
    assert main(["record", "--camera", "royale", "--use-case", "MODE_5_45FPS_500", "--sweep", "distance",
                 "--from", "0.8", "--to", "1.2", "--samples", "3", "--frames", str(FRAMES), "--roi", "2,2",
                 "--quiet", "--out", str(out)]) == 0
    data = sf.read_sweep(out)
    assert data.metadata["source"] == "measurement" and data.metadata["camera_model"] == "PICOFLEXX (fake roypy)"
    assert "gray value (not the model's amplitude in LSB)" in data.metadata["amplitude"]
    assert data.metadata["modulation_frequency_source"].startswith("configuration")
    assert np.isnan(data.columns["amplitude_mean_lsb"]).all() and np.isnan(data.columns["amplitude_std_lsb"]).all()
    assert (data.columns["gray_value_mean"] > 0).all() and (data.columns["gray_value_std"] > 0).all()
    np.testing.assert_allclose(data.columns["depth_mean_m"], 1.0, atol=0.01)  # linear statistics, not wrapped
    np.testing.assert_allclose(data.columns["depth_std_m"], 0.003, rtol=0.3)  # the fake's noise
    import fitting as ft

    rows = ft.load_rows(out, tj.Config())  # the calibration takes it, depth noise only
    assert len(rows.used("depth_std_m")) == 3 and len(rows.used("amplitude_mean_lsb")) == 0
