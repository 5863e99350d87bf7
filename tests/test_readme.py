"""The README's walkthrough runs as written.

Every fenced ``python`` and ``bash`` block of ``README.md`` is run here, in a fresh
directory, in new processes of this environment (the one ``.ci/run`` builds from the
README's test command on a clean clone):

* the ``python`` blocks, in order, as one script (later blocks use earlier names);
* the ``bash`` blocks as written, except the two set-up commands: the demo's is run from
  its first ``sarjax`` command on (its venv and install are this environment's), and the
  test command is the command running this test;
* the commands the text quotes inline (```sarjax check …```, ```sarjax fit …```), after
  the shell walkthrough whose files they read.

A README edit that breaks a command fails here, not on a user's machine.
"""

from __future__ import annotations

import os
import pathlib
import re
import subprocess
import sys

import pytest

README = pathlib.Path(__file__).resolve().parents[1] / "README.md"
FENCE = re.compile(r"^```(\w+)\n(.*?)^```", re.S | re.M)
INLINE = re.compile(r"`(sarjax (?:check|fit) [^`]+)`")


def _blocks(language):
    return [body for lang, body in FENCE.findall(README.read_text()) if lang == language]


def _run(args, cwd, timeout=600, **kwargs):
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONUNBUFFERED="1")
    done = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout, **kwargs)
    assert done.returncode == 0, f"{args!r} exited {done.returncode}:\n{done.stdout[-3000:]}" \
                                 f"\n{done.stderr[-3000:]}"
    return done


def _shell_commands():
    """The README's bash blocks as they are run here (see the module docstring)."""
    commands = []
    for body in _blocks("bash"):
        if "pytest" in body:  # the test command: this suite
            continue
        if "pip install" in body:  # the demo's set-up: this environment is installed
            body = body[body.index("sarjax "):]
        commands.append(body)
    return commands


def test_the_readme_has_a_walkthrough():
    """The blocks this module runs exist (a README rewrite keeps them testable)."""
    assert len(_blocks("python")) >= 2
    assert any("sarjax simulate" in c for c in _shell_commands())
    assert any(c.startswith("sarjax demo") for c in _shell_commands())
    assert INLINE.findall(README.read_text())


def test_python_blocks_run(tmp_path):
    """The quick start (exact model, ω-k with MoCo, metrics, validity, auto) as one script;
    it must print the metrics and a method name."""
    script = "\n\n".join(_blocks("python"))
    done = _run([sys.executable, "-c", script], tmp_path)
    assert "IRW" in done.stdout or "irw" in done.stdout.lower(), done.stdout[-2000:]


def test_shell_walkthrough_runs(tmp_path):
    """The demo, the TOML walkthrough (simulate, focus, metrics, plot, export) and the
    inline commands, each with exit status 0 and the files it names; the demo's table and
    figures as it promises (the demo runs here only, as written: the embedded default)."""
    for command in _shell_commands():
        done = _run(["bash", "-euo", "pipefail", "-c", command], tmp_path)
        if command.startswith("sarjax demo"):
            _check_demo(done.stdout, tmp_path / "sarjax_demo")
    for name in ("raw.nc", "image.nc", "image.png", "raw.cphd", "image.nitf"):
        assert (tmp_path / name).stat().st_size > 0, name
    for command in INLINE.findall(README.read_text()):
        _run(["bash", "-euo", "pipefail", "-c", command], tmp_path)
    # the fit file keeps what comparing it with the truth needs: the error in the fit's
    # own gauge (means of Δy, Δz removed) is far below the 20 mm deviations
    import xarray as xr

    with xr.open_dataset(tmp_path / "fit.nc", engine="h5netcdf") as fitted:
        attrs = dict(fitted.attrs)
    assert "horizontal mean" in attrs["fit_fixed"]
    for name in ("horizontal", "vertical"):
        assert attrs[f"fit_error_rms_{name}"] < 1e-3, attrs
        assert 0 < attrs[f"fit_std_rms_{name}"] < 1e-3, attrs



def _check_demo(out, folder):
    """The demo prints the metrics of the straight-track and the compensated images and
    writes its five figures; the compensated rows focus (every target's azimuth PSLR below
    −10 dB: without compensation the seed-000 motion defocuses them)."""
    assert "MoCo 1st+2nd" in out and "straight track" in out, out[-2000:]
    for name in ("raw_amplitude.png", "image_moco_db.png", "image_no_moco_db.png",
                 "cuts_5140.png", "motion.png"):
        assert (folder / name).stat().st_size > 10_000, name
    rows = [line for line in out.splitlines() if line.startswith("MoCo 1st+2nd")]
    assert len(rows) == 3, out[-2000:]
    for line in rows:
        assert float(line.split("|")[1].split()[1]) < -10.0, line


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-q"]))
