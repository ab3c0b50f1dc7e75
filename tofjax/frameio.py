"""Full frames' files, public: writing frames (:func:`tofjax.predict` and :func:`tofjax.simulate` of a
frame scene) as NPZ arrays, PNG colour maps with colour bars, a PLY point cloud and a self-contained
HTML report (``tofjax render``); :func:`save_returns` and :func:`load_returns` (a scene's
:class:`tofjax.Returns` as ``.npz``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ._flags import CAMERA_FLAGS, DIAGNOSTIC_FLAGS, FLAG_KEYS, FLAGS, delivered, flag_fractions, no_good_pixels_line
from .outputs import save_figure, write_bytes, write_text
from .outputs import write_npz as write_npz_file

def __getattr__(name: str):
    if name in ("save_returns", "load_returns"):  # they need JAX; this module's writers do not
        from . import _returns

        return getattr(_returns, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: Map name -> (title, unit, colour map) of the PNGs ("categorical": the flags, :func:`flag_classes`).
MAPS = {
    "radial_m": ("Measured radial distance", "m", "viridis"),
    "z_m": ("Measured Z depth", "m", "viridis"),
    "error_mm": ("Distance error (measured - true,\nwrapped to +- half the unambiguity range)", "mm", "coolwarm"),
    "depth_std_mm": ("Depth noise (Monte Carlo std over frames)", "mm", "magma"),
    "predicted_std_mm": ("Predicted depth noise (analytic)", "mm", "magma"),
    "amplitude_lsb": ("Amplitude", "LSB", "gray"),
    "intensity_e": ("Intensity (mean electrons per tap)", "e-", "gray"),
    "frame_radial_m": ("One noisy frame: radial distance", "m", "viridis"),
    "flags": ("Flags: one colour per combination present\n(bits: frame.npz flag_names)", "-", "categorical"),
}

#: The colour of a good (unflagged) pixel and of each flag alone in the flags map (:func:`flag_classes`).
GOOD_COLOUR = "#e0e0e0"
FLAG_COLOURS = {1: "#d62728", 2: "#ff7f0e", 4: "#3b3b3b", 8: "#1f77b4", 16: "#9467bd", 32: "#8c564b", 64: "#bcbd22"}
#: The colours of combinations of flags, in the order of their share of the pixels (then repeated).
COMBINATION_COLOURS = ("#17becf", "#e377c2", "#2ca02c", "#aec7e8", "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5",
                       "#c49c94", "#f7b6d2", "#dbdb8d", "#9edae5")


def flag_classes(flags: np.ndarray) -> list[tuple[int, str, str]]:
    """The flags map's classes: one per combination of flags present, ``(code, label, colour)``; good
    pixels (code 0) first in :data:`GOOD_COLOUR`, each flag alone in its own colour
    (:data:`FLAG_COLOURS`), combinations in :data:`COMBINATION_COLOURS`; labels name the flags and
    their share of the pixels (``"mixed + wrapped: 0.4 %"``)."""
    codes, counts = np.unique(np.asarray(flags, dtype=np.int64), return_counts=True)
    order = sorted(zip(codes.tolist(), counts.tolist(), strict=True), key=lambda cc: (cc[0] != 0, -cc[1], cc[0]))
    out, spare = [], iter(COMBINATION_COLOURS * (1 + len(order) // len(COMBINATION_COLOURS)))
    for code, count in order:
        names = [FLAG_KEYS[bit].replace("_", " ") for bit in FLAGS if code & bit]
        label = " + ".join(names) if names else "good (no flag)"
        colour = GOOD_COLOUR if code == 0 else FLAG_COLOURS.get(code) or next(spare)
        out.append((code, f"{label}: {100 * count / np.size(flags):.3g} %", colour))
    return out


def flag_rgb(flags: np.ndarray, classes: list[tuple[int, str, str]]) -> np.ndarray:
    """The flags as an RGB image ``(rows, cols, 3)`` in their classes' colours (:func:`flag_classes`)."""
    from matplotlib.colors import to_rgb

    flags = np.asarray(flags, dtype=np.int64)
    rgb = np.zeros(flags.shape + (3,))
    for code, _, colour in classes:
        rgb[flags == code] = to_rgb(colour)
    return rgb


def _show_flags(fig, ax, flags: np.ndarray, fontsize: float = 8) -> None:
    """The flags map on ``ax``: every combination present in its colour, a legend naming each (a
    categorical map: on a colour scale the bits' sums read as numbers, wrapped pixels blue as good)."""
    from matplotlib.patches import Patch

    classes = flag_classes(flags)
    ax.imshow(flag_rgb(flags, classes), interpolation="nearest")
    fig.legend(handles=[Patch(facecolor=colour, edgecolor="0.5", label=label) for _, label, colour in classes],
               loc="outside right upper", fontsize=fontsize, title="pixels", title_fontsize=fontsize, frameon=False)


def frame_arrays(frame, predicted=None) -> dict[str, np.ndarray]:
    """The frame's images as NumPy arrays (``(rows, cols)``; ``frames_radial_m`` ``(frames, rows,
    cols)`` when frames were kept), with the analytic ``predicted`` frame's noise image if given;
    ``flags`` with its bits described in ``flag_names`` (``"1: saturated: ..."``, :data:`FLAGS`)."""
    r = frame.result
    out = {
        "radial_m": np.asarray(frame.radial_m), "z_m": np.asarray(frame.z_m),
        "radial_true_m": np.asarray(frame.radial_true_m), "z_true_m": np.asarray(frame.z_true_m),
        "depth_std_m": np.asarray(frame.depth_std_m), "amplitude_lsb": np.asarray(frame.amplitude_lsb),
        "amplitude_std_lsb": np.asarray(r.amplitude_std_lsb), "intensity_e": np.asarray(frame.intensity_e),
        "signal_e": np.asarray(r.noise.signal_e), "background_e": np.asarray(r.noise.background_e),
        "valid_fraction": np.asarray(r.valid_fraction), "flags": np.asarray(frame.flags),
        "direction": np.asarray(frame.direction), "unambiguity_range_m": np.asarray(r.unambiguity_range_m),
        "prnu_gain": np.asarray(frame.pattern.gain), "phase_offset_rad": np.asarray(frame.pattern.phase_offset_rad),
    }
    out["flag_names"] = np.array([f"{bit}: {text}" for bit, text in FLAGS.items()])
    if frame.frames_radial_m is not None:
        out["frames_radial_m"] = np.asarray(frame.frames_radial_m)
        out["frames_amplitude_lsb"] = np.moveaxis(np.asarray(r.amplitude_lsb), -1, 0)
        out["frames_valid"] = np.moveaxis(np.asarray(r.valid), -1, 0)
    if predicted is not None:
        out["predicted_std_m"] = np.asarray(predicted.depth_std_m)
    return out


#: What ``raw_convention`` in frame.npz says (docs/model.md, "Raw phase images").
RAW_CONVENTION = (
    "raw_codes[k, f, j] is the ADC code of the taps' difference A - B in phase image j of kept frame k at "
    "modulation frequency f (raw_mid_code: zero difference); raw_tap_a_e and raw_tap_b_e are the electrons each "
    "tap holds as read (after SBI and saturation, with the noise after them). Tap A integrates while the reference "
    "waveform, delayed by raw_phase_steps_rad[j], is high. Decoding: D = raw_codes - raw_mid_code, "
    "Re Z = sum_j raw_phase_weights[0, j] D_j, Im Z = sum_j raw_phase_weights[1, j] D_j (cos and sin of the steps, "
    "90-degree steps exact), radial distance = mod(arctan2(Im Z, Re Z), 2 pi) / (2 pi) * unambiguity_range_m, "
    "amplitude = raw_amplitude_scale * |Z| (frames_radial_m, frames_amplitude_lsb)")


def raw_arrays(frame, params) -> dict[str, np.ndarray]:
    """The raw phase images of a frame's kept frames (``frame.result.codes`` and the taps: rendered
    with ``raw=True``) in the
    documented layout of frame.npz (docs/model.md, "Raw phase images"): ``raw_codes`` (int32 with
    the hard ADC) and ``raw_tap_a_e``/``raw_tap_b_e`` (float32, electrons), each ``(frames,
    frequencies, phases, rows, cols)``; ``raw_phase_steps_rad`` ``(phases,)`` and
    ``raw_phase_weights`` ``(2, phases)`` (their cosines and sines, as the model demodulates),
    ``raw_modulation_frequencies_hz`` ``(frequencies,)``, ``raw_mid_code``, ``raw_amplitude_scale``
    and ``raw_convention`` (:data:`RAW_CONVENTION`). ``params``: the frame's camera."""
    from ._adc import mid_code
    from ._depth import amplitude_scale, phase_weights
    from ._waveforms import phase_steps

    r = frame.result
    if r.frames_tap_a_e is None:
        raise ValueError("the frame kept no raw phase images: render it with keep_frames >= 1 and raw=True")

    def layout(x):  # (rows, cols, frames, phases) -> (frames, 1 frequency, phases, rows, cols)
        return np.transpose(np.asarray(x), (2, 3, 0, 1))[:, None]

    codes = layout(r.codes)
    integral = np.all(np.isfinite(codes)) and np.array_equal(codes, np.round(codes))
    n_phases = codes.shape[2]
    return {
        "raw_codes": codes.astype(np.int32) if integral else codes,
        "raw_tap_a_e": layout(r.frames_tap_a_e).astype(np.float32),
        "raw_tap_b_e": layout(r.frames_tap_b_e).astype(np.float32),
        "raw_phase_steps_rad": np.asarray(phase_steps(n_phases), dtype=float),
        "raw_phase_weights": np.stack(phase_weights(n_phases)),
        "raw_modulation_frequencies_hz": np.array([float(params.illumination_waveform.modulation_frequency_hz)]),
        "raw_mid_code": np.asarray(mid_code(params.adc)),
        "raw_amplitude_scale": np.asarray(amplitude_scale(n_phases)),
        "raw_convention": np.array(RAW_CONVENTION),
    }


def write_npz(path, arrays: dict[str, np.ndarray]) -> Path:
    """All arrays in one compressed NPZ (``format = "tofjax-frame/1"``), written atomically
    (:mod:`tofjax.outputs`)."""
    return write_npz_file(path, {"format": np.array("tofjax-frame/1"), **arrays})


def write_ply(path, points_m: np.ndarray, values: np.ndarray | None = None, grey: np.ndarray | None = None) -> Path:
    """A binary little-endian PLY point cloud: float32 x, y, z (m); if given, a float32
    ``intensity`` per point; if given, a grey level per point (0-255) as uchar ``red``, ``green``,
    ``blue``: the colour Open3D and other viewers show."""
    path = Path(path)
    pts = np.asarray(points_m, dtype="<f4").reshape(-1, 3)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")] + ([("intensity", "<f4")] if values is not None else [])
    fields += [(c, "u1") for c in ("red", "green", "blue")] if grey is not None else []
    data = np.empty(len(pts), dtype=fields)
    data["x"], data["y"], data["z"] = pts[:, 0], pts[:, 1], pts[:, 2]
    if values is not None:
        data["intensity"] = np.asarray(values, dtype="<f4").reshape(-1)
    if grey is not None:
        for c in ("red", "green", "blue"):
            data[c] = np.asarray(grey, dtype=np.uint8).reshape(-1)
    header = ["ply", "format binary_little_endian 1.0", "comment tofjax frame: x right, y up, z along the optical "
              "axis, metres", f"element vertex {len(pts)}"]
    header += [f"property {'uchar' if kind == 'u1' else 'float'} {name}" for name, kind in fields] + ["end_header"]
    write_bytes(path, ("\n".join(header) + "\n").encode("ascii") + data.tobytes())
    return path


def read_ply(path) -> np.ndarray:
    """The vertices of a PLY written by :func:`write_ply`, as a structured array."""
    raw = Path(path).read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    props = [line.split()[1:] for line in raw[:end].decode("ascii").splitlines() if line.startswith("property")]
    return np.frombuffer(raw[end:], dtype=[(name, "u1" if kind == "uchar" else "<f4") for kind, name in props])


def grey_levels(values: np.ndarray) -> np.ndarray:
    """Grey levels 0-255 of ``values``, 255 at their 99th percentile (a few bright pixels do not
    darken the rest)."""
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)]
    top = float(np.percentile(finite, 99)) if finite.size else 0.0
    scaled = np.where(np.isfinite(values), values, 0.0) / top if top > 0 else np.zeros(values.shape)
    return np.round(255 * np.clip(scaled, 0.0, 1.0)).astype(np.uint8)


#: The 16-bit images engineers load directly: file -> (array, scale to the stored unit).
SIXTEEN_BIT = {"depth_mm.png": ("z_m", 1e3), "amplitude.png": ("amplitude_lsb", 1.0)}


def sixteen_bit(values: np.ndarray, scale: float, good: np.ndarray) -> np.ndarray:
    """``values x scale`` rounded to uint16; 0 where a pixel is not good, not finite or beyond 65535
    (0 is "no value", as in the depth images of other depth cameras)."""
    x = np.asarray(values, dtype=float) * scale
    ok = good & np.isfinite(x) & (x >= 0) & (np.round(x) <= 65535)
    return np.round(np.where(ok, x, 0.0)).astype(np.uint16)


def write_png16(path, image: np.ndarray) -> Path:
    """A 16-bit grayscale PNG of a uint16 image (Pillow, which matplotlib brings), written atomically."""
    import io

    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image, dtype=np.uint16)).save(buffer, format="PNG")
    return write_bytes(path, buffer.getvalue())


#: A colour map's layout in inches (:func:`write_png`): the map's longer side and the least of its
#: shorter one, and the margins around it for the row ticks and label (left), the column ticks and
#: label (bottom), above the title's lines (top), the colour bar with its ticks and label (right: a gap, the bar,
#: then its text).
MAP_SIZE_IN, MAP_MIN_IN = 5.0, 1.5
MAP_MARGINS_IN = {"left": 0.75, "bottom": 0.6, "top": 0.2, "right": 1.3}
#: The top margin's height per line of the title, in inches.
TITLE_LINE_IN = 0.22
COLOR_BAR_GAP_IN, COLOR_BAR_WIDTH_IN = 0.2, 0.18


def write_png(path, image: np.ndarray, title: str, unit: str, cmap: str = "viridis", vmin=None, vmax=None) -> Path:
    """One image as a PNG colour map with a colour bar and title (pixel (0, 0) at the top left);
    ``cmap="categorical"``: the flags, one colour per combination present and a legend naming them
    (:func:`map_figure`)."""
    save_figure(map_figure(image, title, unit, cmap, vmin, vmax), path)
    return Path(path)


def map_figure(image: np.ndarray, title: str, unit: str, cmap: str = "viridis", vmin=None, vmax=None):
    """:func:`write_png`'s figure (a ``matplotlib.figure.Figure``).

    The colour maps are placed by fixed margins (:data:`MAP_MARGINS_IN`), the map at its pixels'
    aspect ratio: matplotlib's constrained layout drew every figure twice and took half of a render's
    time to write its maps. The flags' legend, whose width depends on its entries, keeps it."""
    from matplotlib.figure import Figure

    image = np.asarray(image, dtype=float)
    rows, cols = image.shape
    if cmap == "categorical":  # the flags: a legend of the combinations present, not a colour bar
        fig = Figure(figsize=(9.0, 6.4 * rows / cols + 0.6), dpi=110, layout="constrained")
        ax = fig.subplots()
        _show_flags(fig, ax, image.astype(np.int64))
    else:
        m = MAP_MARGINS_IN
        # The longer side MAP_SIZE_IN, the shorter at the pixels' aspect ratio but at least MAP_MIN_IN
        # (a strip of a few rows is stretched, not drawn as a line).
        map_w, map_h = ((MAP_SIZE_IN, max(MAP_SIZE_IN * rows / cols, MAP_MIN_IN)) if cols >= rows
                        else (max(MAP_SIZE_IN * cols / rows, MAP_MIN_IN), MAP_SIZE_IN))
        # A tall map stands in the middle of a figure as wide as a wide one's, where its title fits.
        top = m["top"] + TITLE_LINE_IN * (title.count("\n") + 1)
        width, height = MAP_SIZE_IN + m["left"] + m["right"], map_h + m["bottom"] + top
        left = m["left"] + (MAP_SIZE_IN - map_w) / 2
        fig = Figure(figsize=(width, height), dpi=110)
        ax = fig.add_axes((left / width, m["bottom"] / height, map_w / width, map_h / height))
        bar = fig.add_axes(((left + map_w + COLOR_BAR_GAP_IN) / width, m["bottom"] / height,
                            COLOR_BAR_WIDTH_IN / width, map_h / height))
        if vmin is None:
            vmin, vmax = color_limits(image)
        shown = ax.imshow(np.ma.masked_invalid(image), cmap=cmap, vmin=vmin, vmax=vmax, interpolation="nearest",
                          aspect="auto")  # the axes have the image's aspect ratio (or the least height)
        fig.colorbar(shown, cax=bar, label=unit)
    ax.set_title(title)
    ax.set_xlabel("column")
    ax.set_ylabel("row")
    return fig


def color_limits(image: np.ndarray) -> tuple[float | None, float | None]:
    """A colour map's limits: the 1st and 99th percentiles of the finite values (all of them for 100
    or fewer), widened to a unit span where they are equal; ``(None, None)`` when none is finite."""
    finite = image[np.isfinite(image)]
    if not finite.size:
        return None, None
    vmin, vmax = np.percentile(finite, [1, 99]) if finite.size > 100 else (finite.min(), finite.max())
    return (vmin - 0.5, vmax + 0.5) if vmin == vmax else (vmin, vmax)


def map_images(arrays: dict[str, np.ndarray]) -> dict[str, tuple]:
    """The colour maps of :data:`MAPS` that the arrays allow: name -> (image, title, unit, colour map,
    (vmin, vmax) or (None, None)); what :func:`write_maps` writes and the explorer's Frame tab shows."""
    images = {
        "radial_m": arrays["radial_m"], "z_m": arrays["z_m"],
        "error_mm": 1e3 * distance_error_m(arrays),
        "depth_std_mm": 1e3 * arrays["depth_std_m"], "amplitude_lsb": arrays["amplitude_lsb"],
        "intensity_e": arrays["intensity_e"], "flags": arrays["flags"].astype(float),
    }
    if "predicted_std_m" in arrays:
        images["predicted_std_mm"] = 1e3 * arrays["predicted_std_m"]
    if "frames_radial_m" in arrays:
        images["frame_radial_m"] = arrays["frames_radial_m"][0]
    out = {}
    for name, image in images.items():
        title, unit, cmap = MAPS[name]
        limits = (None, None)
        if name == "error_mm":  # the delivered pixels' errors set the scale (not the few a camera drops)
            shown = image[np.isfinite(image) & delivered(arrays["flags"])]
            finite = np.abs(shown if shown.size else image[np.isfinite(image)])
            span = float(np.percentile(finite, 95)) if finite.size else 1.0  # the rest clip at the ends
            limits = (-span, span) if span > 0 else (-1, 1)
        out[name] = (image, title, unit, cmap, limits)
    return out



def frame_figure(arrays: dict[str, np.ndarray], names: tuple[str, ...] = ("radial_m", "error_mm", "depth_std_mm",
                                                                          "amplitude_lsb", "flags")):
    """A frame's colour maps side by side, each with its colour bar (:func:`map_images`: the titles,
    units, colour maps and limits ``tofjax render`` writes): what the explorer's Frame tab shows.
    ``arrays``: :func:`frame_arrays`. A ``matplotlib.figure.Figure``."""
    from matplotlib.figure import Figure

    images = map_images(arrays)
    shown = [n for n in names if n in images]
    rows, cols = np.asarray(arrays["radial_m"]).shape
    fig = Figure(figsize=(3.6 * len(shown), 3.6 * rows / cols + 1.0), layout="constrained")
    axes = fig.subplots(1, len(shown), squeeze=False)
    for ax, name in zip(axes[0], shown, strict=True):
        image, title, unit, cmap, (vmin, vmax) = images[name]
        image = np.asarray(image, dtype=float)
        ax.set_title(title, fontsize=8)
        ax.set_xticks([])
        ax.set_yticks([])
        if cmap == "categorical":
            _show_flags(fig, ax, image.astype(np.int64), fontsize=6)
            continue
        if vmin is None:
            vmin, vmax = color_limits(image)
        im = ax.imshow(np.ma.masked_invalid(image), cmap=cmap, vmin=vmin, vmax=vmax, interpolation="nearest")
        fig.colorbar(im, ax=ax, label=unit, shrink=0.8)
    return fig


def write_maps(directory, arrays: dict[str, np.ndarray]) -> list[Path]:
    """The PNG colour maps of :data:`MAPS` that the arrays allow (:func:`map_images`)."""
    directory = Path(directory)
    return [write_png(directory / f"{name}.png", image, title, unit, cmap, *limits)
            for name, (image, title, unit, cmap, limits) in map_images(arrays).items()]


def distance_error_m(arrays: dict[str, np.ndarray]) -> np.ndarray:
    """Measured minus true radial distance, wrapped to [-d_u/2, d_u/2) (a distance beyond the
    unambiguity range d_u reads d_u short: aliasing, not error); NaN where there is no truth (the
    centre ray meets nothing: a mesh in empty space) or no measurement."""
    du = float(arrays["unambiguity_range_m"])
    with np.errstate(invalid="ignore"):
        diff = arrays["radial_m"] - arrays["radial_true_m"]
        return np.where(np.isfinite(diff), diff - du * np.floor(diff / du + 0.5), np.nan)


def headlines(arrays: dict[str, np.ndarray]) -> dict[str, float]:
    """Frame-level numbers: pixels, the good (delivered) fraction, every flag's fraction of all pixels
    and each diagnostic's fraction of the good ones (``<name>_good_fraction``), median noise, median
    error (good pixels: those the camera delivers, :func:`tofjax._flags.delivered`)."""
    flags = arrays["flags"]
    good = delivered(flags)
    err = distance_error_m(arrays)[good]
    out = {
        "pixels": float(flags.size), "good_fraction": float(np.mean(good)),
        "unambiguity_range_m": float(arrays["unambiguity_range_m"]),
        **{f"{FLAG_KEYS[bit]}_fraction": share for bit, share in flag_fractions(flags).items()},
        **{f"{FLAG_KEYS[bit]}_good_fraction": float(np.mean((flags[good] & bit) != 0)) if good.any() else 0.0
           for bit in FLAGS if bit & DIAGNOSTIC_FLAGS},
        "median_depth_std_mm": float(1e3 * np.nanmedian(arrays["depth_std_m"][good])) if good.any() else float("nan"),
        "median_abs_error_mm": float(1e3 * np.nanmedian(np.abs(err))) if err.size else float("nan"),
    }
    if "predicted_std_m" in arrays and good.any():
        out["median_predicted_std_mm"] = float(1e3 * np.nanmedian(arrays["predicted_std_m"][good]))
        # The two medians are of different pixel sets' noise distributions, so their quotient is not
        # the agreement: the median of the per-pixel ratio is (the render summary reports it).
        measured = arrays["depth_std_m"][good]
        usable = np.isfinite(measured) & (measured > 0)  # a pixel whose frames all agree has no ratio
        ratio = arrays["predicted_std_m"][good][usable] / measured[usable]
        out["median_noise_ratio"] = float(np.nanmedian(ratio)) if np.isfinite(ratio).any() else float("nan")
    return out


def headline_text(numbers: dict, monte_carlo: bool = True) -> str:
    """The frame's headline numbers (:func:`headlines`) in words, of the good pixels (those the camera
    delivers): their share, and the camera's flags that took the others; median noise, the median of
    the per-pixel ratio of analytic to Monte Carlo noise (the agreement; the ratio of the two medians
    is not), median |error|; and the truth's diagnostics among them (mixed, wrapped: delivered,
    biased). ``monte_carlo``: whether the noise is the frames' (else the analytic frame's alone). A frame of which no pixel is
    good (nothing delivered, or every delivered pixel wraps) is one line that says so and why
    (:func:`tofjax._flags.no_good_pixels_line`)."""
    import math

    def num(key, fmt):
        x = numbers.get(key, math.nan)
        return "-" if not math.isfinite(x) else format(x, fmt)

    if not numbers["good_fraction"] > 0 or numbers.get("wrapped_good_fraction", 0.0) >= 1.0:  # one line
        return no_good_pixels_line({bit: numbers[f"{name}_fraction"] for bit, name in FLAG_KEYS.items()},
                                   numbers.get("unambiguity_range_m"))
    flagged = [f"{100 * numbers[f'{FLAG_KEYS[bit]}_fraction']:.1f} % {FLAG_KEYS[bit].replace('_', ' ')}"
               for bit in FLAGS if bit & CAMERA_FLAGS and numbers[f"{FLAG_KEYS[bit]}_fraction"] > 0]
    diagnosed = [f"{100 * numbers[f'{FLAG_KEYS[bit]}_good_fraction']:.1f} % {FLAG_KEYS[bit].replace('_', ' ')}"
                 for bit in FLAGS if bit & DIAGNOSTIC_FLAGS and numbers.get(f"{FLAG_KEYS[bit]}_good_fraction", 0) > 0]
    noise = (f"median depth noise {num('median_depth_std_mm', '.3g')} mm (Monte Carlo), analytic / Monte Carlo "
             f"{num('median_noise_ratio', '.3f')} (median of the per-pixel ratio)" if monte_carlo
             else f"median depth noise {num('median_depth_std_mm', '.3g')} mm (analytic)")
    return (f"good pixels (delivered by the camera) {100 * numbers['good_fraction']:.1f} %"
            + (f" ({', '.join(flagged)})" if flagged else "")
            + f"; of those, {noise}, median |error| {num('median_abs_error_mm', '.3g')} mm"
            + (f"; the truth says of them: {', '.join(diagnosed)}" if diagnosed else ""))


def write_report(directory, arrays: dict[str, np.ndarray], pngs: list[Path], title: str, lines: list[str]) -> Path:
    """``report.html``: the run's description ``lines``, the headline numbers and every PNG embedded
    (:class:`tofjax.report.Summary`)."""
    from .report import Figure, Section, Summary, Table

    numbers = headlines(arrays)
    if not numbers["good_fraction"] > 0:
        lines = [*lines, headline_text(numbers)]
    summary = Summary(title, list(lines), [
        Section("Headline numbers", [Table(("number", "value"), tuple((k, f"{v:.4g}") for k, v in numbers.items()))]),
        Section("Images", [Figure(p.name, p.read_bytes()) for p in pngs]),
    ])
    return write_text(Path(directory) / "report.html", summary.html())


def intrinsics_arrays(intrinsics: dict) -> dict[str, np.ndarray]:
    """frame.npz's arrays of the camera's intrinsics (:func:`tofjax.optics.intrinsics`):
    ``camera_matrix`` ``(3, 3)``, ``dist_coeffs`` ``(5,)`` (OpenCV's k1, k2, p1, p2, k3),
    ``image_size`` ``(width, height)`` and ``intrinsics_convention``."""
    return {"camera_matrix": np.asarray(intrinsics["camera_matrix"], dtype=float),
            "dist_coeffs": np.asarray(intrinsics["dist_coeffs"], dtype=float),
            "image_size": np.array([intrinsics["width"], intrinsics["height"]]),
            "intrinsics_convention": np.array(intrinsics["convention"])}


def write_frame(directory, arrays: dict[str, np.ndarray], title: str, lines: list[str],
                intrinsics: dict | None = None) -> dict:
    """Everything ``tofjax render`` writes into ``directory``: ``frame.npz``, the PNG maps, the
    16-bit ``depth_mm.png`` (Z depth in millimetres) and ``amplitude.png`` (LSB), both 0 where the
    camera does not deliver a pixel, ``points.ply`` (the delivered pixels, with their intensity, grey
    by amplitude),
    ``report.html`` and, given the camera's ``intrinsics`` (:func:`tofjax.optics.intrinsics`),
    ``intrinsics.json`` (and the same numbers in ``frame.npz``, :func:`intrinsics_arrays`).
    Returns ``{"pngs": [...], "points": n}``."""
    directory = Path(directory)
    if intrinsics is not None:
        arrays = {**arrays, **intrinsics_arrays(intrinsics)}
        write_text(directory / "intrinsics.json", json.dumps(intrinsics, indent=2) + "\n")
    write_npz(directory / "frame.npz", arrays)
    pngs = write_maps(directory, arrays)
    keep = delivered(arrays["flags"]) & np.isfinite(arrays["radial_m"])
    for name, (key, scale) in SIXTEEN_BIT.items():
        write_png16(directory / name, sixteen_bit(arrays[key], scale, keep))
    cloud = arrays["radial_m"][keep][:, None] * arrays["direction"][keep]
    write_ply(directory / "points.ply", cloud, arrays["intensity_e"][keep], grey_levels(arrays["amplitude_lsb"][keep]))
    write_report(directory, arrays, pngs, title, lines)
    return {"pngs": pngs, "points": len(cloud)}
