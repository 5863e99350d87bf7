"""The verbs of the ``sarjax`` command (a click group) and the helpers they share."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import click

from .config import ACQUISITION_KEYS, PRESETS, Fail, campaign_config, load_config

_CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


@click.group(context_settings=_CONTEXT, help="The ``sarjax`` command: demo, simulate, focus, "
             "autofocus, metrics, fit, check, config, export, plot, campaign, launch.\n\n"
             "Run 'sarjax COMMAND --help' for the options of a command.")
@click.version_option(package_name="sarjax", prog_name="sarjax",
                      message="%(prog)s %(version)s")
def cli():
    pass


# ---- shared helpers ---------------------------------------------------------------------


def _out_option(help_text):
    return click.option("-o", "--out", required=True, type=click.Path(dir_okay=False),
                        help=help_text)


_force = click.option("--force", is_flag=True, help="replace an existing output file")


class _StepLog:
    """Progress as log lines on stderr (``sarjax: simulate: step 1/2 done after 3.1 s``),
    for a log file or a pipe, where a bar would show nothing."""

    def __init__(self, total, desc):
        self.total, self.desc, self.done, self.start = total, desc, 0, time.perf_counter()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n=1):
        self.done += n
        click.echo(f"sarjax: {self.desc}: step {self.done}/{self.total} done after "
                   f"{time.perf_counter() - self.start:.1f} s", err=True)


def _progress(total, desc):
    """A tqdm bar of ``total`` steps on stderr when it is a terminal; log lines otherwise."""
    if not sys.stderr.isatty():
        return _StepLog(total, desc)
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="step", leave=False, file=sys.stderr)


def _check_output(out, force):
    """Refuse an output path before any work: an existing file without ``--force``, a
    folder, or a missing parent folder."""
    path = Path(out)
    if path.is_dir():
        raise Fail(f"output {path} is a folder")
    if path.exists() and not force:
        raise Fail(f"{path} exists (pass --force to replace it)")
    if not path.parent.is_dir():
        raise Fail(f"folder {path.parent} of the output does not exist")


def _load(path, kind):
    """A file's run (:func:`sarjax.io.load`); ``kind``: the product type it must hold, with
    radar parameters (None: any)."""
    from .. import io

    try:
        run = io.load(path)
    except OSError as err:
        raise Fail(f"cannot read {path}: {err}") from None
    if kind is not None and type(run.product).__name__ != kind:
        raise Fail(f"{path} holds {type(run.product).__name__}, expected {kind}")
    if kind is not None and run.radar is None:
        raise Fail(f"{path} holds no radar parameters")
    return run


# ---- demo -------------------------------------------------------------------------------


@cli.command(context_settings=_CONTEXT)
@click.option("-o", "--out", default="sarjax_demo", show_default=True,
              type=click.Path(file_okay=False), help="output folder for the PNG figures")
@click.option("--pulses", type=int, default=None, help="number of pulses (default 1941)")
@click.option("--force", is_flag=True, help="replace the figures of an earlier demo in OUT")
def demo(out, pulses, force):
    """Simulate, focus and measure the seed 000 airborne case; write PNG figures."""
    from ..demo import FIGURES, format_table, run_demo

    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise Fail(f"output {folder} is a file, not a folder")
    earlier = sorted(name for name in FIGURES if (folder / name).exists())
    if earlier and not force:
        raise Fail(f"{folder} holds figures of an earlier demo ({', '.join(earlier)}); "
                   "pass --force to replace them")
    t0 = time.perf_counter()
    rows = run_demo(out, num_pulses=pulses)
    click.echo()
    click.echo("Point-target metrics, airborne X-band (seed 000 Table 2), exact time-domain "
               "raw data,")
    click.echo("cm-level trajectory deviations + pointing jitter δ_m = λ/(20L), T_b = T_s/10;")
    click.echo("ω-k focusing over the full PRF band (azimuth pattern equalised):")
    click.echo(format_table(rows))
    click.echo(f"\ntotal {time.perf_counter() - t0:.1f} s")


# ---- simulate, focus ----------------------------------------------------------------------


@cli.command(context_settings=_CONTEXT)
@click.argument("config", type=click.Path(dir_okay=False))
@_out_option("output raw-data file (NetCDF, .nc)")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
              help="override a configuration entry (repeatable), e.g. radar.num_pulses=512")
@_force
def simulate(config, out, overrides, force):
    """Simulate raw data from a TOML configuration (see 'sarjax --help' of the module).

    The compiled simulation is kept in ~/.cache/sarjax/jax (SARJAX_CACHE_DIR names
    another folder, 'off' none): a later run of the same method and shapes loads it
    instead of tracing and compiling; its checks and warnings run every time."""
    from .. import io
    from . import simulate_config  # the package's name (it can be replaced there)

    cfg = load_config(config, overrides)
    _check_output(out, force)
    with _progress(2, "simulate") as bar:
        raw, radar, scene, motion, attrs = simulate_config(cfg)
        main = _one_writer()
        if main is not None:  # one of the processes of a launched run: all of it, here
            from .. import distributed

            raw = distributed.gather(raw)
        bar.update()
        if main is False:  # process 0 writes the file
            return
        io.save(out, raw, radar=radar, scene=scene, motion=motion, attrs=attrs,
                overwrite=force)
        bar.update()
    click.echo(f"wrote {out}: raw data {raw.shape[0]} × {raw.shape[1]} ({raw.method})")


def _one_writer():
    """None in a one-process run; in a multi-process run (``sarjax launch``, ``srun``),
    True in process 0 (which writes the outputs) and False in the others."""
    import jax

    return None if jax.process_count() == 1 else jax.process_index() == 0


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
    from .. import io
    from ..processing import focus as focus_

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
        attrs = _focus_attributes(run, raw_file, method, moco, weighting, motion)
        io.save(out, image, radar=run.radar, scene=run.scene, motion=run.motion,
                attrs=attrs, overwrite=force)
        bar.update()
    click.echo(f"wrote {out}: image {image.shape[0]} × {image.shape[1]} ({method})")


@cli.command(context_settings=_CONTEXT)
@click.argument("raw_file", type=click.Path(dir_okay=False))
@_out_option("output image file (NetCDF, .nc), focused with the estimated motion")
@click.option("--objective", type=click.Choice(["entropy", "contrast"]), default="entropy",
              show_default=True, help="image-sharpness objective")
@click.option("--max-steps", type=click.IntRange(min=0), default=200, show_default=True,
              help="L-BFGS iterations of the sharpness stage")
@click.option("--restarts", type=click.IntRange(min=0), default=2, show_default=True,
              help="further estimates from random starts; a warning when they disagree")
@_force
def autofocus(raw_file, out, objective, max_steps, restarts, force):
    """Estimate Δy, Δz and the pointing error from a raw-data file of an unknown scene
    (sarjax.inverse.autofocus) and write the refocused image with the estimated motion."""
    from .. import io
    from ..inverse import autofocus as autofocus_

    _check_output(out, force)
    run = _load(raw_file, "RawData")
    result = autofocus_(run.radar, run.product, objective=objective, max_steps=max_steps,
                        restarts=restarts)
    io.save(out, result.image, radar=run.radar, motion=result.motion,
            attrs={"source": str(raw_file), **result.attributes()}, overwrite=force)
    agreement = ("" if result.agreement is None else
                 f"; {result.agreeing} of {restarts + 1} starts agree with the estimate kept, "
                 f"the largest difference {float(max(result.agreement)):.3g} rad")
    click.echo(f"wrote {out}: image {result.image.shape[0]} × {result.image.shape[1]} "
               f"(autofocus, {result.timings['total']:.1f} s{agreement})")


def _focus_attributes(run, raw_file, method, moco, weighting, motion):
    """The image file's attributes: the raw file's run parameters and the focusing."""
    attrs = {k: v for k, v in run.attrs.items() if k.startswith(("simulate_", "config_"))}
    attrs.update(focus_method=method, focus_moco=moco if method == "omega_k" else "",
                 focus_weighting=weighting if method == "omega_k" else "",
                 focus_track="nominal" if motion is None else "file motion",
                 source=str(raw_file))
    return attrs


# ---- metrics ----------------------------------------------------------------------------


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
    run = _load(image_file, "Image")
    positions = _target_positions(targets, run.scene, image_file)
    results = [((x, r), _point_metrics(run.product, x, r, half_window))
               for x, r in positions]
    if as_json:
        click.echo(_metrics_json(results))
    else:
        _echo_metrics_table(results)


def _target_positions(targets, scene, image_file):
    """(azimuth, range) [m] of each ``--target X,R``, or of the file's point targets."""
    from ..scene import PointTargets

    if targets:
        positions = []
        for t in targets:
            try:
                x, r = (float(v) for v in t.split(","))
            except ValueError:
                raise Fail(f"--target {t!r}: expected X,R in metres") from None
            positions.append((x, r))
        return positions
    if isinstance(scene, PointTargets):
        return list(zip(map(float, scene.azimuth), map(float, scene.range), strict=True))
    raise Fail(f"{image_file} holds no point targets: give --target X,R")


def _point_metrics(image, x, r, half_window):
    """The metrics of the target at (x, r), widening the neighbourhood (twice at most)
    when a wide sidelobe window needs it."""
    from .. import metrics as metrics_

    for attempt in range(3):
        try:
            return metrics_.point_target_metrics(image, azimuth=x, range=r,
                                                 half_window=half_window * 2**attempt)
        except ValueError as err:
            if attempt == 2 or "increase half_window" not in str(err):
                raise


def _metrics_json(results):
    out = []
    for (x, r), m in results:
        d = {k: v for k, v in m.as_dict().items() if k != "peak_value"}
        out.append({"azimuth": x, "range": r, **{k: float(v) for k, v in d.items()}})
    return json.dumps(out, indent=1)


def _echo_metrics_table(results):
    from .. import metrics as metrics_

    click.echo(f"{'x [m]':>8} {'r [m]':>9} " + metrics_.PointTargetMetrics.header())
    for (x, r), m in results:
        click.echo(f"{x:8.2f} {r:9.2f} " + m.as_row())


# ---- fit --------------------------------------------------------------------------------


@cli.command(context_settings=_CONTEXT)
@click.argument("raw_file", type=click.Path(dir_okay=False))
@_out_option("output file (NetCDF) holding the raw data and the fitted motion")
@click.option("--png", type=click.Path(dir_okay=False), default=None,
              help="also plot the fit against the file's motion (its truth)")
@_force
def fit(raw_file, out, png, force):
    """Estimate the trajectory deviations and pointing error from a raw-data file of a
    known point-target scene (sarjax.fit_motion)."""
    from .. import io

    fit_motion = _fit_motion_function()
    _check_output(out, force)
    run = _load(raw_file, "RawData")
    if run.scene is None:
        raise Fail(f"{raw_file} holds no scene: the fit needs the calibration targets")
    with _progress(2, "fit") as bar:
        result = fit_motion(run.radar, run.scene, run.product)
        bar.update()
        summary = fit_summary(result, run.motion)
        attrs = {"source": str(raw_file), **{f"fit_{k}": v for k, v in summary.items()}}
        io.save(out, run.product, radar=run.radar, scene=run.scene, motion=result.motion,
                attrs=attrs, overwrite=force)
        bar.update()
    if png:
        from .. import plot

        plot.motion_fit(run.product.azimuth, result.motion, truth=run.motion, path=png)
    click.echo(f"wrote {out}: fitted motion (χ² = {float(result.chi2):.4g} over "
               f"{result.num_residuals} residuals, "
               f"{'converged' if result.converged else 'not converged'})")
    for line in _fit_lines(summary):
        click.echo(line)


FIT_UNITS = {"horizontal": ("Δy", 1e3, "mm"), "vertical": ("Δz", 1e3, "mm"),
             "pointing": ("δ_az", 1e6, "µrad")}


def fit_summary(result, truth=None) -> dict:
    """What a fit file keeps of a :class:`~sarjax.inverse.FitResult` (the attributes
    ``fit_*``): χ², convergence, solver, noise power, the fitted pulses, the components
    held fixed (the gauge) and why, the rms CRB standard deviation of each profile, and,
    with the ``truth`` (a :class:`~sarjax.Motion`), the rms error in the fit's own gauge
    (:func:`sarjax.inverse.align`: the means of Δy and Δz removed when the fit cannot
    see them) [m, m, rad]."""
    import numpy as np

    pulses = np.flatnonzero(np.asarray(result.support))
    summary = {"chi2": float(result.chi2), "converged": int(bool(result.converged)),
               "solver": str(result.solver), "noise_power": float(result.noise_power),
               "support_first_pulse": int(pulses[0]), "support_last_pulse": int(pulses[-1]),
               "support_pulses": int(pulses.size),
               "fixed": json.dumps([[f.component, f.reason] for f in result.fixed])}
    std = result.profile_std()
    for name in FIT_UNITS:
        if name in std and std[name] is not None:
            summary[f"std_rms_{name}"] = float(np.sqrt(np.mean(np.square(std[name]))))
    if truth is not None:
        from ..inverse import align

        for name, err in zip(FIT_UNITS, align(result.motion, truth, result), strict=True):
            summary[f"error_rms_{name}"] = float(np.sqrt(np.mean(np.square(err))))
    return summary


def _fit_lines(summary):
    """The fit's per-component lines: rms error against the truth (when known) beside
    the CRB standard deviation, in the fit's gauge."""
    fixed = [component for component, _ in json.loads(summary["fixed"])]
    yield (f"pulses {summary['support_first_pulse']} … {summary['support_last_pulse']} fitted"
           + (f"; held fixed (unobservable): {', '.join(fixed)}" if fixed else ""))
    for name, (symbol, scale, unit) in FIT_UNITS.items():
        parts = []
        if f"error_rms_{name}" in summary:
            parts.append(f"error vs truth {summary[f'error_rms_{name}'] * scale:.3g} {unit} rms")
        if f"std_rms_{name}" in summary:
            parts.append(f"CRB σ {summary[f'std_rms_{name}'] * scale:.3g} {unit} rms")
        if parts:
            yield f"  {symbol:5s} " + ", ".join(parts)


def _fit_motion_function():
    try:
        from ..inverse import fit_motion
    except ImportError:
        raise Fail("motion fitting (sarjax.inverse.fit_motion) is not available in this "
                   "installation") from None
    return fit_motion


# ---- check ------------------------------------------------------------------------------


@cli.command(context_settings=_CONTEXT)
@click.argument("config", required=False, type=click.Path(dir_okay=False))
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
              help="override a configuration entry of CONFIG (repeatable)")
@click.option("--preset", type=click.Choice(sorted(PRESETS)), default="airborne",
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
def check(config, overrides, preset, deviation, cycles, jitter, ranges, pulses, seed):
    """Validity budgets of every simulator (no simulation): of the run a TOML CONFIG
    describes (as 'sarjax simulate' would run it), or of the options' preset scene."""
    from ..scene import PointTargets

    if config is not None:
        from .config import build_run

        radar, scene, motion, sim = build_run(load_config(config, overrides))
        click.echo(f"{config}: {sim['num_pulses']} pulses, {scene.azimuth.size} targets, "
                   f"method {sim['method']!r}")
        acquisition = {key: sim[key] for key in ACQUISITION_KEYS if key in sim}
        for line in method_report(radar, scene, None if motion.is_ideal else motion,
                                  **acquisition):
            click.echo(line)
        return
    radar, motion = _check_radar_motion(preset, pulses, deviation, cycles, jitter, seed)
    target_ranges = _ranges(ranges)
    scene = PointTargets(azimuth=[0.0] * len(target_ranges), range=target_ranges)
    click.echo(f"preset {preset}; deviations {deviation} m rms (≤ {cycles} cycles per "
               f"footprint), jitter δ_m = {jitter} λ/L; targets at {target_ranges} m")
    for line in method_report(radar, scene, motion):
        click.echo(line)


def _check_radar_motion(preset, pulses, deviation, cycles, jitter, seed):
    """The preset radar and a smooth deviation (and jitter) on its pulses."""
    import numpy as np

    from .. import presets
    from ..motion import Motion, seed_pointing_jitter, smooth_deviation

    radar = getattr(presets, PRESETS[preset])(
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
    return radar, motion


def _ranges(ranges):
    try:
        return [float(v) for v in ranges.split(",")]
    except ValueError:
        raise Fail(f"--ranges {ranges!r}: expected comma-separated numbers") from None


def method_report(radar, scene, motion, **acquisition):
    """Yields the validity report of every registered simulator (the registry's order),
    then the line naming the one ``method='auto'`` would choose."""
    from ..simulators import method_names
    from ..validity import choose_method, validity

    for method in method_names(aliases=False):
        yield str(validity(radar, scene, motion, method=method, **acquisition))
    yield (f"method='auto' would choose: "
           f"{choose_method(radar, scene, motion, **acquisition)[0]}")


# ---- config -----------------------------------------------------------------------------


@cli.command(name="config", context_settings=_CONTEXT)
@click.option("--example", is_flag=True, required=True,
              help="print a commented configuration with every key")
def config_command(example):
    """Print a commented TOML configuration of 'sarjax simulate' with every key."""
    from .config import EXAMPLE

    click.echo(EXAMPLE, nl=False)


# ---- export, plot -----------------------------------------------------------------------


@cli.command(context_settings=_CONTEXT)
@click.argument("in_file", type=click.Path(dir_okay=False))
@_out_option("output file (.cphd, .crsd, or .nitf for SICD)")
@click.option("--format", "fmt", type=click.Choice(["cphd", "crsd", "sicd"]), required=True,
              help="CPHD 1.1.0 (FX domain) or CRSD 1.0 (raw chirped echoes) of a raw-data "
                   "file; SICD 1.4.0 (complex slant-plane image) of an image file")
@click.option("--track", type=click.Choice(["true", "nominal"]), default="true",
              show_default=True, help="antenna positions written into the file (CPHD, "
                                      "CRSD; a SICD carries the nominal track it is "
                                      "focused on)")
@click.option("--latitude", type=float, default=52.0, show_default=True,
              help="latitude of the scene reference point [deg]")
@click.option("--longitude", type=float, default=5.0, show_default=True,
              help="longitude of the scene reference point [deg]")
@click.option("--heading", type=float, default=0.0, show_default=True,
              help="flight direction, clockwise from north [deg]")
@click.option("--side", type=click.Choice(["L", "R"]), default="R", show_default=True,
              help="side of the track the scene is on")
@_force
def export(in_file, out, fmt, track, latitude, longitude, heading, side, force):
    """Export a raw-data file (CPHD, CRSD) or an image file (SICD) to an NGA standard
    file through sarkit."""
    from .. import export as export_

    _check_output(out, force)
    run = _load(in_file, "Image" if fmt == "sicd" else "RawData")
    reference = export_.GeoReference(latitude=latitude, longitude=longitude,
                                      heading=heading, side_of_track=side)
    with _progress(1, f"export {fmt}") as bar:
        if fmt == "sicd":
            # ω-k records its weighting; back-projection keeps the antenna's
            weighting = run.attrs.get("focus_weighting") or (
                "antenna" if run.attrs.get("focus_method") == "backprojection" else "uniform")
            export_.to_sicd(run.product, out, run.radar, azimuth_weighting=weighting,
                            reference=reference, overwrite=force)
        else:
            writer = export_.to_cphd if fmt == "cphd" else export_.to_crsd
            writer(out, run.radar, run.product, run.motion, track=track,
                   reference=reference, overwrite=force)
        bar.update()
    click.echo(f"wrote {out} ({fmt.upper()}, "
               f"{'nominal' if fmt == 'sicd' else track} track)")


@cli.command(context_settings=_CONTEXT)
@click.argument("file", type=click.Path(dir_okay=False))
@_out_option("output PNG")
@click.option("--dynamic-range", type=float, default=50.0, show_default=True,
              help="image: dB below the peak shown")
@click.option("--zoom", default="targets", show_default=True, metavar="targets|K|X0,X1,R0,R1",
              help="image: the window shown, square in metres: around the file's point "
                   "targets, around target K (0-based), a window in metres, or 'full'")
@_force
def plot(file, out, dynamic_range, zoom, force):
    """Plot a file: raw data (amplitude and phase) or an image (dB, grey, axes in metres)."""
    from .. import plot as plot_
    from ..export._common import atomic_write

    _check_output(out, force)
    run = _load(file, None)
    if type(run.product).__name__ == "RawData":
        fig = plot_.raw_amplitude_phase(run.product)
    else:
        window = _zoom_window(zoom, run)
        fig = plot_.image_db(run.product, dynamic_range=dynamic_range, zoom=window,
                             aspect="auto" if window is None else "equal")
    atomic_write(Path(out), lambda tmp: fig.savefig(tmp, format="png", dpi=110,
                                                    bbox_inches="tight"), overwrite=force)
    click.echo(f"wrote {out}")


ZOOM_HALF_WIDTH = 40.0  # [m] shown on each side of a target (about 13 range cells at 3 m)


def _zoom_window(zoom, run):
    """((x0, x1), (r0, r1)) [m] of ``--zoom`` (None: the whole image), square in metres
    and clipped to the image."""
    import numpy as np

    from ..scene import PointTargets

    image = run.product
    az, rg = np.asarray(image.azimuth, float), np.asarray(image.range, float)
    text = zoom.strip().lower()
    if text == "full":
        return None
    if "," in text:
        try:
            x0, x1, r0, r1 = (float(v) for v in text.split(","))
        except ValueError:
            raise Fail(f"--zoom {zoom!r}: expected X0,X1,R0,R1 in metres") from None
        if not (x0 < x1 and r0 < r1):
            raise Fail(f"--zoom {zoom!r}: expected X0 < X1 and R0 < R1")
        return (x0, x1), (r0, r1)
    scene = run.scene
    if not isinstance(scene, PointTargets):
        if text == "targets":
            return None  # no targets to centre on: the whole image
        raise Fail(f"--zoom {zoom!r}: the file holds no point targets")
    xs, rs = np.asarray(scene.azimuth, float), np.asarray(scene.range, float)
    if text != "targets":
        try:
            k = int(text)
        except ValueError:
            raise Fail(f"--zoom {zoom!r}: expected 'targets', 'full', a target index or "
                       "X0,X1,R0,R1") from None
        if not 0 <= k < xs.size:
            raise Fail(f"--zoom {k}: the file holds targets 0 … {xs.size - 1}")
        xs, rs = xs[k:k + 1], rs[k:k + 1]
    centre_x, centre_r = (xs.min() + xs.max()) / 2, (rs.min() + rs.max()) / 2
    half = max(xs.max() - xs.min(), rs.max() - rs.min()) / 2 + ZOOM_HALF_WIDTH
    x0, x1 = max(centre_x - half, az[0]), min(centre_x + half, az[-1])
    r0, r1 = max(centre_r - half, rg[0]), min(centre_r + half, rg[-1])
    if not (x0 < x1 and r0 < r1):
        return None  # the targets lie outside the image: show all of it
    return (x0, x1), (r0, r1)


# ---- campaign ---------------------------------------------------------------------------


class _UnitProgress:
    """``progress(done, total)`` of :func:`sarjax.campaign.run`: a bar with its ETA on a
    terminal, log lines with the time left otherwise."""

    def __init__(self):
        self.bar, self.start, self.first = None, time.perf_counter(), None

    def __call__(self, done, total):
        if self.first is None:  # units finished before this run (resumed)
            self.first = done
            if sys.stderr.isatty():
                from tqdm import tqdm

                self.bar = tqdm(total=total, initial=done, desc="campaign", unit="unit",
                                file=sys.stderr, leave=False)
            return
        if self.bar is not None:
            self.bar.update(done - self.bar.n)
            return
        elapsed = time.perf_counter() - self.start
        ran = done - self.first
        left = elapsed / ran * (total - done) if ran else float("nan")
        click.echo(f"sarjax: campaign: unit {done}/{total} done after {elapsed:.1f} s, "
                   f"about {left:.0f} s left", err=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()


@cli.command(context_settings=_CONTEXT)
@click.argument("config", type=click.Path(dir_okay=False))
@click.option("-o", "--out", required=True, type=click.Path(),
              help="the campaign's Zarr store (a folder); rerunning resumes it")
@click.option("--set", "overrides", multiple=True, metavar="SECTION.KEY=VALUE",
              help="override a configuration entry (repeatable), e.g. campaign.unit=4")
@click.option("--png", type=click.Path(dir_okay=False), default=None,
              help="also plot the validity map (NMSE against deviation rms) or, for a "
                   "fit campaign, the fits' errors against the Cramér–Rao bound")
def campaign(config, out, overrides, png):
    """Run (or resume) a campaign into a resumable Zarr store and print its summary: a
    validity map (each method of [campaign] against the exact model over deviation rms,
    squint and realizations) or, with kind = "fit", a Monte Carlo of motion fits against
    the Cramér–Rao bound over deviation rms, SNR and realizations."""
    from .. import campaign as campaign_

    cfg = load_config(config, overrides)
    spec = campaign_config(cfg)
    progress = _UnitProgress()
    try:
        ran = campaign_.run(spec, out, progress=progress)
    finally:
        progress.close()
    if _one_writer() is False:  # one summary, from process 0 of a multi-process run
        return
    dataset = campaign_.load(out)
    click.echo(f"{out}: {spec.num_scenarios} scenarios in {spec.num_units} units "
               f"({ran} run by this call)")
    click.echo(campaign_.summary(dataset))
    if png:
        from .. import plot

        _check_output(png, True)
        if "nmse_db" in dataset:
            plot.validity_map(dataset, path=png)
        else:
            plot.fit_monte_carlo(dataset, path=png)


# ---- launch -----------------------------------------------------------------------------


@cli.command(context_settings=dict(_CONTEXT, ignore_unknown_options=True))
@click.option("-n", "--num-processes", type=click.IntRange(min=1), default=2,
              show_default=True, help="local processes of the run")
@click.option("--devices-per-process", type=click.IntRange(min=1), default=None,
              help="forced CPU devices in each process (default: XLA's, one on a CPU)")
@click.argument("command", nargs=-1, type=click.UNPROCESSED, required=True)
def launch(num_processes, devices_per_process, command):
    """Run another sarjax command as one multi-process JAX run on this machine:
    'sarjax launch -n 2 -- campaign study.toml -o study.zarr'. Each process runs the
    command (it joins the run through its environment, sarjax.distributed.initialize);
    a campaign shares its units out over them; simulate runs on the devices of all of
    them (process 0 writes the file).
    Exits with the first non-zero status of the processes. On a cluster, start the
    processes with the scheduler instead ('srun sarjax campaign ...')."""
    from .. import distributed

    status = distributed.launch(["-m", "sarjax.cli", *command], num_processes,
                                devices_per_process=devices_per_process)
    if status:
        raise click.exceptions.Exit(status)
