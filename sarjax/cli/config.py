"""Configuration files (TOML) of ``sarjax simulate``: reading, checking, and the run they
describe.

Keys::

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

``--set section.key=value`` overrides any entry (value in TOML syntax);
``sarjax config --example`` prints :data:`EXAMPLE`, every key with its unit.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

from .._names import unknown_names

PRESETS = {"airborne": "airborne_xband", "cband": "spaceborne_cband",
           "highspeed": "highspeed_xband"}


EXAMPLE = """\
# sarjax simulate CONFIG.toml -o raw.nc   (every key is optional unless marked)
preset = "airborne"              # airborne | cband | highspeed (sarjax.presets)

[radar]                          # overrides of any Radar field, SI units
num_pulses = 1025                # pulses [-]
# num_range = 830                # range samples [-]
# near_range = 4900.0            # first sample's slant range [m]
# squint = 0.0                   # squint φ_d [rad]
# chirp_duration = 5e-6          # τ [s]

[scene]                          # point targets (azimuth and range required)
azimuth = [0.0, 0.0, 0.0]        # x [m]
range = [4840.0, 5140.0, 5440.0] # closest-approach slant range r [m]
reflectivity = [1.0, 1.0, 1.0]   # |γ| [-]
reflectivity_phase = 0.0         # arg γ [rad], one value or one per target
height = [0.0, 0.0, 0.0]         # h above the reference plane [m]

[motion]                         # absent: the ideal straight track
deviation_rms = 0.02             # smooth Δy, Δz rms [m] (sarjax.smooth_deviation)
max_cycles = 1.0                 # highest deviation cycles per footprint [-]
seed = 2017                      # random key of the deviations
jitter = 0.05                    # pointing jitter δ_m in units of λ/L (seed 000 eq. 55)
jitter_period = 0.1              # T_b in units of T_s

[simulate]
method = "auto"                  # time_domain | time_domain_nufft | fourier_2d |
                                 # small_deviation | moderate_deviation | chirp_scaling |
                                 # high_speed | auto (the fastest valid)
dtype = "complex128"             # or complex64
# num_pulses = 1025              # the window: pulses [-] (default: the radar's)
# num_range = 830                # range samples [-]
# near_range = 4900.0            # [m]
# azimuth_center = 0.0           # x' of the window's centre [m]
# strict = false                 # refuse instead of warning outside a validity budget

[campaign]                       # sarjax campaign CONFIG.toml -o study.zarr only
# kind = "validity"              # validity (methods vs the exact model) | fit (fit vs CRB)
# methods = ["fourier_2d", "small_deviation", "moderate_deviation"]  # validity
# deviation_rms = [0.0, 0.005, 0.02, 0.1]  # grid of Δy, Δz rms [m] ([motion] unused)
# squint_deg = [0.0]             # validity: grid of squints φ_d [deg]
# snr_db = [0.0, 10.0]           # fit: grid of raw SNR [dB]
# realizations = 1               # draws per grid point [-] (fit: 10)
# max_cycles = 1.0               # highest deviation cycles per footprint [-]
# unit = 8                       # scenarios per unit of work and Zarr chunk [-] (fit: 1)
"""

ACQUISITION_KEYS = ("num_pulses", "num_range", "near_range", "azimuth_center")
SCENE_KEYS = ("azimuth", "range", "reflectivity", "reflectivity_phase", "height")
MOTION_KEYS = ("deviation_rms", "max_cycles", "seed", "jitter", "jitter_period")


class Fail(Exception):
    """A handled failure: printed as one line, exit status 2."""


def load_config(path=None, overrides=()) -> dict:
    """Read a TOML configuration and apply ``section.key=value`` overrides."""
    config = {} if path is None else _read_toml(Path(path))
    for item in overrides:
        _apply_override(config, item)
    _check_sections(config)
    return config


def _read_toml(path):
    try:
        return tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise Fail(f"configuration {path} does not exist") from None
    except IsADirectoryError:
        raise Fail(f"configuration {path} is a folder, not a TOML file") from None
    except UnicodeDecodeError:
        raise Fail(f"configuration {path} is not a text (TOML) file") from None
    except tomllib.TOMLDecodeError as err:
        raise Fail(f"{path}: {err}") from None


def _apply_override(config, item):
    """Set the entry of one ``section.key=value`` override (value in TOML syntax, or a bare
    word taken as a string)."""
    key, sep, value = item.partition("=")
    if not sep or not key:
        raise Fail(f"--set {item!r}: expected section.key=value")
    try:
        parsed = tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value  # a bare word: take it as a string
    *sections, leaf = key.strip().split(".")
    node = config
    for section in sections:
        node = node.setdefault(section, {})
        if not isinstance(node, dict):
            raise Fail(f"--set {item!r}: {section!r} is not a table")
    node[leaf] = parsed


def _check_sections(config):
    known = {"preset", "radar", "scene", "motion", "simulate", "campaign"}
    unknown = set(config) - known
    if unknown:
        raise Fail(unknown_names("configuration entries", unknown, known))
    for section in known - {"preset"}:
        if not isinstance(config.get(section, {}), dict):
            raise Fail(f"[{section}] must be a table, got {section} = {config[section]!r}")


def number(name, value, *, integer=False, minimum=None, positive=False):
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


def numbers(name, value):
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

    radar = _radar(config)
    scene = _scene(config)
    sim = dict(config.get("simulate", {}))
    num_pulses = number("simulate.num_pulses", sim.pop("num_pulses", radar.num_pulses),
                        integer=True, positive=True)
    azimuth_center = number("simulate.azimuth_center", sim.get("azimuth_center", 0.0))
    x = azimuth_center + (np.arange(num_pulses) - (num_pulses - 1) / 2) * float(
        radar.azimuth_spacing)
    motion = _motion(config, radar, x)
    sim.setdefault("method", "time_domain")
    if not isinstance(sim["method"], str):
        raise ValueError(f"simulate.method={sim['method']!r} must be a method name")
    sim["num_pulses"] = num_pulses
    return radar, scene, motion, sim


def _radar(config):
    """The preset's radar with the ``[radar]`` overrides, checked."""
    from .. import _validate, presets

    preset = config.get("preset", "airborne")
    if not isinstance(preset, str) or preset not in PRESETS:
        raise ValueError(f"preset={preset!r}; choose one of {sorted(PRESETS)}")
    radar_cfg = dict(config.get("radar", {}))
    for key, value in radar_cfg.items():
        radar_cfg[key] = number(f"radar.{key}", value,
                                integer=key in ("num_pulses", "num_range"))
    radar = getattr(presets, PRESETS[preset])(**radar_cfg)
    _validate.check_radar(radar)  # before any number is derived from it
    return radar


def _scene(config):
    """The ``[scene]`` point targets."""
    import numpy as np

    from ..scene import PointTargets

    scene_cfg = dict(config.get("scene", {}))
    unknown = {key: value for key, value in scene_cfg.items() if key not in SCENE_KEYS}
    if unknown:  # first: a misspelt "azimuth" is answered with its correction
        raise ValueError(unknown_names("[scene] entries", unknown, SCENE_KEYS))
    if "azimuth" not in scene_cfg or "range" not in scene_cfg:
        raise ValueError("the configuration needs [scene] azimuth = [...] and range = [...]")
    azimuth = numbers("scene.azimuth", scene_cfg.pop("azimuth"))
    range_ = numbers("scene.range", scene_cfg.pop("range"))
    amplitude = (numbers("scene.reflectivity", scene_cfg.pop("reflectivity"))
                 if "reflectivity" in scene_cfg else np.ones(azimuth.size))
    phase = numbers("scene.reflectivity_phase", scene_cfg.pop("reflectivity_phase", 0.0))
    height = scene_cfg.pop("height", None)
    height = None if height is None else numbers("scene.height", height)
    if phase.size not in (1, amplitude.size):
        raise ValueError(f"scene.reflectivity_phase has {phase.size} values, "
                         f"scene.reflectivity {amplitude.size}")
    return PointTargets(azimuth=azimuth, range=range_,
                        reflectivity=amplitude * np.exp(1j * phase), height=height)


CAMPAIGN_KEYS = ("kind", "methods", "deviation_rms", "squint_deg", "snr_db",
                 "realizations", "max_cycles", "unit")
CAMPAIGN_KINDS = {"validity": ("methods", "squint_deg"), "fit": ("snr_db",)}


def campaign_config(config: dict):
    """The campaign of a configuration (:class:`sarjax.campaign.ValidityMap` or, with
    ``kind = "fit"``, :class:`sarjax.campaign.FitMonteCarlo`): its ``preset``,
    ``[radar]`` and ``[scene]``, and the axes of ``[campaign]``."""
    from ..campaign import FitMonteCarlo, ValidityMap

    radar = _radar(config)
    scene = _scene(config)
    table = dict(config.get("campaign", {}))
    unknown = {key: value for key, value in table.items() if key not in CAMPAIGN_KEYS}
    if unknown:
        raise ValueError(unknown_names("[campaign] entries", unknown, CAMPAIGN_KEYS))
    kind = table.pop("kind", "validity")
    if kind not in CAMPAIGN_KINDS:
        raise ValueError(f"campaign.kind={kind!r}; choose one of {sorted(CAMPAIGN_KINDS)}")
    for other, keys in CAMPAIGN_KINDS.items():
        foreign = [key for key in keys if key in table]
        if other != kind and foreign:
            raise ValueError(f"[campaign] {foreign} apply to kind = {other!r}, not {kind!r}")
    options = {}
    if "methods" in table:
        methods = table["methods"]
        if isinstance(methods, str):
            methods = [methods]
        if not (isinstance(methods, list) and all(isinstance(m, str) for m in methods)):
            raise ValueError(f"campaign.methods={methods!r} must be a list of method names")
        from ..simulators import simulator_class

        for name in methods:
            simulator_class(name)  # an unknown name is answered with the known ones
        options["methods"] = tuple(methods)
    for key in ("deviation_rms", "squint_deg", "snr_db"):
        if key in table:
            options[key] = tuple(float(v) for v in numbers(f"campaign.{key}", table[key]))
    if "realizations" in table:
        options["realizations"] = number("campaign.realizations", table["realizations"],
                                         integer=True, positive=True)
    if "unit" in table:
        options["unit"] = number("campaign.unit", table["unit"], integer=True, positive=True)
    if "max_cycles" in table:
        options["max_cycles"] = number("campaign.max_cycles", table["max_cycles"],
                                       positive=True)
    return (ValidityMap if kind == "validity" else FitMonteCarlo)(radar, scene, **options)


def _motion(config, radar, x):
    """The ``[motion]`` deviations and jitter on the pulses ``x``."""
    from ..motion import Motion, seed_pointing_jitter, smooth_deviation

    motion_cfg = dict(config.get("motion", {}))
    rms = number("motion.deviation_rms", motion_cfg.pop("deviation_rms", 0.0), minimum=0)
    cycles = number("motion.max_cycles", motion_cfg.pop("max_cycles", 1.0), positive=True)
    seed = number("motion.seed", motion_cfg.pop("seed", 2017), integer=True, minimum=0)
    jitter = number("motion.jitter", motion_cfg.pop("jitter", 0.0), minimum=0)
    period = number("motion.jitter_period", motion_cfg.pop("jitter_period", 0.1),
                    positive=True)
    if motion_cfg:
        raise ValueError(unknown_names("[motion] entries", motion_cfg, MOTION_KEYS))
    footprint = float(radar.footprint(radar.reference_range))
    return Motion(
        horizontal=smooth_deviation(x, key=seed, rms=rms, max_cycles=cycles,
                                    aperture=footprint) if rms else None,
        vertical=smooth_deviation(x, key=seed + 1, rms=rms, max_cycles=cycles,
                                  aperture=footprint) if rms else None,
        pointing=seed_pointing_jitter(radar, x, amplitude_fraction=jitter,
                                      period_fraction=period) if jitter else None,
    )


def simulate_config(config: dict):
    """Run a configuration through :func:`sarjax.simulate`; returns
    (raw, radar, scene, motion, attributes for the file)."""
    import numpy as np

    from .. import io
    from .._simulate import simulate

    radar, scene, motion, sim = build_run(config)
    sim = dict(sim)
    method, dtype = sim.pop("method"), sim.pop("dtype", "complex128")
    try:
        dtype = np.dtype(dtype)
    except TypeError:
        raise ValueError(f"simulate.dtype={dtype!r}: choose 'complex64' or 'complex128'") from None
    num_pulses = sim.pop("num_pulses")
    num_range = number("simulate.num_range", sim.pop("num_range", radar.num_range),
                       integer=True, positive=True)
    near_range = number("simulate.near_range", sim.pop("near_range", float(radar.near_range)),
                        positive=True)
    azimuth_center = number("simulate.azimuth_center", sim.pop("azimuth_center", 0.0))
    raw = simulate(radar, scene, None if motion.is_ideal else motion, method=method,
                   num_pulses=num_pulses, num_range=num_range, near_range=near_range,
                   azimuth_center=azimuth_center, dtype=dtype, **sim)
    attrs = io.simulate_attributes(method=raw.method, num_pulses=num_pulses,
                                   num_range=num_range, near_range=near_range,
                                   azimuth_center=azimuth_center, dtype=dtype, **sim)
    attrs["config_toml"] = json.dumps(config)
    return raw, radar, scene, (None if motion.is_ideal else motion), attrs
