"""CPHD 1.1.0 export (frequency domain, through sarkit)."""

from __future__ import annotations

import math

import numpy as np

from .._files import atomic_write
from .._numerics.interpolation import next_fast_len
from ..constants import SPEED_OF_LIGHT
from ..processing._range_compression import matched_filter
from ._common import (
    check_grid,
    collection,
    parameters,
    quiet_sarkit,
    receive_geometry,
    require,
    scalar,
    scene_area,
    two_way_delay,
)
from ._frame import GeoReference

CPHD_NAMESPACE = "http://api.nsgreg.nga.mil/schema/cphd/1.1.0"
_CHANNEL = "1"
_PVP_LAYOUT = (  # name, size in 8-byte words (CPHD 1.1.0 schema order)
    ("TxTime", 1), ("TxPos", 3), ("TxVel", 3), ("RcvTime", 1), ("RcvPos", 3), ("RcvVel", 3),
    ("SRPPos", 3), ("aFDOP", 1), ("aFRR1", 1), ("aFRR2", 1), ("FX1", 1), ("FX2", 1),
    ("TOA1", 1), ("TOA2", 1), ("TDTropoSRP", 1), ("SC0", 1), ("SCSS", 1),
)


def fx_fft_length(radar, num_range: int) -> int:
    """Range FFT length of the FX conversion: holds the N_r samples plus one chirp
    without wrap-around, 1.25× oversampled so the saved delay window keeps
    1 / (SCSS · (TOA2 − TOA1)) ≥ 1.2 (the CPHD recommendation)."""
    chirp = int(math.ceil(float(radar.chirp_samples)))
    return next_fast_len(int(math.ceil(1.25 * (num_range + chirp))))


def phase_history(radar, raw, srp_range, *, pulse_chunk: int = 256):
    """FX-domain phase history compensated to each pulse's scene reference point.

    For pulse p and frequency f = f₀ + f_r (|f_r| ≤ Δf/2)::

        S_p(f) = FFT_r'[h](f_r) · conj(chirp spectrum) · exp(−j k_r r'₀) · exp(+j 4π f R_srp,p / c)

    with k_r = 4π f_r / c, r'₀ the first range sample and f_r over the whole sampled band
    ±f_s/2 (the chirp band Δf and the skirts of its spectrum, as sarjax's own range
    compression keeps them): a scatterer at range R gives
    γ W² exp(−j 4π f (R − R_srp,p) / c) = γ W² exp(SGN · j 2π f ΔTOA), SGN = −1,
    ΔTOA = 2 (R − R_srp,p) / c.

    Returns:
        (signal (pulse, K) complex64, first frequency SC0 [Hz], spacing SCSS [Hz]).
    """
    data = np.asarray(raw.data)
    n_pulses, n_range = data.shape
    n_fft = fx_fft_length(radar, n_range)
    fs = scalar(radar.sampling_rate, "radar.sampling_rate")
    f0 = scalar(radar.carrier_frequency, "radar.carrier_frequency")
    bandwidth = scalar(radar.bandwidth, "radar.bandwidth")
    if bandwidth > fs:
        raise ValueError(f"radar.bandwidth={bandwidth} Hz exceeds the sampling rate {fs} Hz")
    f_r = np.fft.fftfreq(n_fft, 1 / fs)
    keep = np.argsort(f_r)  # the whole sampled band f₀ ± f_s/2, ascending
    f_r = f_r[keep]
    filt = np.asarray(matched_filter(radar, n_fft))[keep]
    k_r = 4 * np.pi * f_r / SPEED_OF_LIGHT
    k0 = 4 * np.pi * f0 / SPEED_OF_LIGHT
    near = float(np.asarray(raw.range)[0])
    out = np.empty((n_pulses, keep.size), np.complex64)
    for start in range(0, n_pulses, pulse_chunk):
        sl = slice(start, min(start + pulse_chunk, n_pulses))
        spectrum = np.fft.fft(data[sl], n=n_fft, axis=-1)[:, keep] * filt
        r = srp_range[sl, None]
        carrier = np.mod(k0 * r, 2 * np.pi)  # float64 reduction of the large term
        spectrum *= np.exp(1j * (carrier + k_r * (r - near)))
        out[sl] = spectrum
    return out, f0 + f_r[0], fs / n_fft


def to_cphd(path, radar, raw, motion=None, *, track: str = "true",
            reference: GeoReference | None = None, core_name: str = "sarjax",
            classification: str = "UNCLASSIFIED", release_info: str = "UNRESTRICTED",
            attrs: dict | None = None, overwrite: bool = False,
            stop_and_go: bool | None = None):
    """Write raw data as a CPHD 1.1.0 file (FX domain, one channel).

    Conventions (also written into the file's ``CollectionID/Parameter`` list):

    * **SGN = −1**: a scatterer at range R from the antenna gives the phase
      −2π f ΔTOA, ΔTOA = 2 (R − R_srp) / c, at every frequency f = SC0 + k·SCSS of the
      vector; SC0 … cover the chirp band f₀ ± Δf/2 (range compression by the matched
      filter, then the range spectrum, see :func:`phase_history`).
    * **Reference point**: each pulse's SRP is the ground point at closest-approach
      range r₀ on the beam centre, (x'_p + r₀ tan φ_d, √(r₀² − H²), 0) in sarjax's frame
      (abeam the pulse at broadside; a stripmap SRP that moves with the beam;
      ``SRPFixed`` false). The IARP is the SRP of the middle of
      the track; the reference surface is the plane tangent to the ellipsoid there
      (``Planar``), on which sarjax's flat ground lies exactly.
    * **Track**: ``track="true"`` (default) writes the actual antenna positions
      (x'_p, Δy_p, H + Δz_p) into TxPos/RcvPos, so any processor that uses the
      positions (back-projection) focuses the deviations away; ``"nominal"`` writes the
      straight track (x'_p, 0, H), and the deviations stay in the data as errors.
      The phase compensation to the SRP uses the positions written.
    * **Pulse timing**: TxTime_p = p / PRF from the collection start. With the
      stop-and-go echo model (one antenna position per pulse) RcvPos = TxPos and
      RcvTime = TxTime + 2 R_srp / c. Data simulated beyond stop-and-go (``high_speed``,
      or ``time_domain`` with ``stop_and_go=False``: the antenna moves on at v during
      the echo) have RcvTime = TxTime + τ_srp with c τ_srp = |TxPos − SRP| +
      |RcvPos − SRP|, RcvPos = TxPos + (v τ_srp, 0, 0) in sarjax's frame (the pulse's
      deviation held, as in the echo model), and ΔTOA is taken from τ_srp, so a
      processor that uses both legs matches the data's delays; aFDOP = aFRR1 = aFRR2 = 0
      (no fast-time Doppler in the model; the standard allows zeros); TDTropoSRP = 0
      (no atmosphere).
    * The flat sarjax frame is placed on the Earth by ``reference``
      (:class:`~sarjax.export.GeoReference`): x along ``heading``, y away from the track
      on ``side_of_track``, z along the ellipsoid normal at the IARP.

    Args:
        path: destination file (written atomically).
        radar: the :class:`~sarjax.Radar` of the acquisition.
        raw: :class:`~sarjax.RawData` (azimuth, range) on the radar's grid.
        motion: the :class:`~sarjax.Motion` the data were simulated with (None = ideal).
        track: ``"true"`` or ``"nominal"`` (see above).
        reference: where and when (default :class:`GeoReference()`).
        core_name, classification, release_info: CPHD identification fields.
        attrs: extra name → value pairs for the parameter list.
        overwrite: replace an existing file.
        stop_and_go: the echo model of ``raw`` (see Pulse timing); None: False for the
            output of ``method="high_speed"``, True otherwise.

    Returns:
        The path.
    """
    lxml_etree = require("lxml.etree")
    skcphd = require("sarkit.cphd")
    if stop_and_go is None:
        stop_and_go = raw.method != "high_speed"
    reference = GeoReference() if reference is None else reference
    check_grid(radar, raw)
    geo = collection(radar, raw, motion, track, reference)
    # one-way-equivalent SRP range c τ_srp / 2 and the antenna's receive positions
    srp_range, rcv_local = receive_geometry(radar, geo, stop_and_go)
    signal, sc0, scss = phase_history(radar, raw, srp_range)
    n_pulses, n_samples = signal.shape
    f0 = scalar(radar.carrier_frequency, "radar.carrier_frequency")
    bandwidth = float(radar.bandwidth)
    fs = float(radar.sampling_rate)
    tau = float(radar.chirp_duration)
    range_axis = np.asarray(raw.range, float)
    near, far = range_axis[0], range_axis[-1]
    half_chirp = SPEED_OF_LIGHT * tau / 4

    # ---- PVPs ----------------------------------------------------------------------
    apc, vel, srp = geo.apc_ecf, geo.velocity_ecf, geo.srp_ecf
    words = {name: size for name, size in _PVP_LAYOUT}
    dtype = np.dtype([(name, ">f8", (size,)) if size > 1 else (name, ">f8")
                      for name, size in _PVP_LAYOUT])
    pvp = np.zeros(n_pulses, dtype)
    pvp["TxTime"] = geo.tx_time
    pvp["TxPos"] = apc
    pvp["TxVel"] = vel
    pvp["RcvTime"] = geo.tx_time + two_way_delay(srp_range)
    pvp["RcvPos"] = geo.frame.to_ecf(rcv_local)
    pvp["RcvVel"] = vel
    pvp["SRPPos"] = srp
    pvp["FX1"] = sc0  # the whole sampled band f₀ ± f_s/2 (chirp band and its skirts)
    pvp["FX2"] = sc0 + (n_samples - 1) * scss
    # delays of the saved window (the raw window widened by the chirp half-lengths)
    pvp["TOA1"] = two_way_delay(near - half_chirp - srp_range)
    pvp["TOA2"] = two_way_delay(far + half_chirp - srp_range)
    pvp["SC0"] = sc0
    pvp["SCSS"] = scss

    area = scene_area(radar, raw, geo, reference)
    area.update(f0=f0, bandwidth=bandwidth, tau=tau, fs=fs)

    # ---- XML ---------------------------------------------------------------------------
    with quiet_sarkit():
        metadata = _metadata(
            lxml_etree, skcphd, reference, radar, raw, track, attrs, core_name,
            classification, release_info, pvp, words, n_pulses, n_samples, area,
            stop_and_go)

    def write(tmp):
        with open(tmp, "wb") as f, skcphd.Writer(f, metadata) as writer:
            writer.write_signal(_CHANNEL, np.ascontiguousarray(signal))
            writer.write_pvp(_CHANNEL, pvp)

    return atomic_write(path, write, overwrite=overwrite)


def _metadata(lxml_etree, skcphd, reference, radar, raw, track, attrs, core_name,
              classification, release_info, pvp, words, n_pulses, n_samples, v, stop_and_go):
    """The CPHD XML (``v``: the scene and band numbers of :func:`to_cphd`)."""
    f0, bandwidth, tau, fs = v["f0"], v["bandwidth"], v["tau"], v["fs"]
    x1, x2, y1, y2 = v["x1"], v["x2"], v["y1"], v["y2"]
    line_spacing, sample_spacing = v["line_spacing"], v["sample_spacing"]
    root = lxml_etree.Element(f"{{{CPHD_NAMESPACE}}}CPHD", nsmap={None: CPHD_NAMESPACE})
    xml = skcphd.ElementWrapper(root)
    params = parameters(radar, raw, track, {
        "reference.latitude_deg": reference.latitude, "reference.longitude_deg":
        reference.longitude, "reference.heading_deg": reference.heading,
        "convention.sgn": "-1: phase -2 pi f dTOA, dTOA = 2 (R - R_srp) / c",
        "convention.srp": "ground point at closest-approach range r0 on each pulse's beam "
                          "centre (abeam at broadside)",
        "convention.positions": (
            "stop-and-go: RcvPos = TxPos, the antenna of pulse p" if stop_and_go else
            "non-stop-and-go: RcvPos = TxPos + v tau_srp along the track"),
        "convention.frame": "local x along track, y away from the track, z up; "
                            "IARP = SRP of the mid-track time",
        **(attrs or {})})
    xml["CollectionID"] = {
        "CollectorName": "sarjax", "CoreName": core_name, "CollectType": "MONOSTATIC",
        "RadarMode": {"ModeType": "STRIPMAP"}, "Classification": classification,
        "ReleaseInfo": release_info,
    }
    root.find(f"{{{CPHD_NAMESPACE}}}CollectionID").extend(
        _parameters(lxml_etree, params))
    xml["Global"] = {
        "DomainType": "FX", "SGN": -1,
        "Timeline": {"CollectionStart": reference.collection_start,
                     "TxTime1": float(pvp["TxTime"][0]), "TxTime2": float(pvp["TxTime"][-1])},
        "FxBand": {"FxMin": float(pvp["FX1"].min()), "FxMax": float(pvp["FX2"].max())},
        "TOASwath": {"TOAMin": float(pvp["TOA1"].min()), "TOAMax": float(pvp["TOA2"].max())},
    }
    polygon = v["polygon"]
    xml["SceneCoordinates"] = {
        "EarthModel": "WGS_84",
        "IARP": {"ECF": v["iarp_ecf"], "LLH": v["iarp_llh"]},
        "ReferenceSurface": {"Planar": {"uIAX": v["u_iax"], "uIAY": v["u_iay"]}},
        "ImageArea": {"X1Y1": [x1, y1], "X2Y2": [x2, y2], "Polygon": polygon},
        "ImageAreaCornerPoints": v["llh_corners"][:, :2],
        "ImageGrid": {
            "IARPLocation": [-x1 / line_spacing - 0.5, -y1 / sample_spacing - 0.5],
            "IAXExtent": {"LineSpacing": line_spacing, "FirstLine": 0,
                          "NumLines": v["num_lines"]},
            "IAYExtent": {"SampleSpacing": sample_spacing, "FirstSample": 0,
                          "NumSamples": v["num_samples"]},
        },
    }
    xml["Data"] = {
        "SignalArrayFormat": "CF8", "NumBytesPVP": 8 * sum(words.values()),
        "NumCPHDChannels": 1,
        "Channel": [{"Identifier": _CHANNEL, "NumVectors": n_pulses,
                     "NumSamples": n_samples, "SignalArrayByteOffset": 0,
                     "PVPArrayByteOffset": 0}],
        "NumSupportArrays": 0,
    }
    # the "fixed" flags from the PVPs themselves (a straight track at constant height has
    # one TOA window for every pulse; the stripmap SRP moves with the beam)
    fixed = {name: bool(np.all(pvp[a] == pvp[a][0]) and np.all(pvp[b] == pvp[b][0]))
             for name, (a, b) in (("FX", ("FX1", "FX2")), ("TOA", ("TOA1", "TOA2")),
                                  ("SRP", ("SRPPos", "SRPPos")))}
    xml["Channel"] = {
        "RefChId": _CHANNEL, "FXFixedCPHD": fixed["FX"], "TOAFixedCPHD": fixed["TOA"],
        "SRPFixedCPHD": fixed["SRP"],
        "Parameters": [{
            "Identifier": _CHANNEL, "RefVectorIndex": n_pulses // 2, "FXFixed": fixed["FX"],
            "TOAFixed": fixed["TOA"], "SRPFixed": fixed["SRP"],
            "Polarization": {"TxPol": "UNSPECIFIED", "RcvPol": "UNSPECIFIED"},
            "FxC": float(pvp["FX1"][0] + pvp["FX2"][0]) / 2,
            "FxBW": float(pvp["FX2"][0] - pvp["FX1"][0]),
            "TOASaved": float(pvp["TOA2"].max() - pvp["TOA1"].min()),
            "DwellTimes": {"CODId": "cod", "DwellId": "dwell"},
            "TxRcv": {"TxWFId": ["chirp"], "RcvId": ["receiver"]},
        }],
    }
    offset = 0
    pvp_xml = {}
    for name, size in _PVP_LAYOUT:
        pvp_xml[name] = {"Offset": offset, "Size": size,
                         "dtype": np.dtype(("f8", (3,))) if size == 3 else np.dtype("f8")}
        offset += size
    xml["PVP"] = pvp_xml
    xml["Dwell"] = {
        "NumCODTimes": 1, "CODTime": [{"Identifier": "cod", "CODTimePoly": v["cod_poly"]}],
        "NumDwellTimes": 1,
        "DwellTime": [{"Identifier": "dwell", "DwellTimePoly": v["dwell_poly_2d"]}],
    }
    xml["TxRcv"] = {
        "NumTxWFs": 1,
        "TxWFParameters": [{"Identifier": "chirp", "PulseLength": tau,
                            "RFBandwidth": bandwidth, "FreqCenter": f0,
                            "LFMRate": -bandwidth / tau, "Polarization": "UNSPECIFIED"}],
        "NumRcvs": 1,
        "RcvParameters": [{"Identifier": "receiver",
                           "WindowLength": raw.data.shape[1] / fs, "SampleRate": fs,
                           "IFFilterBW": bandwidth, "FreqCenter": f0, "LFMRate": 0.0,
                           "Polarization": "UNSPECIFIED"}],
    }
    tree = root.getroottree()
    xml["ReferenceGeometry"] = skcphd.compute_reference_geometry(tree, pvp)
    _validate(skcphd, tree)
    return skcphd.Metadata(xmltree=tree)


def _validate(skcphd, tree):
    import lxml.etree

    schema = lxml.etree.XMLSchema(file=str(skcphd.VERSION_INFO[CPHD_NAMESPACE]["schema"]))
    if not schema.validate(tree):
        raise RuntimeError(f"internal error: the CPHD XML is not schema-valid: "
                           f"{schema.error_log.last_error}")


def _parameters(etree, params: dict):
    out = []
    for name, value in params.items():
        elem = etree.Element(f"{{{CPHD_NAMESPACE}}}Parameter", name=str(name))
        elem.text = str(value)
        out.append(elem)
    return out
