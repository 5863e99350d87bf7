"""Accuracy of an approximate simulator against the exact time-domain model.

"Accurate" (the issue's definition), for one point target per simulation, both raw data
focused by the same ω-k focuser with first- and second-order motion compensation:

* focused-image NMSE within ±16 cells of the target ≤ −25 dB;
* azimuth and range IRW within 1 % of the reference's;
* azimuth and range PSLR and ISLR within 0.3 dB of the reference's;
* raw-data phase error rms ≤ π/20 where the reference raw amplitude is within 20 dB of
  its maximum.

The exact reference (raw crop, focused crop and point-target metrics) and each method's
figures are cached by the content of (radar, scene, motion[, method]), so tests that
share a case share the work. Only crops of the reference are kept (a full 1941 × 830
complex128 raw/image pair is 52 MB; the full calibration grid has 144 references).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import warnings

import jax
import numpy as np

import sarjax as sj
from sarjax.metrics import nmse_db_near, phase_error_rms

RADAR = sj.presets.airborne_xband()
AZIMUTH = (np.arange(RADAR.num_pulses) - (RADAR.num_pulses - 1) / 2) * float(
    RADAR.azimuth_spacing
)
RANGES = (4840.0, 5140.0, 5440.0)
FOOTPRINT = 171.0  # λ r / L at the far target (5440 m): the aperture of smooth_deviation
PROFILES = {"slow": 0.3, "fast": 2.0}  # max_cycles per footprint

# the "accurate"
NMSE_DB = -25.0
IRW_RELATIVE = 0.01
SIDELOBE_DB = 0.3
PHASE_RMS = math.pi / 20
WITHIN_DB = 20.0
CELLS = 16

_CROP = 48  # image crop half-size [samples]: > CELLS and room for the metric windows
# the focuser's azimuth weighting: "uniform" (sj.focus's default: PRF band equalised,
# PSLR ≈ −13.5 dB as in seed 000 Table 3) or "antenna" (natural sinc² taper, azimuth
# PSLR ≈ −39.6 dB, where 0.3 dB is a −60 dB error)
WEIGHTING = "uniform"


def single_target(range_, azimuth=0.0):
    """One unit point target."""
    return sj.PointTargets(azimuth=[azimuth], range=[range_], reflectivity=[1.0])


def make_motion(rms, profile="slow", fraction=0.05, *, max_cycles=None, seed=7,
                radar=RADAR, azimuth=AZIMUTH):
    """Smooth random Δy and Δz, each of rms ``rms`` [m] (same seeds for every rms, so a
    row of the grid is one shape scaled), and the seed 000 sinusoidal pointing jitter with
    δ_m = ``fraction`` λ/L, T_b = T_s/10 (``fraction`` None or 0: no pointing error)."""
    cycles = PROFILES[profile] if max_cycles is None else max_cycles
    dy = dz = None
    if rms:
        dy = sj.smooth_deviation(azimuth, key=seed, rms=rms, max_cycles=cycles,
                                 aperture=FOOTPRINT)
        dz = sj.smooth_deviation(azimuth, key=seed + 1000, rms=rms, max_cycles=cycles,
                                 aperture=FOOTPRINT)
    pointing = (sj.seed_pointing_jitter(radar, azimuth, amplitude_fraction=fraction)
                if fraction else None)
    return sj.Motion(horizontal=dy, vertical=dz, pointing=pointing)


def digest(*objects) -> str:
    """Content hash of strings and pytrees (array leaves by value)."""
    h = hashlib.sha1()
    for obj in objects:
        if isinstance(obj, str):
            h.update(obj.encode())
            continue
        leaves, treedef = jax.tree_util.tree_flatten(obj)
        h.update(str(treedef).encode())
        for leaf in leaves:
            a = np.asarray(leaf)
            h.update(f"{a.dtype}{a.shape}".encode())
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def _crop_image(image, azimuth, range_, half=_CROP):
    """The focused image within ±half samples of the sample nearest (azimuth, range)."""
    az = np.asarray(image.azimuth)
    rg = np.asarray(image.range)
    ia = int(np.argmin(np.abs(az - azimuth)))
    ir = int(np.argmin(np.abs(rg - range_)))
    sa = slice(max(0, ia - half), min(az.size, ia + half + 1))
    sr = slice(max(0, ir - half), min(rg.size, ir + half + 1))
    return sj.Image(data=np.asarray(image.data)[sa, sr], azimuth=az[sa], range=rg[sr])


def _bright_box(data, within_db=WITHIN_DB):
    """Bounding slices of the samples within ``within_db`` of the maximum (the support of
    :func:`phase_error_rms`'s mask)."""
    mag = np.abs(data)
    mask = mag >= mag.max() * 10.0 ** (-within_db / 20.0)
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


def _metrics(image, azimuth, range_, half_window):
    try:
        return sj.point_target_metrics(image, azimuth=azimuth, range=range_,
                                       half_window=half_window)
    except ValueError:  # defocused beyond the metric window: no sidelobe structure
        return None


@dataclasses.dataclass(frozen=True)
class Reference:
    """What the comparison needs of the exact model (crops only)."""

    raw_box: tuple
    raw_crop: np.ndarray
    image_crop: sj.Image
    metrics: object  # PointTargetMetrics, or None when even the reference is unmeasurable
    half_window: int


@dataclasses.dataclass(frozen=True)
class Accuracy:
    """Measured figures of one method against the exact model, for one target.

    ``d_irw_*`` are relative (test/ref − 1), ``d_pslr_*`` and ``d_islr_*`` in dB
    (test − ref); NaN where a metric could not be measured. ``failures`` names each
    violated criterion; ``accurate`` is True when there is none.
    """

    method: str
    azimuth: float
    range: float
    nmse_db: float
    phase_rms: float
    d_irw_azimuth: float
    d_irw_range: float
    d_pslr_azimuth: float
    d_pslr_range: float
    d_islr_azimuth: float
    d_islr_range: float
    failures: tuple
    accurate: bool

    def summary(self) -> str:
        return (f"NMSE {self.nmse_db:7.1f} dB  phase {self.phase_rms:7.4f} rad  "
                f"dIRW az/rg {100 * self.d_irw_azimuth:+6.2f}/{100 * self.d_irw_range:+6.2f} %  "
                f"dPSLR {self.d_pslr_azimuth:+6.2f}/{self.d_pslr_range:+6.2f}  "
                f"dISLR {self.d_islr_azimuth:+6.2f}/{self.d_islr_range:+6.2f} dB  "
                f"{'ACCURATE' if self.accurate else 'inaccurate: ' + ', '.join(self.failures)}")


def reference_of(radar, ref_raw, ref_image, azimuth, range_) -> Reference:
    """Crops and metrics of the exact model's raw data and focused image."""
    ref_data = np.asarray(ref_raw.data)
    box = _bright_box(ref_data)
    half_window = 32
    metrics = _metrics(ref_image, azimuth, range_, half_window)
    if metrics is None:  # the reference itself defocused (large motion): a wider window
        half_window = 128
        metrics = _metrics(ref_image, azimuth, range_, half_window)
    return Reference(box, ref_data[box], _crop_image(ref_image, azimuth, range_),
                     metrics, half_window)


def compare(test_raw, test_image, ref: Reference, azimuth, range_, method="") -> Accuracy:
    """The issue's accuracy criteria of a focused test image and its raw data."""
    test_data = np.asarray(test_raw.data)
    phase = phase_error_rms(test_data[ref.raw_box], ref.raw_crop, within_db=WITHIN_DB)
    nmse = nmse_db_near(_crop_image(test_image, azimuth, range_), ref.image_crop,
                        azimuth=azimuth, range=range_, cells=CELLS)
    failures = []
    if not nmse <= NMSE_DB:
        failures.append(f"NMSE {nmse:.1f} dB > {NMSE_DB}")
    if not phase <= PHASE_RMS:
        failures.append(f"phase rms {phase:.3f} > π/20")
    nan = float("nan")
    deltas = dict(d_irw_azimuth=nan, d_irw_range=nan, d_pslr_azimuth=nan,
                  d_pslr_range=nan, d_islr_azimuth=nan, d_islr_range=nan)
    if ref.metrics is None:
        failures.append("reference not measurable (IRW/PSLR/ISLR)")
    else:
        got = _metrics(test_image, azimuth, range_, ref.half_window)
        if got is None:
            failures.append("test image not measurable (defocused)")
        else:
            want = ref.metrics
            for axis in ("azimuth", "range"):
                d = getattr(got, f"irw_{axis}") / getattr(want, f"irw_{axis}") - 1
                deltas[f"d_irw_{axis}"] = d
                if not abs(d) <= IRW_RELATIVE:
                    failures.append(f"IRW {axis} {100 * d:+.2f} %")
                for kind in ("pslr", "islr"):
                    d = getattr(got, f"{kind}_{axis}") - getattr(want, f"{kind}_{axis}")
                    deltas[f"d_{kind}_{axis}"] = d
                    if not abs(d) <= SIDELOBE_DB:
                        failures.append(f"{kind.upper()} {axis} {d:+.2f} dB")
    return Accuracy(method=method, azimuth=float(azimuth), range=float(range_),
                    nmse_db=float(nmse), phase_rms=float(phase), failures=tuple(failures),
                    accurate=not failures, **deltas)


_REFERENCES: dict[str, Reference] = {}
_RESULTS: dict[str, Accuracy] = {}


def focus(radar, raw, motion, weighting=None):
    """The one focuser used for test and reference: ω-k, 1st + 2nd-order MoCo. Its own
    accuracy does not enter (both images are focused alike), so its FocusWarning at
    metre-level motion (``moco_aperture_phase``) is not this comparison's."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sj.FocusWarning)
        return sj.focus(radar, raw, motion=motion, azimuth_weighting=weighting or WEIGHTING)


_RAW: dict[str, object] = {}  # the last simulated raw data per key (for re-focusing)


def reference(radar, scene_target, motion, weighting=None) -> Reference:
    """The exact time-domain reference of one target (cached by content)."""
    weighting = weighting or WEIGHTING
    key = digest(radar, scene_target, motion, weighting)
    if key not in _REFERENCES:
        x = float(np.asarray(scene_target.azimuth)[0])
        r = float(np.asarray(scene_target.range)[0])
        raw = sj.simulate(radar, scene_target, motion, method="time_domain")
        image = focus(radar, raw, motion, weighting)
        _REFERENCES[key] = reference_of(radar, raw, image, x, r)
    return _REFERENCES[key]


def accuracy(radar, scene_target, motion, method, weighting=None) -> Accuracy:
    """Figures of ``method`` against the exact model for a one-target scene (cached)."""
    if np.asarray(scene_target.azimuth).shape != (1,):
        raise ValueError("accuracy() takes a one-target scene (the issue's definition)")
    weighting = weighting or WEIGHTING
    key = digest(radar, scene_target, motion, method, weighting)
    if key not in _RESULTS:
        ref = reference(radar, scene_target, motion, weighting)
        x = float(np.asarray(scene_target.azimuth)[0])
        r = float(np.asarray(scene_target.range)[0])
        raw_key = digest(radar, scene_target, motion, method)
        raw = _RAW.get(raw_key)
        if raw is None:
            raw = sj.simulate(radar, scene_target, motion, method=method)
            _RAW.clear()  # keep only the latest (52 MB each)
            _RAW[raw_key] = raw
        image = focus(radar, raw, motion, weighting)
        _RESULTS[key] = compare(raw, image, ref, x, r, method=method)
    return _RESULTS[key]


def forget(radar, scene_target, motion, method, weighting=None):
    """Drop :func:`accuracy`'s cached figures and raw data of one case, so that its next
    call simulates (and warns) again."""
    _RESULTS.pop(digest(radar, scene_target, motion, method, weighting or WEIGHTING), None)
    _RAW.pop(digest(radar, scene_target, motion, method), None)


def forget_references():
    """Drop the cached references (the full grid keeps one motion's at a time)."""
    _REFERENCES.clear()
