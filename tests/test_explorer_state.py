"""The explorer's state without widgets (tofjax/_explorer_state.py): editing and validation, files in
its one folder and the overwrite confirmation, a run and whether it is stale; no ipywidgets needed."""

import subprocess
import sys

import tofjax as tj
from tofjax._explorer_state import ExplorerState, Message
from tofjax._schema import KEY_BY_DOTTED


def test_the_state_needs_no_widgets():
    code = ("import sys; sys.modules['ipywidgets'] = None\n"
            "from tofjax._explorer_state import ExplorerState\nExplorerState()\n"
            "assert 'ipywidgets' not in [m for m in sys.modules if sys.modules[m] is not None]")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_edits_validate_the_whole_configuration_and_keep_the_last_valid_one(tmp_path):
    state = ExplorerState(folder=tmp_path)
    key = KEY_BY_DOTTED["pixel.v_saturated_v"]
    error = state.edit(key, lambda: 3.5)  # above v_reset_v: the pair is refused, the last valid config kept
    assert error is not None and "pixel.v_saturated_v" in error and state.error == error
    assert float(state.config.params.pixel.v_saturated_v) == 2.0
    assert state.edit(key, lambda: 1.5) is None and state.error is None
    assert float(state.config.params.pixel.v_saturated_v) == 1.5
    assert state.take_changed() == {"pixel"} and state.take_changed() == set()


def test_files_stay_in_the_folder_and_an_existing_one_waits_for_a_confirmation(tmp_path):
    state = ExplorerState(folder=tmp_path)
    assert state.resolve("../outside.toml") == Message(
        f"../outside.toml: the explorer reads and writes files only in {tmp_path.resolve()} (its folder, chosen when it "
        "started)", True)
    again = []
    assert state.save("camera.toml", False, lambda overwrite: again.append(overwrite)) == Message(
        f"saved {tmp_path.resolve() / 'camera.toml'}")
    first = (tmp_path / "camera.toml").read_text()
    state.edit(KEY_BY_DOTTED["pixel.v_saturated_v"], lambda: 1.5)
    waiting = state.save("camera.toml", False, lambda overwrite: again.append(overwrite))
    assert waiting.error and "camera.toml exists: press Overwrite" in waiting.text and state.pending is not None
    assert (tmp_path / "camera.toml").read_text() == first  # nothing replaced before the confirmation
    state.confirm()
    assert again == [True]
    assert state.save("camera.toml", True, lambda overwrite: None).text.startswith("saved ")
    assert state.pending is None and "v_saturated_v = 1.5" in (tmp_path / "camera.toml").read_text()
    loaded, message = state.load("camera.toml")
    assert isinstance(loaded, tj.Config) and float(loaded.params.pixel.v_saturated_v) == 1.5
    assert message == Message(f"loaded {tmp_path.resolve() / 'camera.toml'}")


def test_the_path_box_names_a_file_in_the_folder_never_the_folder_itself(tmp_path):
    """Issue 49 item 13: "." or the folder's own path put the plots, the CSV and the report beside the
    folder, in its parent."""
    from types import SimpleNamespace

    folder = tmp_path / "work"
    (folder / "sub").mkdir(parents=True)
    state = ExplorerState(folder=folder)
    for text in (".", str(folder), "sub", f"{folder}/sub/.."):
        message = state.resolve(text)
        assert message == Message(f"{text}: is a folder, not a file: give the name of a file in {folder.resolve()} "
                                  "(e.g. camera.toml)", True), message
    state.run, state.figures = SimpleNamespace(sweep=SimpleNamespace(variable="distance")), {"snr": None}
    written, message = state.write_plots(".", ["snr"], "png", lambda path, _fig: path.write_text("x"), False, None)
    assert written is None and message.error and sorted(p.name for p in tmp_path.iterdir()) == ["work"]


def test_a_long_file_name_is_saved_or_refused_in_one_line(tmp_path):
    """Issue 49 item 12: a legal 250-character name failed ("File name too long": its temporary name
    is longer); a name longer than the file system allows raised OSError out of Save."""
    state = ExplorerState(folder=tmp_path)
    name = "c" * 245 + ".toml"
    assert state.save(name, False, None) == Message(f"saved {tmp_path.resolve() / name}")
    message = state.save("c" * 300 + ".toml", False, None)
    assert message.error and "the name is 305 bytes long: this file system allows at most 255" in message.text
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_a_run_is_stale_once_the_settings_differ(tmp_path):
    state = ExplorerState(tj.config_from_dict({"scene": {"samples": 5}}), folder=tmp_path)
    assert state.check_calculate(False, -1) == Message("seed = -1 is out of range: allowed integer >= 0", True)
    run, figures, numbers = state.compute(state.config, state.config.sweep("distance"), "analytic", 0, ["amplitude"],
                                          overlay=False)
    state.accept(run, figures, numbers)
    assert set(figures) == {"amplitude"} and not state.stale("distance", "analytic", 0)
    assert state.stale("illuminance", "analytic", 0) and state.stale("distance", "mc", 0)
    assert not state.stale("distance", "analytic", 7)  # the seed matters to Monte Carlo runs only
    state.edit(KEY_BY_DOTTED["scene.distance_m"], lambda: 2.0)
    assert state.stale("distance", "analytic", 0)


def test_a_frame_of_a_scene_in_words_or_a_file_of_the_folder(tmp_path):
    """The Frame tab's state: a built-in scene's analytic frame and Monte Carlo frames (its headline
    text says which), a depth map from the folder, and a message, not an exception, for a scene that
    is not one, a file outside the folder and bad counts."""
    import numpy as np

    config = tj.Config().replace("camera.optical_area_m", [31 * 17.5e-6, 21 * 17.5e-6])
    state = ExplorerState(config, folder=tmp_path)
    arrays, text = state.frame(config, "step_edge:near_m=1,far_m=1.6", 0, 0)
    assert arrays["radial_m"].shape == (21, 31) and "(analytic)" in text and "good pixels" in text
    arrays, text = state.frame(config, "wall", 4, 1)
    assert "(Monte Carlo)" in text and np.all(np.isfinite(arrays["depth_std_m"]))
    np.savez(tmp_path / "depth.npz", z_m=np.full((21, 31), 1.2))
    arrays, _ = state.frame(config, "depth.npz", 0, 0)
    np.testing.assert_allclose(arrays["z_true_m"], 1.2)
    assert state.frame(config, "walll", 0, 0).text.startswith("scene 'walll' is not a built-in scene")
    assert "only in" in state.frame(config, "../depth.npz", 0, 0).text
    dual = config.replace("illumination_waveform.extra_modulation_frequencies_hz", [60.24e6])
    arrays, text = state.frame(dual, "wall", 0, 0)  # two frequencies: fused (tofjax/_multiframe.py)
    assert float(arrays["unambiguity_range_m"]) > 7.4 and "good pixels" in text
    assert state.frame(config, "wall", -1, 0) == Message("frames = -1 is out of range: allowed integer 0 <= value <= "
                                                         "10000", True)
    fig = tj.frameio.frame_figure(arrays)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]  # the images (their colour bars have none)
    assert titles == [tj.frameio.MAPS[name][0] for name in ("radial_m", "error_mm", "depth_std_mm", "amplitude_lsb",
                                                            "flags")]
