"""The simulation report (tofjax/report.py): files, headline figures."""

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
                 "[pixel]", "run time"):
        assert text in html


def test_headlines_are_physical():
    from tofjax.report import headlines

    r = tj.predict(tj.Params(), tj.Sweep.linspace("distance", 0.5, 4.5, 30))
    h = headlines(tj.Params(), r)
    assert 0.2 < h["valid_from_m"] < 0.5
    assert h["valid_from_m"] < h["relative_noise_1pct_at_m"] < h["relative_noise_2pct_at_m"]
    assert 100 < h["sbi_engages_at_lx"] < 1000 and h["pixel_saturates_at_lx"] is None
    no_sbi = headlines(tj.Params(pixel=tj.Pixel(sbi=False)), r)
    assert no_sbi["pixel_saturates_at_lx"] == pytest.approx(h["sbi_engages_at_lx"], rel=0.05)
    sources = [region["source"] for region in h["dominant_noise"]]
    assert sources == ["photon shot noise", "read noise"]  # shot noise near, read noise far
