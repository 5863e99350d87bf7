"""The `sarjax demo` and `sarjax check` commands in process (the demo's full run, as the
README writes it, is checked in test_readme.py)."""

import sarjax.cli


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
