"""exotune.text.excite: the exact lines of the excite report, every number with its unit."""

from types import SimpleNamespace

from exotune.text.excite import excitation_text


def _e(**kw):
    e = dict(path="ex.csv", sidecar="ex.yaml", samples=20000, sample_rate_hz=1000.0, periods=5, period_s=4.0,
             period_samples=4000, duration_s=20.0, f_lo_hz=0.5, f_hi_hz=40.0, harmonics=list(range(2, 161)),
             selection="every line", seed=None, lines_hz=[0.5, 40.0], resolution_hz=0.25, peak_nm=3.1234567,
             rms_nm=1.2, amplitude_kind="peak", amplitude_nm=3.0, line_amplitude_nm=0.13452, crest_factor=2.60288)
    e.update(kw)
    return SimpleNamespace(**e)


def test_excitation_text():
    assert excitation_text(_e()).splitlines() == [
        "exotune excite — Schroeder-phased multisine: ex.csv (t [s], tau_cmd [N·m]; described in ex.yaml)",
        "  20000 samples at 1000 Hz: 5 periods of 4 s (4000 samples), 20 s",
        "  band 0.5–40 Hz: 159 excited lines (every line), 0.5–40 Hz",
        "  frequency resolution 1/period: 0.25 Hz",
        "  amplitude: peak 3.12346 N·m, RMS 1.2 N·m (peak 3 N·m asked), 0.1345 N·m per line",
        "  crest factor (peak/RMS): 2.603 [–]",
        "  play it as the motor command and log tau_cmd with the measured signals; the first period is the "
        "plant's transient",
    ]


def test_unwritten_and_seeded():
    lines = excitation_text(_e(path=None, selection="random lines", seed=7)).splitlines()
    assert lines[0] == "exotune excite — Schroeder-phased multisine: not written"
    assert lines[2] == "  band 0.5–40 Hz: 159 excited lines (random lines, seed 7), 0.5–40 Hz"


def test_one_period_and_one_line_are_singular():
    """"1 periods" and "1 excited lines, 1.5015–1.5015 Hz" read as plurals and a range."""
    lines = excitation_text(_e(samples=666, periods=1, period_s=0.666, period_samples=666, duration_s=0.666,
                               f_lo_hz=1.5, f_hi_hz=2.5, harmonics=[1], lines_hz=[1.5015015015])).splitlines()
    assert lines[1] == "  666 samples at 1000 Hz: 1 period of 0.666 s (666 samples), 0.666 s"
    assert lines[2] == "  band 1.5–2.5 Hz: 1 excited line (every line), 1.5015 Hz"
