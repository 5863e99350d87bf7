"""Runs over several processes: JAX's multi-controller runtime, set up for sarjax.

One process per host (or per GPU) runs the *same* program; after :func:`initialize`,
``jax.devices()`` lists the devices of every process, and ``sj.simulate(...,
devices=jax.devices())`` splits a batch of motion realizations (and, for the exact model,
blocks of pulses) over all of them. The result is a global ``jax.Array``: each process
holds its shards; :func:`gather` gives every process the whole data as NumPy, and
:func:`is_main` picks the one process that writes files.

Three ways to start the processes:

* **One laptop, several local processes** (testing the multi-process path, or several
  CPU sockets): ``python -m sarjax.distributed -n 2 --devices-per-process 2 --
  script.py ARGS`` starts ``n`` copies of ``script.py`` on this machine, with a free
  localhost port as coordinator, and returns the first non-zero exit status (the others
  are stopped then). :func:`launch` is the same from Python.
* **A SLURM cluster**: ``srun --ntasks=N python script.py``; :func:`initialize` with no
  arguments lets JAX read the coordinator, process count and index from SLURM's
  environment (also Open MPI's ``mpirun``).
* **Explicitly**: ``initialize("host0:1234", num_processes=N, process_id=i)`` in each.

On CPU the processes exchange data through gloo (``jax_cpu_collectives_implementation``),
which :func:`initialize` selects; GPUs use NCCL as JAX sets up.

The script calls :func:`initialize` before any other JAX work (it must come before the
first computation: JAX starts its backend then).
"""

from __future__ import annotations

import argparse
import os
import signal
import socket
import subprocess
import sys
import time

import jax
import numpy as np

# set by launch() for each child; read by initialize()
ENV_COORDINATOR = "SARJAX_COORDINATOR"
ENV_NUM_PROCESSES = "SARJAX_NUM_PROCESSES"
ENV_PROCESS_ID = "SARJAX_PROCESS_ID"


def initialize(coordinator: str | None = None, num_processes: int | None = None,
               process_id: int | None = None) -> None:
    """Join the multi-process run (``jax.distributed.initialize``), once per process.

    Args:
        coordinator: ``"host:port"`` of process 0. None: from :func:`launch`'s environment
            (``SARJAX_COORDINATOR`` …), else JAX's auto-detection (SLURM, Open MPI).
        num_processes: the number of processes (with ``coordinator``).
        process_id: this process's index, 0 … num_processes − 1 (with ``coordinator``).

    Raises:
        ValueError: a coordinator without both counts, or counts out of range.
    """
    if coordinator is None and os.environ.get(ENV_COORDINATOR):
        coordinator = os.environ[ENV_COORDINATOR]
        num_processes = int(os.environ[ENV_NUM_PROCESSES])
        process_id = int(os.environ[ENV_PROCESS_ID])
    if coordinator is not None:
        if num_processes is None or process_id is None:
            raise ValueError(f"coordinator={coordinator!r} needs num_processes and "
                             f"process_id (got {num_processes!r}, {process_id!r})")
        if not (int(num_processes) >= 1 and 0 <= int(process_id) < int(num_processes)):
            raise ValueError(f"process_id={process_id!r} must lie in 0 … num_processes − 1 "
                             f"(num_processes={num_processes!r})")
    # CPU devices of different processes talk through gloo (the default has none)
    jax.config.update("jax_cpu_collectives_implementation", "gloo")
    if coordinator is None:
        jax.distributed.initialize()
    else:
        jax.distributed.initialize(coordinator, num_processes=int(num_processes),
                                   process_id=int(process_id))


def is_main() -> bool:
    """True in process 0 (the one that writes files and prints)."""
    return jax.process_index() == 0


def gather(product):
    """The whole of a (globally sharded) :class:`~sarjax.RawData` or
    :class:`~sarjax.Image` in every process, its data as a NumPy array; a product whose
    data are already local is returned with NumPy data unchanged."""
    import dataclasses

    data = product.data
    if isinstance(data, jax.Array) and not data.is_fully_addressable:
        from jax.experimental import multihost_utils

        data = multihost_utils.process_allgather(data, tiled=True)
    return dataclasses.replace(product, data=np.asarray(data))


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def launch(command: list[str], num_processes: int = 2, *,
           devices_per_process: int | None = None, timeout: float | None = None,
           env: dict | None = None) -> int:
    """Start ``num_processes`` local copies of ``python COMMAND`` as one multi-process run.

    Each child gets the coordinator (a free localhost port), the process count and its
    index in its environment (read by :func:`initialize`), and with
    ``devices_per_process`` that many forced host (CPU) devices. Their output goes to this
    process's stdout and stderr.

    Args:
        command: the arguments after ``python``: a script and its arguments, or ``-m``,
            a module and its arguments.
        num_processes: processes to start (≥ 1).
        devices_per_process: CPU devices each process shows (None: XLA's default, one).
        timeout: seconds to wait for them all (None: no limit); past it all are stopped.
        env: extra environment entries for every child.

    Returns:
        0 when every process exits with 0, else the first non-zero status (the other
        processes are then stopped: a run cannot finish without all of them).
    """
    if not command:
        raise ValueError("command is empty: give a script (and its arguments) to run")
    if not (isinstance(num_processes, int) and num_processes >= 1):
        raise ValueError(f"num_processes={num_processes!r} must be an integer ≥ 1")
    if devices_per_process is not None and not (
            isinstance(devices_per_process, int) and devices_per_process >= 1):
        raise ValueError(f"devices_per_process={devices_per_process!r} must be an integer "
                         "≥ 1")
    base = dict(os.environ, **(env or {}))
    base[ENV_COORDINATOR] = f"127.0.0.1:{_free_port()}"
    base[ENV_NUM_PROCESSES] = str(num_processes)
    if devices_per_process is not None:
        flags = [f for f in base.get("XLA_FLAGS", "").split()
                 if not f.startswith("--xla_force_host_platform_device_count")]
        base["XLA_FLAGS"] = " ".join(
            [*flags, f"--xla_force_host_platform_device_count={devices_per_process}"])
    children = [subprocess.Popen([sys.executable, *command],
                                 env=dict(base, **{ENV_PROCESS_ID: str(i)}))
                for i in range(num_processes)]
    deadline = None if timeout is None else time.monotonic() + timeout
    status = 0
    try:
        while None in [child.poll() for child in children]:  # poll each (no short cut)
            failed = [child.returncode for child in children
                      if child.returncode not in (None, 0)]
            if failed:
                status = failed[0]
                break
            if deadline is not None and time.monotonic() > deadline:
                status = 124
                print(f"sarjax.distributed: stopped after {timeout} s", file=sys.stderr)
                break
            time.sleep(0.05)
        else:
            status = next((c.returncode for c in children if c.returncode != 0), 0)
    finally:
        for child in children:  # a failed or timed-out run: the rest cannot finish
            if child.poll() is None:
                child.send_signal(signal.SIGTERM)
        for child in children:
            try:
                child.wait(timeout=10)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
    return status


def main(argv=None) -> int:
    """``python -m sarjax.distributed -n N [--devices-per-process D] -- SCRIPT ARGS``."""
    parser = argparse.ArgumentParser(
        prog="python -m sarjax.distributed",
        description="Run N local copies of a Python script as one multi-process JAX run "
                    "(the script calls sarjax.distributed.initialize()).")
    parser.add_argument("-n", "--num-processes", type=int, default=2)
    parser.add_argument("--devices-per-process", type=int, default=None,
                        help="forced CPU devices in each process")
    parser.add_argument("--timeout", type=float, default=None, help="seconds")
    parser.add_argument("command", nargs=argparse.REMAINDER,
                        help="the script and its arguments (after --)")
    args = parser.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    try:
        return launch(command, args.num_processes,
                      devices_per_process=args.devices_per_process, timeout=args.timeout)
    except ValueError as error:
        print(f"sarjax.distributed: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
