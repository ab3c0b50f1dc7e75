"""The simulation report (tofjax/report.py): files, headline figures."""

import numpy as np
import pytest

import tofjax as tj
from tofjax import plots
from tofjax import sweepfile as sf
from tofjax.cli import main


@pytest.mark.parametrize("sweep", ["distance", "illuminance", "integration_time"])
def test_report_writes_csv_pngs_and_html(tmp_path, capsys, sweep):
    out = tmp_path / sweep
    assert main(["simulate", "--sweep", sweep, "--samples", "30", "--iterations", "100", "--report", str(out)]) == 0
    assert "report:" in capsys.readouterr().out
    assert sf.read_sweep(out / "sweep.csv").n_rows == 30
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") == len(plots.applicable(sweep)) + 3  # + taps, waveforms, FoV
    for name in plots.applicable(sweep):
        assert (out / f"{name}.png").stat().st_size > 1000
    for text in ("Headline figures", "SBI engages at", "relative depth noise reaches 1 %", "Dominant noise source",
                 "[pixel]", "run time", "Frame timing and eye safety", "eye safety (an estimate against IEC"):
        assert text in html
    # Each headline figure says where it comes from: the run's own sweep where it covers the figure.
    assert "<th>from</th>" in html and "at the nominal point</td>" in html
    assert ("this distance sweep (Monte Carlo)" in html) == (sweep == "distance")
    assert ("this illuminance sweep (Monte Carlo)" in html) == (sweep == "illuminance")


def test_headlines_are_physical():
    from tofjax.report import headline_figure, headlines

    r = tj.predict(tj.Params(), tj.Sweep.linspace("distance", 0.5, 4.5, 30))
    h = headlines(tj.Params(), r)
    assert 0.2 < h["valid_from_m"] < 0.5
    assert h["valid_from_m"] < h["relative_noise_1pct_at_m"] < h["relative_noise_2pct_at_m"]
    assert 100 < h["sbi_engages_at_lx"] < 1000 and h["pixel_saturates_at_lx"] is None
    no_sbi = headlines(tj.Params(pixel=tj.Pixel(sbi=False)), r)
    assert no_sbi["pixel_saturates_at_lx"] == pytest.approx(h["sbi_engages_at_lx"], rel=0.05)
    sources = [region["source"] for region in h["dominant_noise"]]
    assert sources == ["photon shot noise", "read noise"]  # shot noise near, read noise far
    # The distance figures of a distance sweep are its own (they had come from a hidden scan over
    # 0.05-50 m and contradicted the sweep's table): its first sample at or above 1 %, 2 % beyond
    # it, valid from its first sample on; an illuminance figure is the scan's, and says so.
    short = tj.predict(tj.Params(), tj.Sweep.linspace("distance", 0.5, 2.5, 30))
    hs = headlines(tj.Params(), short)
    d = np.asarray(short.distance_m)
    rel = np.asarray(short.depth_std_m) / d
    i = int(np.argmax(rel >= 0.01))
    assert hs["from_sweep"]["relative_noise_1pct_at_m"] == (d[i], "at") and 0 < i and rel[:i].max() < 0.01
    assert hs["from_sweep"]["relative_noise_2pct_at_m"] == (None, "beyond") and rel.max() < 0.02
    value, source = headline_figure(hs, "relative_noise_2pct_at_m", "m")
    assert value == "beyond the sweep (0.5-2.5 m)"
    assert source.endswith(f"puts it at {hs['relative_noise_2pct_at_m']:.4g} m")
    assert hs["from_sweep"]["valid_from_m"] == (0.5, "start")
    assert headline_figure(hs, "valid_from_m", "m")[0] == "at or below 0.5 m"
    assert headline_figure(hs, "sbi_engages_at_lx", "lx")[1].startswith("analytic scan over 0-200 klx")


def test_one_summary_renders_as_text_markdown_and_html_with_every_text_escaped():
    from tofjax.report import Code, Figure, Section, Summary, Table

    odd = "<b>|x|[l](u)*`.csv"
    summary = Summary("title <i>", [f"line {odd}"], [
        Section("S", ["para & more", [odd, "two"], Table(("file", "n"), ((odd, "1"), ("b", "2")), (True, False)),
                      Figure("f.png", b"\x89PNG fake", "cap"), Code("[a]\nb = 1")]),
    ])
    text = summary.text()
    assert text.splitlines()[0] == f"line {odd}" and f"- {odd}" in text and "[figure f.png: cap]" in text
    assert "    [a]" in text and any(line.strip().startswith(odd) for line in text.splitlines())
    md = summary.markdown()
    assert "<b>" not in md and "&lt;b&gt;\\|x\\|\\[l\\](u)\\*\\`.csv" in md and "![cap](f.png)" in md
    assert "| file | n |\n|---|---|\n" in md and "```\n[a]\nb = 1\n```" in md
    page = summary.html()
    assert "<b>" not in page and "<i>" not in page and "&lt;b&gt;|x|[l](u)*`.csv" in page
    assert page.count("<tr class='muted'>") == 1 and "data:image/png;base64,iVBORyBmYWtl" in page  # b64 of the bytes
    assert summary.html_fragment() == "line &lt;b&gt;|x|[l](u)*`.csv"
