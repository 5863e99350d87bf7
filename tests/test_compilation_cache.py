"""The command's persistent compilation cache: on by default in its own folder, off with
``SARJAX_CACHE_DIR=off``, and a folder JAX was given already is kept. (Its speed-up is
measured in ``benchmarks/bench_cli_cache.py``, not asserted here.)"""

from __future__ import annotations

import os
import subprocess
import sys

import jax

import sarjax as sj

CONFIG = """\
preset = "airborne"
[radar]
num_pulses = 65
num_range = 64
near_range = 5044.07
[scene]
azimuth = [0.0]
range = [5140.0]
[simulate]
method = "fourier_2d"
"""


def _simulate(tmp_path, cache, name):
    env = {k: v for k, v in os.environ.items() if not k.startswith("JAX_COMPILATION_CACHE")}
    env["SARJAX_CACHE_DIR"] = cache
    (tmp_path / "run.toml").write_text(CONFIG)
    done = subprocess.run([sys.executable, "-m", "sarjax.cli", "simulate",
                           str(tmp_path / "run.toml"), "-o", str(tmp_path / name)],
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return done


def test_the_command_keeps_its_programs_unless_turned_off(tmp_path):
    cache = tmp_path / "cache"
    _simulate(tmp_path, str(cache), "a.nc")
    first = {name: (cache / name).stat().st_mtime_ns for name in os.listdir(cache)}
    assert any(name.startswith("jit__run-") for name in first), first  # the engine's body
    # a second run loads them: each entry is kept as written, and no program of the first
    # run is compiled again under another key (a program whose compile time sits near
    # the 0.1 s threshold may be added now: that is timing, not a miss)
    _simulate(tmp_path, str(cache), "b.nc")
    second = {name: (cache / name).stat().st_mtime_ns for name in os.listdir(cache)}
    assert {name: second.get(name) for name in first} == first
    programs = {name.rsplit("-", 2)[0] for name in first}
    assert not [name for name in set(second) - set(first)
                if name.rsplit("-", 2)[0] in programs]
    _simulate(tmp_path, "off", "c.nc")
    assert not (tmp_path / "off").exists()


def test_the_api_opt_in_keeps_a_folder_already_chosen(tmp_path):
    # the suite runs with JAX_COMPILATION_CACHE_DIR set (tests/conftest.py)
    chosen = jax.config.jax_compilation_cache_dir
    assert chosen
    assert str(sj.enable_compilation_cache(tmp_path / "elsewhere")) == chosen
    assert not (tmp_path / "elsewhere").exists()


def test_a_folder_that_cannot_be_made_is_named(tmp_path):
    """(In a fresh process: this one's cache folder is set for the suite.)"""
    blocker = tmp_path / "file"
    blocker.write_text("")
    env = {k: v for k, v in os.environ.items() if not k.startswith("JAX_COMPILATION_CACHE")}
    code = ("import sarjax as sj\n"
            "try:\n"
            f"    sj.enable_compilation_cache({str(blocker / 'cache')!r})\n"
            "except ValueError as err:\n"
            "    print(err)\n")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=120)
    assert "cannot be created" in done.stdout and "SARJAX_CACHE_DIR" in done.stdout, done
