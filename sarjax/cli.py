"""The ``sarjax`` command: demo, simulate, focus, metrics, fit, check, export, plot.

Every command takes ``--help``. Files are NetCDF-4 (:mod:`sarjax.io`): ``simulate`` writes
raw data with every parameter of the run, ``focus`` an image carrying them on, so each
file reproduces its run. Outputs are written atomically and never replace an existing
file without ``--force``. Exit status 0 on success; on bad input one line
``sarjax: error: …`` on stderr and status 2 (1 for an unexpected internal error, also
one line; ``SARJAX_TRACEBACK=1`` shows its traceback).

Configuration files (TOML) for ``simulate``::

    preset = "airborne"              # airborne | cband | highspeed (sarjax.presets)

    [radar]                          # overrides of any Radar field (SI units)
    num_pulses = 1025

    [scene]                          # point targets: x [m], closest-approach r [m]
    azimuth = [0.0, 0.0, 0.0]
    range = [4840.0, 5140.0, 5440.0]
    reflectivity = [1.0, 1.0, 1.0]   # optional; also reflectivity_phase [rad], height [m]

    [motion]                         # all optional; absent = ideal straight track
    deviation_rms = 0.02             # smooth Δy, Δz [m] (sarjax.smooth_deviation)
    max_cycles = 1.0                 # per footprint
    seed = 2017
    jitter = 0.05                    # pointing jitter δ_m in units of λ/L (seed 000 eq. 55)
    jitter_period = 0.1              # T_b in units of T_s

    [simulate]
    method = "time_domain"           # or fourier_2d, small_deviation, ..., auto
    dtype = "complex128"

``--set section.key=value`` overrides any entry (value in TOML syntax).
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
import tomllib
import warnings
from pathlib import Path

import click

_PRESETS = {"airborne": "airborne_xband", "cband": "spaceborne_cband",
            "highspeed": "highspeed_xband"}


class _Fail(Exception):
    """A handled failure: printed as one line, exit status 2."""


def _progress(total, desc):
    """A tqdm bar on stderr (hidden when stderr is not a terminal)."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="step", leave=False, disable=None,
                file=sys.stderr)


# ---- configuration ----------------------------------------------------------------------


def load_config(path=None, overrides=()) -> dict:
    """Read a TOML configuration and apply ``section.key=value`` overrides."""
    config = {}
    if path is not None:
        path = Path(path)
        try:
            config = tomllib.loads(path.read_text())
        except FileNotFoundError:
            raise _Fail(f"configuration {path} does not exist") from None
        except IsADirectoryError:
            raise _Fail(f"configuration {path} is a folder, not a TOML file") from None
        except UnicodeDecodeError:
            raise _Fail(f"configuration {path} is not a text (TOML) file") from None
        except tomllib.TOMLDecodeError as err:
            raise _Fail(f"{path}: {err}") from None
    for item in overrides:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise _Fail(f"--set {item!r}: expected section.key=value")
        try:
            parsed = tomllib.loads(f"v = {value}")["v"]
        except tomllib.TOMLDecodeError:
            parsed = value  # a bare word: take it as a string
        *sections, leaf = key.strip().split(".")
        node = config
        for section in sections:
            node = node.setdefault(section, {})
            if not isinstance(node, dict):
                raise _Fail(f"--set {item!r}: {section!r} is not a table")
        node[leaf] = parsed
    known = {"preset", "radar", "scene", "motion", "simulate"}
    unknown = set(config) - known
    if unknown:
        raise _Fail(f"unknown configuration entries {sorted(unknown)}; known: {sorted(known)}")
    for section in known - {"preset"}:
        if not isinstance(config.get(section, {}), dict):
            raise _Fail(f"[{section}] must be a table, got {section} = {config[section]!r}")
    return config


def _number(name, value, *, integer=False, minimum=None, positive=False):
    """A configuration value as a finite float (or int), naming it when it is not one."""
    kind = "an integer" if integer else "a number"
    if isinstance(value, bool) or not isinstance(value, int if integer else (int, float)):
        raise ValueError(f"{name}={value!r} must be {kind}")
    if not math.isfinite(value):
        raise ValueError(f"{name}={value!r} must be finite")
    if positive and value <= 0:
        raise ValueError(f"{name}={value!r} must be > 0")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name}={value!r} must be ≥ {minimum}")
    return int(value) if integer else float(value)


def _numbers(name, value):
    """A configuration list of numbers (or one number) as a 1-D float array."""
    import numpy as np

    items = value if isinstance(value, list) else [value]
    for item in items:
        if isinstance(item, bool) or not isinstance(item, (int, float)):
            raise ValueError(f"{name}={value!r} must be a number or a list of numbers")
    return np.asarray(items, float)


def build_run(config: dict):
    """(radar, scene, motion, simulate keyword arguments) from a configuration dict."""
    import numpy as np

    from . import _validate, presets
    from .motion import Motion, seed_pointing_jitter, smooth_deviation
    from .scene import PointTargets

    preset = config.get("preset", "airborne")
    if not isinstance(preset, str) or preset not in _PRESETS:
        raise ValueError(f"preset={preset!r}; choose one of {sorted(_PRESETS)}")
    radar_cfg = dict(config.get("radar", {}))
    for key, value in radar_cfg.items():
        radar_cfg[key] = _number(f"radar.{key}", value,
                                 integer=key in ("num_pulses", "num_range"))
    radar = getattr(presets, _PRESETS[preset])(**radar_cfg)
    _validate.check_radar(radar)  # before any number is derived from it
    scene_cfg = dict(config.get("scene", {}))
    if "azimuth" not in scene_cfg or "range" not in scene_cfg:
        raise ValueError("the configuration needs [scene] azimuth = [...] and range = [...]")
    azimuth = _numbers("scene.azimuth", scene_cfg.pop("azimuth"))
    range_ = _numbers("scene.range", scene_cfg.pop("range"))
    amplitude = (_numbers("scene.reflectivity", scene_cfg.pop("reflectivity"))
                 if "reflectivity" in scene_cfg else np.ones(azimuth.size))
    phase = _numbers("scene.reflectivity_phase", scene_cfg.pop("reflectivity_phase", 0.0))
    height = scene_cfg.pop("height", None)
    height = None if height is None else _numbers("scene.height", height)
    if phase.size not in (1, amplitude.size):
        raise ValueError(f"scene.reflectivity_phase has {phase.size} values, "
                         f"scene.reflectivity {amplitude.size}")
    if scene_cfg:
        raise ValueError(f"unknown [scene] entries {sorted(scene_cfg)}")
    scene = PointTargets(azimuth=azimuth, range=range_,
                         reflectivity=amplitude * np.exp(1j * phase), height=height)
    sim = dict(config.get("simulate", {}))
    num_pulses = _number("simulate.num_pulses", sim.pop("num_pulses", radar.num_pulses),
                         integer=True, positive=True)
    azimuth_center = _number("simulate.azimuth_center", sim.get("azimuth_center", 0.0))
    x = azimuth_center + (np.arange(num_pulses) - (num_pulses - 1) / 2) * float(
        radar.azimuth_spacing)
    motion_cfg = dict(config.get("motion", {}))
    rms = _number("motion.deviation_rms", motion_cfg.pop("deviation_rms", 0.0), minimum=0)
    cycles = _number("motion.max_cycles", motion_cfg.pop("max_cycles", 1.0), positive=True)
    seed = _number("motion.seed", motion_cfg.pop("seed", 2017), integer=True, minimum=0)
    jitter = _number("motion.jitter", motion_cfg.pop("jitter", 0.0), minimum=0)
    period = _number("motion.jitter_period", motion_cfg.pop("jitter_period", 0.1),
                     positive=True)
    if motion_cfg:
        raise ValueError(f"unknown [motion] entries {sorted(motion_cfg)}")
    footprint = float(radar.footprint(radar.reference_range))
    motion = Motion(
        horizontal=smooth_deviation(x, key=seed, rms=rms, max_cycles=cycles,
                                    aperture=footprint) if rms else None,
        vertical=smooth_deviation(x, key=seed + 1, rms=rms, max_cycles=cycles,
                                  aperture=footprint) if rms else None,
        pointing=seed_pointing_jitter(radar, x, amplitude_fraction=jitter,
                                      period_fraction=period) if jitter else None,
    )
    sim.setdefault("method", "time_domain")
    if not isinstance(sim["method"], str):
        raise ValueError(f"simulate.method={sim['method']!r} must be a method name")
    sim["num_pulses"] = num_pulses
    return radar, scene, motion, sim


def simulate_config(config: dict):
    """Run a configuration through :func:`sarjax.simulate`; returns
    (raw, radar, scene, motion, attributes for the file)."""
    import numpy as np

    from . import io
    from ._simulate import simulate

    radar, scene, motion, sim = build_run(config)
    sim = dict(sim)
    method, dtype = sim.pop("method"), sim.pop("dtype", "complex128")
    try:
        dtype = np.dtype(dtype)
    except TypeError:
        raise ValueError(f"simulate.dtype={dtype!r}: choose 'complex64' or 'complex128'") from None
    num_pulses = sim.pop("num_pulses")
    num_range = _number("simulate.num_range", sim.pop("num_range", radar.num_range),
                        integer=True, positive=True)
    near_range = _number("simulate.near_range", sim.pop("near_range", float(radar.near_range)),
                         positive=True)
    azimuth_center = _number("simulate.azimuth_center", sim.pop("azimuth_center", 0.0))
    raw = simulate(radar, scene, None if motion.is_ideal else motion, method=method,
                   num_pulses=num_pulses, num_range=num_range, near_range=near_range,
                   azimuth_center=azimuth_center, dtype=dtype, **sim)
    attrs = io.simulate_attributes(method=raw.method, num_pulses=num_pulses,
                                   num_range=num_range, near_range=near_range,
                                   azimuth_center=azimuth_center, dtype=dtype, **sim)
    attrs["config_toml"] = json.dumps(config)
    return raw, radar, scene, (None if motion.is_ideal else motion), attrs


# ---- commands ---------------------------------------------------------------------------

_CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


@click.group(context_settings=_CONTEXT, help=__doc__.split("\n\n")[0] + "\n\n"
             "Run 'sarjax COMMAND --help' for the options of a command.")
def cli():
    pass


def _out_option(help_text):
    return click.option("-o", "--out", required=True, type=click.Path(dir_okay=False),
                        help=help_text)


_force = click.option("--force", is_flag=True, help="replace an existing output file")


def _check_output(out, force):
    """Refuse an output path before any work: an existing file without ``--force``, a
    folder, or a missing parent folder."""
    path = Path(out)
    if path.is_dir():
        raise _Fail(f"output {path} is a folder")
    if path.exists() and not force:
        raise _Fail(f"{path} exists (pass --force to replace it)")
    if not path.parent.is_dir():
        raise _Fail(f"folder {path.parent} of the output does not exist")


@cli.command(context_settings=_CONTEXT)
@click.option("-o", "--out", default="sarjax_demo", show_default=True,
              type=click.Path(file_okay=False), help="output folder for the PNG figures")
@click.option("--pulses", type=int, default=None, help="number of pulses (default 1941)")
def demo(out, pulses):
    """Simulate, focus and measure the seed 000 airborne case; write PNG figures."""
    from .demo import format_table, run_demo

    t0 = time.perf_counter()
    rows = run_demo(out, num_pulses=pulses)
    click.echo()
    click.echo("Point-target metrics, airborne X-band (seed 000 Table 2), exact time-domain "
               "raw data,")
    click.echo("cm-level trajectory deviations + pointing jitter δ_m = λ/(20L), T_b = T_s/10;")
    click.echo("ω-k focusing over the full PRF band (azimuth pattern equalised):")
    click.echo(format_table(rows))
    click.echo(f"\ntotal {time.perf_counter() - t0:.1f} s")


@cli.command(context_settings=_CONTEXT)
@click.argument("config", type=click.Path(dir_okay=False))
@_out_option("output raw-data file (NetCDF, .nc)")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
              help="override a configuration entry (repeatable), e.g. radar.num_pulses=512")
@_force
def simulate(config, out, overrides, force):
    """Simulate raw data from a TOML configuration (see 'sarjax --help' of the module)."""
    from . import io

    cfg = load_config(config, overrides)
    _check_output(out, force)
    with _progress(2, "simulate") as bar:
        raw, radar, scene, motion, attrs = simulate_config(cfg)
        bar.update()
        io.save(out, raw, radar=radar, scene=scene, motion=motion, attrs=attrs,
                overwrite=force)
        bar.update()
    click.echo(f"wrote {out}: raw data {raw.shape[0]} × {raw.shape[1]} ({raw.method})")


@cli.command(context_settings=_CONTEXT)
@click.argument("raw_file", type=click.Path(dir_okay=False))
@_out_option("output image file (NetCDF, .nc)")
@click.option("--method", type=click.Choice(["omega_k", "backprojection"]),
              default="omega_k", show_default=True, help="focusing algorithm")
@click.option("--moco", type=click.Choice(["second_order", "first_order", "none"]),
              default="second_order", show_default=True,
              help="ω-k motion compensation with the file's motion")
@click.option("--weighting", type=click.Choice(["uniform", "antenna"]), default="uniform",
              show_default=True, help="ω-k azimuth weighting over the PRF band")
@click.option("--nominal-track", is_flag=True,
              help="ignore the file's motion (focus on the nominal straight track)")
@_force
def focus(raw_file, out, method, moco, weighting, nominal_track, force):
    """Focus a raw-data file into an image file."""
    from . import io
    from .processing import focus as focus_

    _check_output(out, force)
    run = _load(raw_file, "RawData")
    motion = None if nominal_track else run.motion
    kwargs = {}
    if method == "omega_k":
        kwargs = dict(motion_compensation=None if moco == "none" else moco,
                      azimuth_weighting=weighting)
    with _progress(2, "focus") as bar:
        image = focus_(run.radar, run.product, method=method, motion=motion, **kwargs)
        bar.update()
        attrs = {k: v for k, v in run.attrs.items()
                 if k.startswith(("simulate_", "config_"))}
        attrs.update(focus_method=method, focus_moco=moco if method == "omega_k" else "",
                     focus_weighting=weighting if method == "omega_k" else "",
                     focus_track="nominal" if motion is None else "file motion",
                     source=str(raw_file))
        io.save(out, image, radar=run.radar, scene=run.scene, motion=run.motion,
                attrs=attrs, overwrite=force)
        bar.update()
    click.echo(f"wrote {out}: image {image.shape[0]} × {image.shape[1]} ({method})")


@cli.command(context_settings=_CONTEXT)
@click.argument("image_file", type=click.Path(dir_okay=False))
@click.option("--target", "targets", multiple=True, metavar="X,R",
              help="target position azimuth,range [m] (repeatable; default: the file's "
                   "scatterers)")
@click.option("--half-window", type=int, default=32, show_default=True,
              help="neighbourhood half-size [samples] (doubled up to twice when the "
                   "sidelobe window needs it)")
@click.option("--json", "as_json", is_flag=True, help="print JSON instead of a table")
def metrics(image_file, targets, half_window, as_json):
    """IRW, PSLR, ISLR and peak of point targets in an image file."""
    from . import metrics as metrics_
    from .scene import PointTargets

    run = _load(image_file, "Image")
    if targets:
        positions = []
        for t in targets:
            try:
                x, r = (float(v) for v in t.split(","))
            except ValueError:
                raise _Fail(f"--target {t!r}: expected X,R in metres") from None
            positions.append((x, r))
    elif isinstance(run.scene, PointTargets):
        positions = list(zip(map(float, run.scene.azimuth), map(float, run.scene.range),
                             strict=True))
    else:
        raise _Fail(f"{image_file} holds no point targets: give --target X,R")
    results = []
    for x, r in positions:
        for attempt in range(3):  # widen the neighbourhood for wide sidelobe windows
            try:
                m = metrics_.point_target_metrics(run.product, azimuth=x, range=r,
                                                  half_window=half_window * 2**attempt)
                break
            except ValueError as err:
                if attempt == 2 or "increase half_window" not in str(err):
                    raise
        results.append(((x, r), m))
    if as_json:
        out = []
        for (x, r), m in results:
            d = {k: v for k, v in m.as_dict().items() if k != "peak_value"}
            out.append({"azimuth": x, "range": r, **{k: float(v) for k, v in d.items()}})
        click.echo(json.dumps(out, indent=1))
        return
    click.echo(f"{'x [m]':>8} {'r [m]':>9} " + metrics_.PointTargetMetrics.header())
    for (x, r), m in results:
        click.echo(f"{x:8.2f} {r:9.2f} " + m.as_row())


@cli.command(context_settings=_CONTEXT)
@click.argument("raw_file", type=click.Path(dir_okay=False))
@_out_option("output file (NetCDF) holding the raw data and the fitted motion")
@click.option("--png", type=click.Path(dir_okay=False), default=None,
              help="also plot the fit against the file's motion (its truth)")
@_force
def fit(raw_file, out, png, force):
    """Estimate the trajectory deviations and pointing error from a raw-data file of a
    known point-target scene (sarjax.fit_motion)."""
    from . import io

    try:
        from .inverse import fit_motion
    except ImportError:
        raise _Fail("motion fitting (sarjax.inverse.fit_motion) is not available in this "
                    "installation") from None
    _check_output(out, force)
    run = _load(raw_file, "RawData")
    if run.scene is None:
        raise _Fail(f"{raw_file} holds no scene: the fit needs the calibration targets")
    with _progress(2, "fit") as bar:
        result = fit_motion(run.radar, run.scene, run.product)
        bar.update()
        attrs = {"fit_chi2": float(result.chi2), "fit_converged": int(bool(result.converged)),
                 "source": str(raw_file)}
        io.save(out, run.product, radar=run.radar, scene=run.scene, motion=result.motion,
                attrs=attrs, overwrite=force)
        bar.update()
    if png:
        from . import plot

        plot.motion_fit(run.product.azimuth, result.motion, truth=run.motion, path=png)
    click.echo(f"wrote {out}: fitted motion (χ² = {float(result.chi2):.4g}, "
               f"{'converged' if result.converged else 'not converged'})")


@cli.command(context_settings=_CONTEXT)
@click.option("--preset", type=click.Choice(sorted(_PRESETS)), default="airborne",
              show_default=True)
@click.option("--deviation", type=float, default=0.02, show_default=True,
              help="rms of the smooth horizontal and vertical deviations [m]")
@click.option("--cycles", type=float, default=1.0, show_default=True,
              help="highest number of deviation cycles per footprint")
@click.option("--jitter", type=float, default=0.05, show_default=True,
              help="pointing jitter amplitude in units of λ/L (seed 000: 0.05)")
@click.option("--ranges", default="4840,5140,5440", show_default=True,
              help="target ranges [m]")
@click.option("--pulses", type=int, default=None)
@click.option("--seed", type=int, default=1, show_default=True)
def check(preset, deviation, cycles, jitter, ranges, pulses, seed):
    """Validity budgets of the approximate simulators (no simulation)."""
    import numpy as np

    from . import presets
    from .motion import Motion, seed_pointing_jitter, smooth_deviation
    from .scene import PointTargets
    from .validity import FASTEST_FIRST, validity

    radar = getattr(presets, _PRESETS[preset])(
        **({} if pulses is None else {"num_pulses": pulses}))
    n = radar.num_pulses
    x = (np.arange(n) - (n - 1) / 2) * float(radar.azimuth_spacing)
    footprint = float(radar.footprint(radar.reference_range))
    motion = Motion(
        horizontal=smooth_deviation(x, key=seed, rms=deviation, max_cycles=cycles,
                                    aperture=footprint),
        vertical=smooth_deviation(x, key=seed + 1, rms=deviation, max_cycles=cycles,
                                  aperture=footprint),
        pointing=seed_pointing_jitter(radar, x, amplitude_fraction=jitter) if jitter else None,
    )
    try:
        target_ranges = [float(v) for v in ranges.split(",")]
    except ValueError:
        raise _Fail(f"--ranges {ranges!r}: expected comma-separated numbers") from None
    scene = PointTargets(azimuth=[0.0] * len(target_ranges), range=target_ranges)
    click.echo(f"preset {preset}; deviations {deviation} m rms (≤ {cycles} cycles per "
               f"footprint), jitter δ_m = {jitter} λ/L; targets at {target_ranges} m")
    chosen = None
    for method in FASTEST_FIRST[:-1]:
        report = validity(radar, scene, motion, method=method)
        click.echo(str(report))
        if chosen is None and report.valid:
            chosen = method
    click.echo(f"method='auto' would choose: {chosen or 'time_domain'}")


@cli.command(context_settings=_CONTEXT)
@click.argument("raw_file", type=click.Path(dir_okay=False))
@_out_option("output file (.cphd or .crsd)")
@click.option("--format", "fmt", type=click.Choice(["cphd", "crsd"]), required=True,
              help="CPHD 1.1.0 (FX domain) or CRSD 1.0 (raw chirped echoes)")
@click.option("--track", type=click.Choice(["true", "nominal"]), default="true",
              show_default=True, help="antenna positions written into the file")
@click.option("--latitude", type=float, default=52.0, show_default=True,
              help="latitude of the scene reference point [deg]")
@click.option("--longitude", type=float, default=5.0, show_default=True,
              help="longitude of the scene reference point [deg]")
@click.option("--heading", type=float, default=0.0, show_default=True,
              help="flight direction, clockwise from north [deg]")
@click.option("--side", type=click.Choice(["L", "R"]), default="R", show_default=True,
              help="side of the track the scene is on")
@_force
def export(raw_file, out, fmt, track, latitude, longitude, heading, side, force):
    """Export a raw-data file to an NGA standard file through sarkit."""
    from . import export as export_

    _check_output(out, force)
    run = _load(raw_file, "RawData")
    reference = export_.GeoReference(latitude=latitude, longitude=longitude,
                                      heading=heading, side_of_track=side)
    writer = export_.to_cphd if fmt == "cphd" else export_.to_crsd
    with _progress(1, f"export {fmt}") as bar:
        writer(out, run.radar, run.product, run.motion, track=track, reference=reference,
               overwrite=force)
        bar.update()
    click.echo(f"wrote {out} ({fmt.upper()}, {track} track)")


@cli.command(context_settings=_CONTEXT)
@click.argument("file", type=click.Path(dir_okay=False))
@_out_option("output PNG")
@click.option("--dynamic-range", type=float, default=50.0, show_default=True,
              help="image: dB below the peak shown")
@_force
def plot(file, out, dynamic_range, force):
    """Plot a file: raw data (amplitude and phase) or an image (dB, grey)."""
    from . import plot as plot_
    from .export._common import atomic_write

    _check_output(out, force)
    run = _load(file, None)
    if type(run.product).__name__ == "RawData":
        fig = plot_.raw_amplitude_phase(run.product)
    else:
        fig = plot_.image_db(run.product, dynamic_range=dynamic_range)
    atomic_write(Path(out), lambda tmp: fig.savefig(tmp, format="png", dpi=110,
                                                    bbox_inches="tight"), overwrite=force)
    click.echo(f"wrote {out}")


def _load(path, kind):
    from . import io

    try:
        run = io.load(path)
    except OSError as err:
        raise _Fail(f"cannot read {path}: {err}") from None
    if kind is not None and type(run.product).__name__ != kind:
        raise _Fail(f"{path} holds {type(run.product).__name__}, expected {kind}")
    if kind is not None and run.radar is None:
        raise _Fail(f"{path} holds no radar parameters")
    return run


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    text = " ".join(str(message).split())
    print(f"sarjax: warning: {text} ({category.__name__})", file=sys.stderr)


def main(argv=None) -> int:
    """Entry point of the ``sarjax`` command; returns the exit status."""
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning  # one line each, as errors are
            result = cli.main(args=argv, prog_name="sarjax", standalone_mode=False)
    except click.exceptions.Exit as exit_:
        return int(exit_.exit_code)
    except click.exceptions.Abort:
        print("sarjax: error: aborted", file=sys.stderr)
        return 1
    except click.exceptions.ClickException as err:
        print(f"sarjax: error: {err.format_message()}", file=sys.stderr)
        return 2
    except (_Fail, ValueError, OSError, ImportError, Warning) as err:  # Warning: -W error
        message = " ".join(str(err).split())
        print(f"sarjax: error: {message}", file=sys.stderr)
        return 2
    except Exception as err:  # a bug: still one line (the traceback on request)
        if os.environ.get("SARJAX_TRACEBACK"):
            raise
        message = " ".join(str(err).split())
        print(f"sarjax: error: internal error ({type(err).__name__}: {message}); "
              "SARJAX_TRACEBACK=1 shows where", file=sys.stderr)
        return 1
    return result if isinstance(result, int) else 0


if __name__ == "__main__":
    sys.exit(main())
