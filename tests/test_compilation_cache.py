"""The command's persistent compilation cache: on by default in its own folder, off with
``SARJAX_CACHE_DIR=off``, and a folder JAX was given already is kept; the serialised
simulation programs (``sarjax._exported``) give the uncached result bit for bit, ignore a
damaged entry and survive two processes writing one entry at once; XLA's own entries
appear whole. (Its speed-up is measured in ``benchmarks/bench_cli_cache.py``, not
asserted here.)"""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import threading

import jax
import numpy as np
import pytest

import sarjax as sj
from sarjax import _exported
from sarjax._simulate import _run as _simulation_program

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


def _xla_file_cache(path):
    """The file cache jax opens for XLA's entries in ``path`` (sarjax imported)."""
    from jax._src import compilation_cache

    cache, _ = compilation_cache.get_file_cache(str(path))
    return getattr(cache, "_base_cache", cache)  # under jax's content check, its cache


def test_xla_entries_are_written_under_another_name_and_renamed(tmp_path, monkeypatch):
    """jax 0.10 writes an entry of its file cache in place: a process reading it while
    another was still writing found it truncated, warned and compiled the program itself
    (a clean-clone run of this suite failed its collection on that warning). The cache
    jax opens once sarjax is imported writes each entry to a temporary name: the entry's
    own name never holds part of it, nothing is left behind, and an entry is never
    replaced."""
    cache = _xla_file_cache(tmp_path)
    assert getattr(type(cache), "writes_whole_entries", False), type(cache)
    key, value = "jit_f-0123", os.urandom(1 << 20)
    entry = tmp_path / f"{key}-cache"
    writes, write_bytes = [], pathlib.Path.write_bytes

    def watched(self, data):
        writes.append((self.name, entry.exists()))
        return write_bytes(self, data)

    monkeypatch.setattr(pathlib.Path, "write_bytes", watched)
    cache.put(key, value)
    assert writes and all(name != entry.name and not there for name, there in writes), writes
    assert entry.read_bytes() == value
    assert [p.name for p in tmp_path.iterdir()] == [entry.name]
    cache.put(key, b"another program")
    assert cache.get(key) == value


def test_a_reader_never_finds_part_of_an_xla_entry(tmp_path):
    """A thread reads every entry over and over while another writes them (8 of 4 MiB):
    each read finds an entry whole or not at all. (jax's own writer, in place, gave
    reads of part of an entry here.)"""
    cache = _xla_file_cache(tmp_path)
    values = {f"jit_g-{i}": os.urandom(4 << 20) for i in range(8)}
    done, partial = threading.Event(), []

    def read():
        while not done.is_set():
            for key, value in values.items():
                found = cache.get(key)
                if found is not None and found != value:
                    partial.append((key, len(found)))

    reader = threading.Thread(target=read)
    reader.start()
    try:
        for key, value in values.items():
            cache.put(key, value)
    finally:
        done.set()
        reader.join()
    assert not partial, partial[:5]
    assert all(cache.get(key) == value for key, value in values.items())


def test_the_command_keeps_its_programs_unless_turned_off(tmp_path):
    cache = tmp_path / "cache"
    _simulate(tmp_path, str(cache), "a.nc")
    first = {name: (cache / name).stat().st_mtime_ns for name in os.listdir(cache)}
    assert any(name.startswith("jit__run-") for name in first), first  # the engine's body
    programs_first = sorted(p.name for p in (cache / "programs").iterdir())
    assert [name for name in programs_first if name.startswith("run-")], programs_first
    # a second run loads them: each entry is kept as written, and no program of the first
    # run is compiled again under another key (a program whose compile time sits near
    # the 0.1 s threshold may be added now: that is timing, not a miss)
    _simulate(tmp_path, str(cache), "b.nc")
    second = {name: (cache / name).stat().st_mtime_ns for name in os.listdir(cache)}
    assert {name: second.get(name) for name in first} == first
    programs = {name.rsplit("-", 2)[0] for name in first}
    assert not [name for name in set(second) - set(first)
                if name.rsplit("-", 2)[0] in programs]
    # and the simulation program was loaded, not traced and written again
    assert sorted(p.name for p in (cache / "programs").iterdir()) == programs_first
    _simulate(tmp_path, "off", "c.nc")
    assert not (tmp_path / "off").exists()


def test_the_api_opt_in_keeps_a_folder_already_chosen(tmp_path):
    # the suite runs with JAX_COMPILATION_CACHE_DIR set (tests/conftest.py)
    chosen = jax.config.jax_compilation_cache_dir
    assert chosen
    kept = _exported.folder()
    try:
        assert str(sj.enable_compilation_cache(tmp_path / "elsewhere")) == chosen
    finally:  # the opt-in also turns the programs on: not for the tests after this one
        _exported.set_folder(kept)
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


# ---- the serialised simulation programs -----------------------------------------------

NUM_PULSES, NUM_RANGE, NEAR_RANGE = 65, 64, 5044.07


def _run_small(method="time_domain", radar=None, num_range=NUM_RANGE):
    radar = sj.presets.airborne_xband() if radar is None else radar
    scene = sj.PointTargets(azimuth=[0.0], range=[5140.0])
    motion = sj.Motion(horizontal=1e-5 * np.sin(np.linspace(0.0, 3.0, NUM_PULSES)))
    return sj.simulate(radar, scene, motion, method=method, num_pulses=NUM_PULSES,
                       num_range=num_range, near_range=NEAR_RANGE)


def _same(a, b):
    """Bit for bit: every array of the result, and its method."""
    assert a.method == b.method
    for name in ("data", "azimuth", "range"):
        x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
        assert x.dtype == y.dtype and x.shape == y.shape
        assert np.array_equal(x.view(np.uint8), y.view(np.uint8)), name


@pytest.fixture
def programs(tmp_path, monkeypatch):
    """A fresh programs folder for this process (the state before is restored after),
    and the keys of the simulation programs written to it (the checks' eager antenna
    programs are kept too: they are counted apart)."""
    kept = _exported.folder()
    folder = _exported.set_folder(tmp_path / "programs")
    writes, others = [], []
    store = _exported._store

    def counted(fn, key, entry):
        (writes if fn.__name__ == "_run" else others).append(key)
        store(fn, key, entry)

    monkeypatch.setattr(_exported, "_store", counted)
    yield folder, writes
    _exported.set_folder(kept)


def _uncached(**kwargs):
    kept = _exported.folder()
    _exported.set_folder(None)
    try:
        return _run_small(**kwargs)
    finally:
        _exported.set_folder(kept)


def _fresh_process_call(**kwargs):
    """A call as a new process makes it: nothing loaded in memory yet, and the key's
    environment (the sarjax source) read afresh."""
    _exported._loaded.clear()
    _exported._environment.cache_clear()
    return _run_small(**kwargs)


@pytest.mark.parametrize("method", ["fourier_2d", "time_domain"])
def test_a_loaded_program_gives_the_uncached_result_bit_for_bit(programs, method):
    folder, writes = programs
    plain = _uncached(method=method)
    compiled = _run_small(method=method)  # traced, compiled and written
    assert len(writes) == 1 and len(list(folder.glob("run-*"))) == 1
    loaded = _fresh_process_call(method=method)  # read from the file
    assert len(writes) == 1
    _same(plain, compiled)
    _same(plain, loaded)


def test_other_values_reuse_a_program_other_shapes_do_not(programs):
    folder, writes = programs
    _run_small()
    radar = sj.presets.airborne_xband()
    other = type(radar)(**{**{f: getattr(radar, f) for f in radar.__dataclass_fields__},
                           "carrier_frequency": 9.3e9})
    _same(_uncached(radar=other), _fresh_process_call(radar=other))
    assert len(writes) == 1  # the same program, run on other values
    _run_small(num_range=NUM_RANGE + 2)
    assert len(writes) == 2 and len(set(writes)) == 2  # another shape: another program


def test_the_budget_checks_programs_are_kept_too(programs):
    """The eager antenna programs of the checks (traced for 0.1-0.3 s each otherwise)."""
    from sarjax import antenna

    folder, _ = programs
    pattern, u = sj.presets.airborne_xband().pattern, np.linspace(-1.5, 1.5, 101)

    def values():
        return [np.asarray(antenna.evaluate(pattern, u)),
                np.asarray(antenna.derivative_peak(pattern, 2, u))]

    kept = _exported.folder()
    _exported.set_folder(None)
    plain = values()
    _exported.set_folder(kept)
    compiled = values()
    entries = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    assert sorted(name.split("-")[0] for name in entries) == ["derivative_peak", "evaluate"]
    _exported._loaded.clear()
    loaded = values()
    assert {p.name: p.stat().st_mtime_ns for p in folder.iterdir()} == entries  # read
    for a, b, c in zip(plain, compiled, loaded, strict=True):
        assert np.array_equal(a, b) and np.array_equal(a, c)


def test_a_traced_call_takes_the_jit_path(programs):
    """Inside a transformation (a fit's gradient, a user's jit) nothing is kept or loaded."""
    folder, writes = programs
    radar = sj.presets.airborne_xband()
    traced = jax.jit(lambda r: _run_small(radar=r).data)(radar)
    assert not writes and not folder.exists()
    # the same program under an outer jit: equal up to XLA's fusion choices (rounding)
    expected = np.asarray(_uncached(radar=radar).data)
    np.testing.assert_allclose(traced, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def test_a_damaged_entry_is_ignored_and_written_anew(programs):
    folder, writes = programs
    plain = _run_small()
    (entry,) = folder.glob("run-*")
    blob = entry.read_bytes()
    key = entry.stem.split("-", 1)[1]
    damaged = {
        "truncated": blob[: len(blob) // 2],
        "one bit of the executable": blob[:-4000] + bytes([blob[-4000] ^ 1]) + blob[-3999:],
        "another key's entry": blob.replace(key.encode(), b"0" * len(key), 1),
        "not an entry": b"\x00not a program\n" * 100,
        "empty": b"",
    }
    for name, content in damaged.items():
        entry.write_bytes(content)
        assert _exported._load(_simulation_program, key, 0) is None, name
    _same(plain, _fresh_process_call())  # compiled again: the same result
    assert len(writes) == 2  # and written anew,
    _same(plain, _fresh_process_call())
    assert len(writes) == 2  # whole: the next process loads it


def test_two_processes_writing_one_entry_leave_a_valid_one(programs, tmp_path):
    """Both compile the same call and write its entry at about the same time."""
    folder, writes = programs
    env = {k: v for k, v in os.environ.items() if not k.startswith("JAX_COMPILATION_CACHE")}
    env["SARJAX_CACHE_DIR"] = str(tmp_path)
    code = ("import sys, warnings\n"
            "import numpy as np\n"
            "import jax\n"
            "import sarjax as sj\n"
            "jax.config.update('jax_numpy_rank_promotion', 'raise')  # as tests/conftest.py\n"
            "sys.path.insert(0, sys.argv[2])\n"
            "from test_compilation_cache import _run_small\n"
            "sj.enable_compilation_cache()\n"
            "np.save(sys.argv[1], np.asarray(_run_small().data))\n")
    here = os.path.dirname(os.path.abspath(__file__))
    children = [subprocess.Popen([sys.executable, "-c", code, str(tmp_path / f"{i}.npy"), here],
                                 env=env, stderr=subprocess.PIPE, text=True)
                for i in range(2)]
    for child in children:
        _, err = child.communicate(timeout=300)
        assert child.returncode == 0, err[-2000:]
    entries = list(folder.iterdir())
    assert all(p.suffix == ".bin" for p in entries), entries  # no temporary left
    assert len(list(folder.glob("run-*"))) == 1
    loaded = _fresh_process_call()
    assert not writes  # this process loaded the entry the two left
    for i in range(2):
        assert np.array_equal(np.load(tmp_path / f"{i}.npy"), np.asarray(loaded.data))


def test_the_programs_are_off_with_the_cache(monkeypatch):
    kept = _exported.folder()
    monkeypatch.setenv("SARJAX_CACHE_DIR", "off")
    try:
        sj.enable_compilation_cache()  # XLA's folder of the suite stays as JAX was given it
        assert _exported.folder() is None
        assert _exported.persistent(_run_small) is _run_small
    finally:
        _exported.set_folder(kept)
