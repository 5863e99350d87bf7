"""SICD 1.4.0 export of focused images (complex, slant plane, through sarkit)."""

from __future__ import annotations

import types

import numpy as np

from .._files import atomic_write
from ..constants import SPEED_OF_LIGHT
from ._common import collection, quiet_sarkit, require, scalar
from ._frame import GeoReference

SICD_NAMESPACE = "urn:SICD:1.4.0"
WEIGHTINGS = ("uniform", "antenna")
KAPFAC = 0.8859  # 3 dB width × bandwidth of a uniformly weighted impulse response


def _axis(values, name: str) -> tuple[np.ndarray, float]:
    """A uniform, increasing image axis and its spacing [m]."""
    values = np.asarray(values, float)
    if values.ndim != 1 or values.size < 2:
        raise ValueError(f"image.{name} has shape {values.shape}; at least 2 samples needed")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"image.{name} holds non-finite values")
    step = np.diff(values)
    if step[0] <= 0 or not np.allclose(step, step[0], rtol=1e-9, atol=0):
        raise ValueError(f"image.{name} spacing {step[0]!r} m must be positive and uniform")
    return values, float(step[0])


def azimuth_impulse_response(radar, bandwidth: float, weighting: str,
                             pattern_floor: float = 0.05, samples: int = 4096):
    """3 dB width [m] of the azimuth impulse response over the processed band.

    The column spectrum k ∈ [−B/2, B/2] [cycles/m] carries the two-way pattern at its
    stationary point W²(u*), ``u* = −ξL / (λ√(k₀² − ξ²))``, ξ = 2πk; ``"uniform"``
    divides it by max(W², ``pattern_floor``) as sarjax's ω-k does.

    Returns:
        (3 dB width of |IPR|² [m], the weight (samples,) on the band).
    """
    k = (np.arange(samples) + 0.5) / samples * bandwidth - 0.5 * bandwidth
    xi = 2 * np.pi * k
    k0 = float(radar.wavenumber)
    u_star = -xi * float(radar.antenna_length) / (
        float(radar.wavelength) * np.sqrt(k0**2 - xi**2))
    weight = np.asarray(radar.pattern(u_star), float)
    if weighting == "uniform":
        weight = weight / np.maximum(weight, pattern_floor)
    n_fft = 64 * samples
    ipr = np.abs(np.fft.fftshift(np.fft.fft(weight, n_fft))) ** 2
    ipr /= ipr.max()
    centre = int(np.argmax(ipr))
    above = ipr >= 0.5
    right = centre + int(np.argmin(above[centre:]))
    left = centre - int(np.argmin(above[centre::-1]))

    def crossing(i, j):  # linear interpolation of the 0.5 crossing between i and j
        return i + (ipr[i] - 0.5) / (ipr[i] - ipr[j]) * (j - i)

    width_bins = crossing(right - 1, right) - crossing(left + 1, left)
    return width_bins / (n_fft * bandwidth / samples), weight


def to_sicd(image, path, radar, *, track_azimuth=None, azimuth_weighting: str = "uniform",
            reference: GeoReference | None = None, core_name: str = "sarjax",
            classification: str = "UNCLASSIFIED", overwrite: bool = False):
    """Write a focused image as a SICD 1.4.0 NITF (complex float32, slant plane).

    Geometry:

    * **Image formation: RMA, image type INCA, grid RGZERO.** sarjax's focusers (ω-k and
      back-projection) put a target at its closest-approach coordinates (x, r): along the
      nominal straight track and slant range at zero Doppler. That is the SICD
      range/Doppler-zero grid of the range-migration algorithm (RMA with INCA
      parameters: rows in slant range at closest approach, columns along the track),
      not a polar-format (PFA, a fixed-point k-space grid) or a range/azimuth compressed
      one (RgAzComp, a spotlight grid). ``RMAlgoType`` is OMEGA_K; a back-projected image
      on the same (x, r) grid shares the geometry.
    * **Frame**: the flat scene is placed on the Earth as by :func:`to_cphd` of the same
      run (same :class:`GeoReference`, same reference point: the ground point at the
      reference range abeam the middle pulse), so a pixel at (x, r) is the ECF point of
      the local ground point (x, √(r² − H²), 0), and the SCP lies on the CPHD's
      reference surface.
    * **Track**: the image is formed on the nominal straight track (motion compensated
      by ω-k, or followed by back-projection), so ``Position/ARPPoly`` is that line,
      (x'₀ + v t, 0, H), linear in t and exact. Time t from the first pulse (the
      collection start).
    * **Pixels**: rows are slant range (increasing r), columns along the track
      (increasing x for ``side_of_track="R"``, decreasing for ``"L"`` so the slant-plane
      normal points away from the Earth, as SICD requires). The array written is
      ``image.data.T`` (columns reversed for ``"L"``), complex64 (RE32F_IM32F).
    * **Grid**: row spacing Δr, column spacing Δx (the image axes). Row bandwidth
      2Δf/c [cycles/m] (the chirp band), uniform weighting; column bandwidth 1/Δx (the
      whole PRF band, which ω-k processes), weighting the two-way antenna pattern
      (``azimuth_weighting="antenna"``) or its floored equalisation (``"uniform"``, as
      ``focus(azimuth_weighting=...)``), with the 3 dB width computed from that weight.
      On the pulse grid (Δx = v/PRF) the columns are critically sampled, which the
      checker reports as the one warning "Col OSR >= 1.1".
    * Rows nearer than the platform height (``r ≤ H``) are left out: no ground point
      lies at such a slant range, so they hold no echo and have no ground position (the
      airborne preset's window starts at 3896 m, 104 m short of H = 4000 m).

    Args:
        image: :class:`~sarjax.Image`, data (azimuth, range) complex, on uniform axes
            x [m] (increasing) and closest-approach slant range r [m] (increasing).
        path: destination file (written atomically), e.g. ``out.nitf``.
        radar: the :class:`~sarjax.Radar` of the acquisition (broadside).
        track_azimuth: (pulse,) positions x' [m] of the raw data's pulses (they fix the
            reference point and the collection time; default ``image.azimuth``: the grid
            ω-k and the default back-projection focus onto).
        azimuth_weighting: ``"uniform"`` or ``"antenna"`` (the focusing's weighting).
        reference: where and when (default :class:`GeoReference()`).
        core_name, classification: CollectionInfo fields.
        overwrite: replace an existing file.

    Returns:
        The path.
    """
    lxml_etree = require("lxml.etree")
    sksicd = require("sarkit.sicd")
    reference = GeoReference() if reference is None else reference
    if azimuth_weighting not in WEIGHTINGS:
        raise ValueError(f"azimuth_weighting={azimuth_weighting!r}; choose one of "
                         f"{WEIGHTINGS}")
    if not classification:
        raise ValueError(f"classification={classification!r} must not be empty")
    data = np.asarray(image.data)
    if data.ndim != 2 or not np.iscomplexobj(data):
        raise ValueError(f"image.data must be 2-D complex (azimuth, range), got "
                         f"{data.shape}, {data.dtype}")
    if not np.all(np.isfinite(data)):
        raise ValueError("image.data holds non-finite samples")
    x, dx = _axis(image.azimuth, "azimuth")
    r, dr = _axis(image.range, "range")
    if data.shape != (x.size, r.size):
        raise ValueError(f"image.data shape {data.shape} does not match the axes "
                         f"({x.size}, {r.size})")
    if scalar(radar.squint, "radar.squint") != 0.0:
        # the image's grid is written as RMA/INCA at zero Doppler (RGZERO); a squinted
        # focus needs the Doppler-centroid polynomials, which are not written
        raise ValueError(f"radar.squint={float(radar.squint)} ≠ 0: SICD export writes "
                         "broadside (zero-Doppler) images only; export the raw data "
                         "(to_cphd, to_crsd) for squinted acquisitions")
    height = scalar(radar.height, "radar.height")
    ground = int(np.searchsorted(r, height, side="right"))  # first row beyond the height
    if ground >= r.size:
        raise ValueError(f"image.range ends at {r[-1]} m, not beyond radar.height="
                         f"{height} m: no row sees the ground")
    data, r = data[:, ground:], r[ground:]  # nearer rows hold no echo: no ground there
    pulses = x if track_azimuth is None else np.asarray(track_azimuth, float)
    geo = collection(radar, types.SimpleNamespace(azimuth=pulses), None, "nominal",
                     reference)
    velocity = scalar(radar.velocity, "radar.velocity")
    if velocity <= 0:
        raise ValueError(f"radar.velocity={velocity} m/s must be positive")
    _axis(pulses, "track_azimuth")  # uniform and increasing
    f0 = scalar(radar.carrier_frequency, "radar.carrier_frequency")
    bandwidth = scalar(radar.bandwidth, "radar.bandwidth")
    frame = geo.frame

    def ground(xs, rs):  # local ground point of image coordinates (x, r)
        xs, rs = np.broadcast_arrays(np.asarray(xs, float), np.asarray(rs, float))
        return np.stack([xs, np.sqrt((rs - height) * (rs + height)), np.zeros(xs.shape)],
                        axis=-1)

    # columns along the track, or against it, so that uRow × uCol points up
    n_az, n_r = data.shape
    i_scp_r, i_scp_c = n_r // 2, n_az // 2
    along = frame.axes[0]
    x0 = float(pulses[0])
    arp0 = frame.to_ecf([x0, 0.0, height])

    def arp(xs):
        return frame.to_ecf(np.stack([np.asarray(xs, float), np.zeros(np.shape(xs)),
                                      np.full(np.shape(xs), height)], axis=-1))

    # the flip depends on the side only (any pixel's line of sight decides it)
    look = frame.to_ecf(ground(x[0], r[0])) - arp(x[0])
    flip = float(np.dot(np.cross(look, along), frame.up)) < 0
    sign = -1.0 if flip else 1.0
    col_x = x[::-1] if flip else x
    x_scp, r_scp = float(col_x[i_scp_c]), float(r[i_scp_r])
    scp = frame.to_ecf(ground(x_scp, r_scp))
    u_row = _unit(scp - arp(x_scp))  # at closest approach: ⊥ the track
    u_col = sign * along
    t_scp = (x_scp - x0) / velocity
    prf = scalar(radar.prf, "radar.prf")
    duration = pulses.size / prf  # to the end of the last pulse interval

    row_bw = 2 * bandwidth / SPEED_OF_LIGHT
    col_bw = 1.0 / dx
    col_width, _ = azimuth_impulse_response(radar, col_bw, azimuth_weighting)
    pixels = np.ascontiguousarray((data[::-1] if flip else data).T.astype(np.complex64))

    wgs84 = require("sarkit.wgs84")
    corners_rc = [(0, 0), (0, n_az - 1), (n_r - 1, n_az - 1), (n_r - 1, 0)]
    corner_ecf = frame.to_ecf(ground([col_x[c] for _, c in corners_rc],
                                     [r[i] for i, _ in corners_rc]))
    corner_llh = wgs84.cartesian_to_geodetic(corner_ecf)

    root = lxml_etree.Element(f"{{{SICD_NAMESPACE}}}SICD", nsmap={None: SICD_NAMESPACE})
    with quiet_sarkit():
        xml = sksicd.ElementWrapper(root)
        xml["CollectionInfo"] = {
            "CollectorName": "sarjax", "CoreName": core_name, "CollectType": "MONOSTATIC",
            "RadarMode": {"ModeType": "STRIPMAP"}, "Classification": classification,
        }
        xml["ImageData"] = {
            "PixelType": "RE32F_IM32F", "NumRows": n_r, "NumCols": n_az,
            "FirstRow": 0, "FirstCol": 0,
            "FullImage": {"NumRows": n_r, "NumCols": n_az},
            "SCPPixel": [i_scp_r, i_scp_c],
            "ValidData": np.array(corners_rc),
        }
        xml["GeoData"] = {
            "EarthModel": "WGS_84",
            "SCP": {"ECF": scp, "LLH": wgs84.cartesian_to_geodetic(scp)},
            "ImageCorners": corner_llh[:, :2],
            "ValidData": corner_llh[:, :2],
        }
        xml["Grid"] = {
            "ImagePlane": "SLANT", "Type": "RGZERO",
            "TimeCOAPoly": np.array([[t_scp, sign / velocity]]),
            "Row": {"UVectECF": u_row, "SS": dr, "ImpRespWid":
                    KAPFAC / row_bw, "Sgn": -1, "ImpRespBW": row_bw,
                    "KCtr": 2 * f0 / SPEED_OF_LIGHT, "DeltaK1": -row_bw / 2,
                    "DeltaK2": row_bw / 2, "WgtType": {"WindowName": "UNIFORM"}},
            "Col": {"UVectECF": u_col, "SS": dx, "ImpRespWid": col_width, "Sgn": -1,
                    "ImpRespBW": col_bw, "KCtr": 0.0, "DeltaK1": -col_bw / 2,
                    "DeltaK2": col_bw / 2,
                    "WgtType": {"WindowName": "ANTENNA_PATTERN" if azimuth_weighting
                                == "antenna" else "EQUALISED_ANTENNA_PATTERN"}},
        }
        xml["Timeline"] = {
            "CollectStart": reference.collection_start, "CollectDuration": duration,
            "IPP": {"Set": [{"TStart": 0.0, "TEnd": duration, "IPPStart": 0,
                             "IPPEnd": pulses.size - 1,
                             "IPPPoly": np.array([0.0, prf])}]},
        }
        xml["Position"] = {"ARPPoly": np.stack([arp0, velocity * along])}
        tau = float(radar.chirp_duration)
        fs = float(radar.sampling_rate)
        xml["RadarCollection"] = {
            "TxFrequency": {"Min": f0 - bandwidth / 2, "Max": f0 + bandwidth / 2},
            "Waveform": {"WFParameters": [{
                "TxPulseLength": tau, "TxRFBandwidth": bandwidth,
                "TxFreqStart": f0 + bandwidth / 2, "TxFMRate": -bandwidth / tau,
                "RcvDemodType": "CHIRP", "RcvWindowLength": n_r / fs,
                "ADCSampleRate": fs, "RcvIFBandwidth": bandwidth, "RcvFMRate": 0.0}]},
            "TxPolarization": "OTHER",
            "RcvChannels": {"ChanParameters": [{"TxRcvPolarization": "OTHER"}]},
        }
        xml["ImageFormation"] = {
            "RcvChanProc": {"NumChanProc": 1, "ChanIndex": [1]},
            "TxRcvPolarizationProc": "OTHER", "TStartProc": 0.0, "TEndProc": duration,
            "TxFrequencyProc": {"MinProc": f0 - bandwidth / 2, "MaxProc": f0 + bandwidth / 2},
            "ImageFormAlgo": "RMA", "STBeamComp": "NO", "ImageBeamComp": (
                "SV" if azimuth_weighting == "uniform" else "NO"),
            "AzAutofocus": "NO", "RgAutofocus": "NO",
        }
        xml["RMA"] = {
            "RMAlgoType": "OMEGA_K", "ImageType": "INCA",
            "INCA": {"TimeCAPoly": np.array([t_scp, sign / velocity]), "R_CA_SCP": r_scp,
                     "FreqZero": f0, "DRateSFPoly": np.array([[1.0]]),
                     "DopCentroidPoly": np.array([[0.0]]), "DopCentroidCOA": True},
        }
        for name in ("Set", "WFParameters", "ChanParameters"):
            for i, elem in enumerate(root.iter(f"{{{SICD_NAMESPACE}}}{name}"), start=1):
                elem.set("index", str(i))
                elem.getparent().set("size", str(i))
        tree = root.getroottree()
        _insert_scpcoa(sksicd, tree)
        _validate(lxml_etree, sksicd, tree)
        security = {"security": {"clas": classification[0]}}
        metadata = sksicd.NitfMetadata(
            xmltree=tree,
            file_header_part={"ostaid": "sarjax", "ftitle": core_name, **security},
            im_subheader_part={"isorce": "sarjax", **security},
            de_subheader_part=security,
        )

    def write(tmp):
        with quiet_sarkit(), open(tmp, "wb") as f, sksicd.NitfWriter(f, metadata) as writer:
            writer.write_image(pixels)

    return atomic_write(path, write, overwrite=overwrite)


def _unit(vector):
    vector = np.asarray(vector, float)
    return vector / np.linalg.norm(vector)


def _insert_scpcoa(sksicd, tree):
    """SCPCOA computed by sarkit from the other metadata, at its schema place (after
    ImageFormation)."""
    formation = tree.getroot().find(f"{{{SICD_NAMESPACE}}}ImageFormation")
    formation.addnext(sksicd.compute_scp_coa(tree))


def _validate(lxml_etree, sksicd, tree):
    schema = lxml_etree.XMLSchema(file=str(sksicd.VERSION_INFO[SICD_NAMESPACE]["schema"]))
    if not schema.validate(tree):
        raise RuntimeError(f"internal error: the SICD XML is not schema-valid: "
                           f"{schema.error_log.last_error}")
