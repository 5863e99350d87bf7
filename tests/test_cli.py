"""The ``sarjax`` command line: help everywhere, simulate → focus → metrics from a shell
giving the Python API's numbers, configs with overrides, safe writes, one-line errors."""

import json
import subprocess
import sys

import jax
import numpy as np
import pytest

import sarjax as sj
import sarjax.cli
from sarjax import io

try:
    from _reruns import assert_same_to_rounding
except ImportError:
    from tests._reruns import assert_same_to_rounding

CONFIG = """
preset = "airborne"
[radar]
num_pulses = 257
[scene]
azimuth = [0.0, 5.0]
range = [5100.0, 5200.0]
reflectivity = [1.0, 0.5]
reflectivity_phase = [0.0, 1.0]
[motion]
deviation_rms = 0.01
max_cycles = 1.0
seed = 7
jitter = 0.05
[simulate]
method = "time_domain"
"""

COMMANDS = ("demo", "simulate", "focus", "metrics", "fit", "check", "config", "export",
            "plot", "launch", "autofocus")


def _shell(*args, cwd):
    """Run ``python -m sarjax.cli ARGS`` as a separate process (a shell user's view)."""
    return subprocess.run([sys.executable, "-m", "sarjax.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("command", (None, *COMMANDS))
def test_help_on_every_command(command, capsys):
    args = ["--help"] if command is None else [command, "--help"]
    assert sarjax.cli.main(args) == 0
    out = capsys.readouterr().out
    assert out.startswith("Usage: sarjax")
    if command is None:
        for name in COMMANDS:
            assert name in out


def test_shell_simulate_focus_metrics_match_the_python_api(tmp_path):
    (tmp_path / "run.toml").write_text(CONFIG)
    for args in (["simulate", "run.toml", "-o", "raw.nc"],
                 ["focus", "raw.nc", "-o", "image.nc"]):
        done = _shell(*args, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
    done = _shell("metrics", "image.nc", "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    shell = json.loads(done.stdout)

    # the same run through the Python API
    radar = sj.presets.airborne_xband(num_pulses=257)
    scene = sj.PointTargets(azimuth=[0.0, 5.0], range=[5100.0, 5200.0],
                            reflectivity=[1.0, 0.5 * np.exp(1j)])
    x = (np.arange(257) - 128) * float(radar.azimuth_spacing)
    footprint = float(radar.footprint(radar.reference_range))
    motion = sj.Motion(
        horizontal=sj.smooth_deviation(x, key=7, rms=0.01, max_cycles=1.0, aperture=footprint),
        vertical=sj.smooth_deviation(x, key=8, rms=0.01, max_cycles=1.0, aperture=footprint),
        pointing=sj.seed_pointing_jitter(radar, x, amplitude_fraction=0.05))
    raw = sj.simulate(radar, scene, motion)
    image = sj.focus(radar, raw, motion=motion)
    stored = io.load(tmp_path / "raw.nc")
    np.testing.assert_array_equal(np.asarray(stored.product.data), np.asarray(raw.data))
    assert len(shell) == 2
    for row, (xt, rt) in zip(shell, [(0.0, 5100.0), (5.0, 5200.0)], strict=True):
        m = sj.point_target_metrics(image, azimuth=xt, range=rt, half_window=64)
        for key in ("irw_azimuth", "irw_range", "pslr_azimuth", "pslr_range",
                    "islr_azimuth", "islr_range", "peak_azimuth", "peak_range", "peak_db"):
            assert row[key] == pytest.approx(getattr(m, key), rel=1e-9, abs=1e-9), key


def test_config_overrides_presets_and_reproducible_file(tmp_path, capsys):
    (tmp_path / "run.toml").write_text(CONFIG)
    out = tmp_path / "raw.nc"
    code = sarjax.cli.main(["simulate", str(tmp_path / "run.toml"), "-o", str(out),
                            "--set", "radar.num_pulses=129", "--set", "simulate.method='auto'",
                            "--set", "motion.jitter=0"])
    assert code == 0, capsys.readouterr().err
    run = io.load(out)
    assert run.product.shape == (129, 830) and run.radar.num_pulses == 129
    assert run.motion.pointing is None and run.motion.horizontal is not None
    assert run.attrs["simulate_method"] == run.product.method != "auto"
    assert run.product.method_reason.startswith("cheapest valid by the cost models: "
                                                f"{run.product.method} ")
    again = run.simulate()  # one file reproduces its run (to the FFT's rerun rounding)
    assert_same_to_rounding(again.data, run.product.data)


def test_bad_input_gives_one_line_and_status_2(tmp_path, capsys):
    (tmp_path / "run.toml").write_text(CONFIG)
    (tmp_path / "bad.toml").write_text(CONFIG + "\n[wobble]\nx = 1\n")
    cases = [
        (["simulate", str(tmp_path / "missing.toml"), "-o", str(tmp_path / "a.nc")],
         "does not exist"),
        (["simulate", str(tmp_path / "bad.toml"), "-o", str(tmp_path / "a.nc")], "wobble"),
        (["simulate", str(tmp_path / "run.toml"), "-o", str(tmp_path / "a.nc"),
          "--set", "radar.prf=-1"], "prf"),
        (["simulate", str(tmp_path / "run.toml"), "-o", str(tmp_path / "a.nc"),
          "--set", "radar.wobble=1"], "wobble"),
        (["focus", str(tmp_path / "run.toml"), "-o", str(tmp_path / "b.nc")], "cannot read"),
        (["export", str(tmp_path / "x.nc"), "-o", "y", "--format", "sidd"], "sidd"),
        (["frobnicate"], "frobnicate"),
    ]
    for args, needle in cases:
        assert sarjax.cli.main(args) == 2, args
        err = capsys.readouterr().err
        assert err.startswith("sarjax: error:") and err.count("\n") == 1, err
        assert needle in err, (needle, err)
    assert not (tmp_path / "a.nc").exists()


def test_no_overwrite_without_force(tmp_path, capsys):
    (tmp_path / "run.toml").write_text(CONFIG)
    out = tmp_path / "raw.nc"
    args = ["simulate", str(tmp_path / "run.toml"), "-o", str(out), "--set",
            "radar.num_pulses=65"]
    assert sarjax.cli.main(args) == 0
    log = capsys.readouterr().err  # not a terminal: progress as log lines, no bar
    assert "sarjax: simulate: step 2/2 done after" in log and "\r" not in log, log
    before = out.stat().st_mtime_ns
    assert sarjax.cli.main(args) == 2
    assert "exists" in capsys.readouterr().err
    assert out.stat().st_mtime_ns == before
    assert sarjax.cli.main([*args, "--force"]) == 0
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no debris


def test_export_and_plot_commands(tmp_path, capsys):
    import sarkit.cphd as skcphd

    (tmp_path / "run.toml").write_text(CONFIG)
    raw, cphd, png = tmp_path / "raw.nc", tmp_path / "raw.cphd", tmp_path / "raw.png"
    assert sarjax.cli.main(["simulate", str(tmp_path / "run.toml"), "-o", str(raw)]) == 0
    assert sarjax.cli.main(["export", str(raw), "-o", str(cphd), "--format", "cphd",
                            "--track", "nominal"]) == 0
    with open(cphd, "rb") as f, skcphd.Reader(f) as reader:
        signal, pvp = reader.read_channel("1")
    assert signal.shape[0] == 257 and np.all(np.isfinite(pvp["TxPos"]))
    crsd = tmp_path / "raw.crsd"
    assert sarjax.cli.main(["export", str(raw), "-o", str(crsd), "--format", "crsd",
                            "--side", "L", "--heading", "30"]) == 0
    assert crsd.stat().st_size > 257 * 830 * 8  # the raw samples, complex64
    assert sarjax.cli.main(["plot", str(raw), "-o", str(png)]) == 0
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"


def test_fit_reports_when_unavailable(tmp_path, capsys, monkeypatch):
    (tmp_path / "run.toml").write_text(CONFIG)
    raw = tmp_path / "raw.nc"
    assert sarjax.cli.main(["simulate", str(tmp_path / "run.toml"), "-o", str(raw),
                            "--set", "radar.num_pulses=65"]) == 0
    monkeypatch.setitem(sys.modules, "sarjax.inverse", None)  # as if not installed
    assert sarjax.cli.main(["fit", str(raw), "-o", str(tmp_path / "fit.nc")]) == 2
    assert "not available" in capsys.readouterr().err


def test_version_and_lazy_modules(capsys):
    """``sarjax --version`` and ``sarjax.__version__`` name the installed version; the
    optional-dependency modules are attributes of the package (imported on first use)."""
    from importlib.metadata import version

    assert sarjax.cli.main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"sarjax {version('sarjax')}"
    assert sj.__version__ == version("sarjax")
    assert sj.io.save is io.save and callable(sj.plot.image_db) and callable(sj.export.to_cphd)
    assert {"io", "plot", "export", "focus", "fit_motion", "MotionModel"} <= set(dir(sj))
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        sj.nonexistent  # noqa: B018


def test_the_command_keeps_freed_memory(monkeypatch, capsys):
    """Run as the command (arguments from the command line), ``main`` sets the allocator
    to keep freed memory (``sarjax._allocator``); called from Python with its arguments it
    leaves the process's allocator alone. ``retain_freed_memory`` passes glibc the three
    settings and reports whether all were taken (a fake ``mallopt``: the test process's
    own allocator is not changed)."""
    from sarjax import _allocator

    calls = []
    monkeypatch.setattr(_allocator, "retain_freed_memory", lambda: calls.append(1) or True)
    assert sarjax.cli.main(["--version"]) == 0
    assert calls == []
    monkeypatch.setattr(sys, "argv", ["sarjax", "--version"])
    assert sarjax.cli.main() == 0
    assert calls == [1]
    capsys.readouterr()
    monkeypatch.undo()

    taken = []
    monkeypatch.setattr(_allocator, "_backend_started", lambda: False)
    monkeypatch.setattr(_allocator, "_libc", lambda: lambda p, v: taken.append((p, v)) or 1)
    assert sj.retain_freed_memory() is True
    assert taken == [(_allocator.M_MMAP_MAX, 0), (_allocator.M_TRIM_THRESHOLD, 2**31 - 1),
                     (_allocator.M_ARENA_MAX, 1)]
    monkeypatch.setattr(_allocator, "_libc", lambda: lambda p, v: 0)
    assert sj.retain_freed_memory() is False
    monkeypatch.setattr(_allocator, "_libc", lambda: None)
    assert sj.retain_freed_memory() is False


def test_freed_memory_is_kept_only_when_set_before_jax_starts(monkeypatch):
    """``retain_freed_memory`` after JAX's backend started changes nothing (XLA's threads
    keep the allocator arenas they took when it started): it warns, naming what to do
    instead, and returns False without calling ``mallopt``. In a fresh process, right
    after ``import sarjax``, it takes the settings (glibc) and ``sarjax`` has not started
    the backend by then."""
    from sarjax import _allocator

    taken = []
    monkeypatch.setattr(_allocator, "_libc", lambda: lambda p, v: taken.append((p, v)) or 1)
    jax.numpy.ones(3).block_until_ready()  # the backend has started
    assert _allocator._backend_started()
    with pytest.warns(sj.FreedMemoryWarning, match="before the first JAX computation") as w:
        assert sj.retain_freed_memory() is False
    assert taken == []
    assert "GLIBC_TUNABLES=glibc.malloc.arena_max=1" in str(w[0].message)
    assert w[0].filename == __file__  # attributed to the caller's line
    code = ("import warnings; warnings.simplefilter('error'); import sarjax as sj, "
            "sarjax._allocator as a, platform; "
            "assert not a._backend_started(); ok = sj.retain_freed_memory(); "
            "glibc = platform.libc_ver()[0] == 'glibc'; assert ok is glibc, (ok, glibc)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]


def test_config_example_check_and_did_you_mean(tmp_path, capsys):
    """``config --example`` prints a configuration that builds a run and names every key
    the reader accepts; ``check CONFIG`` reports that run's budgets; a misspelt key is
    answered with the closest valid one and the list."""
    from sarjax.cli import config

    assert sarjax.cli.main(["config", "--example"]) == 0
    example = capsys.readouterr().out
    assert example == config.EXAMPLE
    for key in (*config.SCENE_KEYS, *config.MOTION_KEYS, *config.ACQUISITION_KEYS):
        assert f"{key} =" in example, key
    (tmp_path / "run.toml").write_text(example)
    assert sarjax.cli.main(["check", str(tmp_path / "run.toml"),
                            "--set", "radar.num_pulses=129"]) == 0
    report = capsys.readouterr().out
    assert "method='auto' would choose:" in report and "chirp_edges" in report
    for args, hint in ((["--set", "scene.azimth=1"], "did you mean 'azimuth'?"),
                       (["--set", "motion.jiter=1"], "did you mean 'jitter'?"),
                       (["--set", "radar.nmu_pulses=3"], "did you mean 'num_pulses'?"),
                       (["--set", "simulte.method=auto"], "did you mean 'simulate'?")):
        assert sarjax.cli.main(["check", str(tmp_path / "run.toml"), *args]) == 2
        err = capsys.readouterr().err
        assert hint in err and "known:" in err, err
    # a misspelt required key is answered with its correction, not as a missing one
    (tmp_path / "typo.toml").write_text(example.replace("\nazimuth =", "\nazimth ="))
    assert sarjax.cli.main(["check", str(tmp_path / "typo.toml")]) == 2
    assert "did you mean 'azimuth'?" in capsys.readouterr().err


def test_demo_keeps_earlier_figures_without_force(tmp_path, capsys):
    """An earlier demo's figure in the output folder is not replaced without --force."""
    (tmp_path / "motion.png").write_bytes(b"earlier")
    assert sarjax.cli.main(["demo", "-o", str(tmp_path), "--pulses", "65"]) == 2
    assert "--force" in capsys.readouterr().err
    assert (tmp_path / "motion.png").read_bytes() == b"earlier"


def test_plot_zoom_is_square_around_the_targets(tmp_path, capsys, monkeypatch):
    """``plot --zoom``: by default a window square in metres around the file's targets
    (CONFIG: x 0 … 5 m, r 5100 … 5200 m: 50 + 40 m on each side of their centre), target
    K alone (40 m on each side), a window
    in metres, or the whole image; a window outside the image is refused."""
    from sarjax import plot as plot_

    (tmp_path / "run.toml").write_text(CONFIG)
    raw, image = tmp_path / "raw.nc", tmp_path / "image.nc"
    assert sarjax.cli.main(["simulate", str(tmp_path / "run.toml"), "-o", str(raw),
                            "--set", "motion.deviation_rms=0", "--set", "motion.jitter=0"]) == 0
    assert sarjax.cli.main(["focus", str(raw), "-o", str(image)]) == 0
    windows = []
    original = plot_.image_db
    monkeypatch.setattr(plot_, "image_db", lambda img, **kw: (
        windows.append((kw["zoom"], kw["aspect"])), original(img, **kw))[1])
    for k, zoom in enumerate(["targets", "1", "-10,10,5150,5170", "full"]):
        assert sarjax.cli.main(["plot", str(image), "-o", str(tmp_path / f"{k}.png"),
                                "--zoom", zoom]) == 0, capsys.readouterr().err
    (targets, aspect), (one, _), (given, _), full = windows
    assert targets[1] == pytest.approx((5060.0, 5240.0)) and aspect == "equal"
    assert targets[0] == pytest.approx((-32.0, 32.0))  # ±90 m clipped to the 257 pulses
    assert one[0] == pytest.approx((-32.0, 32.0)) and one[1] == pytest.approx((5160.0, 5240.0))
    assert given == ((-10.0, 10.0), (5150.0, 5170.0))
    assert full == (None, "auto")
    assert sarjax.cli.main(["plot", str(image), "-o", str(tmp_path / "x.png"),
                            "--zoom", "7"]) == 2
    assert "targets 0 … 1" in capsys.readouterr().err
