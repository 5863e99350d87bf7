"""The `sarjax demo` command (reduced pulse count to keep CI fast)."""

import sarjax.cli


def test_demo_runs_and_writes_figures(tmp_path, capsys):
    code = sarjax.cli.main(["demo", "-o", str(tmp_path), "--pulses", "1025"])
    assert code == 0
    out = capsys.readouterr().out
    assert "MoCo 1st+2nd" in out and "straight track" in out
    for name in ("raw_amplitude.png", "image_moco_db.png", "image_no_moco_db.png",
                 "cuts_5140.png", "motion.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    # the compensated rows focus: every target's azimuth PSLR below −10 dB
    rows = [line for line in out.splitlines() if line.startswith("MoCo 1st+2nd")]
    assert len(rows) == 3
    for line in rows:
        pslr_azimuth = float(line.split("|")[1].split()[1])
        assert pslr_azimuth < -10.0


def test_cli_reports_bad_input_in_one_line(capsys):
    code = sarjax.cli.main(["demo", "--pulses", "0", "-o", "/tmp/sarjax_demo_bad"])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("sarjax: error:") and "num_pulses" in err


def test_check_command_prints_budgets(capsys):
    assert sarjax.cli.main(["check", "--deviation", "0.001"]) == 0
    out = capsys.readouterr().out
    for name in ("epsilon_11", "epsilon_12", "epsilon_13", "epsilon_az"):
        assert name in out
    # 1 mm: small_deviation is valid; for three point targets the exact model is the
    # cheapest valid method (no FFT program to compile), and auto says so
    assert "method small_deviation: VALID" in out
    assert "would choose: time_domain" in out
    assert sarjax.cli.main(["check", "--deviation", "5", "--cycles", "2"]) == 0
    out = capsys.readouterr().out
    assert "method small_deviation: NOT VALID" in out and "would choose: time_domain" in out
