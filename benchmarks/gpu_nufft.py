"""The NUFFT exact model on a GPU: the seed 000 scene of ``bench_nufft.py`` timed on the
first GPU, and a small scene's data on the GPU against the CPU's (where the spreading
runs in the native kernel, on the GPU in its JAX formulation).

Needs a machine with a GPU and jax's GPU plugin; prints its figures (the benchmark
machine of ``RESULTS.md`` has no GPU, so nothing is written there)::

    python benchmarks/gpu_nufft.py
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _common import steady, timed  # noqa: E402
from bench_nufft import seed000_call  # noqa: E402


def main():
    import jax
    import numpy as np

    import sarjax as sj
    from sarjax._numerics import native

    gpus = [d for d in jax.devices() if d.platform == "gpu"]
    if not gpus:
        sys.exit("no GPU: this benchmark times the GPU path")
    print(f"jax {jax.__version__}, {gpus[0].device_kind}; CPU spreading: {native.status()}")
    radar = sj.presets.airborne_xband(num_pulses=64, num_range=128)
    scene = sj.PointTargets(azimuth=[-3.0, 0.5, 40.0], range=[5120.0, 5140.0, 5300.0],
                            reflectivity=[1.0, 0.5j, 2.0])
    kw = dict(method="time_domain_nufft", num_pulses=64, num_range=128, near_range=5100.0)
    on_gpu = np.asarray(sj.simulate(radar, scene, devices=gpus[:1], **kw).data)
    on_cpu = np.asarray(sj.simulate(radar, scene, devices=jax.devices("cpu")[:1], **kw).data)
    print("GPU against CPU, max |difference| / max |CPU|: "
          f"{np.abs(on_gpu - on_cpu).max() / np.abs(on_cpu).max():.1e}")
    for dtype in ("complex64", "complex128"):
        call = seed000_call(972, 416, dtype, devices=gpus[:1])
        first = timed(call)[0]
        s = steady(call, 3)
        print(f"seed 000 scene (972 × 416), {dtype}: first call {first:.2f} s, "
              f"steady {s.min:.3f} s")


if __name__ == "__main__":
    main()
