"""Several processes, one run: ``sarjax.distributed`` on this machine.

Two local processes with two forced CPU devices each (``launch``) form one 4-device mesh
through JAX's multi-controller runtime (gloo collectives on CPU). The same ``simulate``
call in both, with ``devices=jax.devices()`` (all four), splits a batch of motion
realizations over the processes, and one scene of a Fourier-domain method by its range
columns (an all-to-all across the processes); ``gather`` assembles it. The exact model
and a Fourier-domain method must equal the one-process results: they run the same
per-device programs, so to rounding (XLA's CPU FFT may round a few rows differently under
another thread split, see ``tests/_reruns.py``; a split column loop fuses differently,
≲ 2e-8 relative, see ``tests/test_sharding.py``), here 1e-9 of the peak for a batch and
1e-7 for a split scene, inside the 1e-6 asked.
"""

from __future__ import annotations

import sys
import textwrap
import time

import numpy as np
import pytest

import sarjax as sj
from sarjax import distributed

NUM_PULSES, NUM_RANGE = 128, 96
METHODS = ("time_domain", "small_deviation")

WORKER = textwrap.dedent("""
    import sys
    import numpy as np
    import sarjax as sj
    from sarjax import distributed

    distributed.initialize()  # from launch()'s environment
    import jax

    sys.path.insert(0, sys.argv[2])
    from test_distributed import METHODS, case

    radar, scene, motion, near = case()
    out = {"processes": jax.process_count(), "devices": jax.device_count()}
    for method in METHODS:
        raw = sj.simulate(radar, scene, motion, method=method, near_range=near,
                          devices=jax.devices())
        out["local_" + method] = len(raw.data.addressable_shards)
        out[method] = distributed.gather(raw).data
    # one realization: the Fourier method's columns over the four devices of both processes
    one = sj.Motion(horizontal=motion.horizontal[1])
    raw = sj.simulate(radar, scene, one, method=METHODS[1], near_range=near,
                      devices=jax.devices())
    out["local_split"] = len(raw.data.addressable_shards)
    out["split"] = distributed.gather(raw).data
    if distributed.is_main():
        np.savez(sys.argv[1], **out)
""")


def case():
    """A batch of four realizations of a horizontal deviation; two targets."""
    radar = sj.presets.airborne_xband(num_pulses=NUM_PULSES, num_range=NUM_RANGE)
    scene = sj.PointTargets(azimuth=[0.0, 3.0], range=[5140.0, 5150.0])
    x = (np.arange(NUM_PULSES) - (NUM_PULSES - 1) / 2) * float(radar.azimuth_spacing)
    motion = sj.Motion(horizontal=np.stack([0.004 * k * np.sin(x / 9) for k in range(4)]))
    near = 5140.0 - NUM_RANGE // 2 * float(radar.range_spacing)
    return radar, scene, motion, near


def test_two_processes_equal_one(tmp_path):
    script = tmp_path / "worker.py"
    script.write_text(WORKER)
    out = tmp_path / "out.npz"
    tests = str(__import__("pathlib").Path(__file__).parent)
    status = distributed.launch([str(script), str(out), tests], 2, devices_per_process=2,
                                timeout=400)
    assert status == 0
    got = np.load(out)
    assert int(got["processes"]) == 2 and int(got["devices"]) == 4
    radar, scene, motion, near = case()
    for method in METHODS:
        # each process held two of the four realizations' shards
        assert int(got["local_" + method]) == 2, method
        one = np.asarray(sj.simulate(radar, scene, motion, method=method,
                                     near_range=near).data)
        assert got[method].shape == one.shape == (4, NUM_PULSES, NUM_RANGE)
        peak = np.max(np.abs(one))
        assert peak > 0
        assert np.max(np.abs(got[method] - one)) <= 1e-9 * peak, method
    # one scene split by columns: each process held two of the four pulse blocks
    assert int(got["local_split"]) == 2
    single = np.asarray(sj.simulate(radar, scene, sj.Motion(horizontal=motion.horizontal[1]),
                                    method=METHODS[1], near_range=near, devices=1).data)
    assert got["split"].shape == single.shape == (NUM_PULSES, NUM_RANGE)
    assert np.max(np.abs(got["split"] - single)) <= 1e-7 * np.max(np.abs(single))


def test_a_failed_process_stops_the_run(tmp_path):
    """Process 1 fails at once: launch returns its status without waiting for process 0
    (which would wait 60 s for a partner that is gone)."""
    script = tmp_path / "fail.py"
    script.write_text("import os, sys, time\n"
                      f"if os.environ[{distributed.ENV_PROCESS_ID!r}] == '1': sys.exit(3)\n"
                      "time.sleep(60)\n")
    start = time.monotonic()
    assert distributed.launch([str(script)], 2) == 3
    assert time.monotonic() - start < 30


def test_the_launcher_command_line(tmp_path, capsys):
    script = tmp_path / "ok.py"
    script.write_text("import os\n"
                      f"assert os.environ[{distributed.ENV_NUM_PROCESSES!r}] == '3'\n")
    assert distributed.main(["-n", "3", "--", str(script)]) == 0
    assert distributed.main(["-n", "0", "--", str(script)]) == 2
    assert "num_processes=0" in capsys.readouterr().err


LAUNCHED_CONFIG = """
preset = "airborne"
[radar]
num_pulses = 96
num_range = 64
near_range = 5120.0
[scene]
azimuth = [0.0, 2.0]
range = [5140.0, 5150.0]
[simulate]
method = "{method}"
"""


@pytest.mark.parametrize("method", [pytest.param("time_domain", marks=pytest.mark.slow),
                                    "small_deviation"])
def test_launched_command_line_simulation_equals_one_process(tmp_path, method):
    """``sarjax launch -n 2 --devices-per-process 2 -- simulate``: both processes run the
    call on the four devices (pulses of the exact model, range columns of a Fourier
    method), process 0 writes the whole raw data, equal to a one-process run's."""
    import sarjax.cli

    config = tmp_path / "run.toml"
    config.write_text(LAUNCHED_CONFIG.format(method=method))
    two, one = tmp_path / "two.nc", tmp_path / "one.nc"
    assert sarjax.cli.main(["launch", "-n", "2", "--devices-per-process", "2", "--",
                            "simulate", str(config), "-o", str(two)]) == 0
    assert sarjax.cli.main(["simulate", str(config), "-o", str(one)]) == 0
    got = np.asarray(sj.io.load(two).product.data)
    want = np.asarray(sj.io.load(one).product.data)
    assert got.shape == want.shape == (96, 64)
    # the exact model's pulse blocks: to rounding; a split column loop: ≲ 2e-8
    assert np.max(np.abs(got - want)) <= 1e-7 * np.max(np.abs(want))
    assert not list(tmp_path.glob("two.nc.*"))  # no second writer's leftovers


@pytest.mark.parametrize("kwargs, message", [
    (dict(coordinator="127.0.0.1:1"), "num_processes"),
    (dict(coordinator="127.0.0.1:1", num_processes=2, process_id=2), "process_id=2"),
])
def test_bad_initialize_arguments_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        distributed.initialize(**kwargs)


def test_bad_launch_arguments_are_named():
    with pytest.raises(ValueError, match="command is empty"):
        distributed.launch([], 2)
    with pytest.raises(ValueError, match="devices_per_process=0"):
        distributed.launch([sys.executable], 2, devices_per_process=0)
