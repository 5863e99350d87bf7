"""CRSD 1.0 export (raw chirped echoes, CRSDsar, through sarkit)."""

from __future__ import annotations

import datetime as _dt

import numpy as np

from .._files import atomic_write
from ..constants import SPEED_OF_LIGHT
from ._common import (
    check_grid,
    collection,
    parameters,
    quiet_sarkit,
    require,
    scalar,
    scene_area,
)
from ._frame import GeoReference

CRSD_NAMESPACE = "http://api.nsgreg.nga.mil/schema/crsd/1.0"
_SEQUENCE = "tx"
_CHANNEL = "rx"
_I8F8 = np.dtype([("Int", ">i8"), ("Frac", ">f8")])
_PPP = (("TxTime", _I8F8), ("TxPos", (">f8", 3)), ("TxVel", (">f8", 3)), ("FX1", ">f8"),
        ("FX2", ">f8"), ("TXmt", ">f8"), ("PhiX0", _I8F8), ("FxFreq0", ">f8"),
        ("FxRate", ">f8"), ("TxRadInt", ">f8"), ("TxACX", (">f8", 3)), ("TxACY", (">f8", 3)),
        ("TxEB", (">f8", 2)), ("FxResponseIndex", ">i8"))
_PVP = (("RcvStart", _I8F8), ("RcvPos", (">f8", 3)), ("RcvVel", (">f8", 3)), ("FRCV1", ">f8"),
        ("FRCV2", ">f8"), ("RefPhi0", _I8F8), ("RefFreq", ">f8"), ("DFIC0", ">f8"),
        ("FICRate", ">f8"), ("RcvACX", (">f8", 3)), ("RcvACY", (">f8", 3)),
        ("RcvEB", (">f8", 2)), ("SIGNAL", ">i8"), ("AmpSF", ">f8"), ("DGRGC", ">f8"),
        ("TxPulseIndex", ">i8"))


def _int_frac(value):
    """Split float64 values into (Int, Frac) with 0 ≤ Frac < 1."""
    value = np.asarray(value, float)
    whole = np.floor(value)
    return whole.astype(np.int64), value - whole


def _layout(fields):
    out, offset = {}, 0
    for name, dtype in fields:
        dtype = np.dtype(dtype)
        words = dtype.itemsize // 8
        out[name] = {"Offset": offset, "Size": words, "dtype": dtype.newbyteorder("=")}
        offset += words
    return out, 8 * offset


def to_crsd(path, radar, raw, motion=None, *, track: str = "true",
            reference: GeoReference | None = None, core_name: str = "sarjax",
            classification: str = "UNCLASSIFIED", release_info: str = "UNRESTRICTED",
            attrs: dict | None = None, overwrite: bool = False, pattern_samples: int = 241):
    """Write raw data as a CRSD 1.0 file (``CRSDsar``: one transmit sequence, one channel).

    The signal array holds the raw samples h(x'_p, r'_k) unchanged (complex64). Their
    time and phase references (also in the file's ``ProductInfo/Parameter`` list):

    * **Pulse time**: sarjax's echo is centred on its delay, i.e. the chirp of pulse p
      is centred on t_p = p / PRF + τ/2 (from ``CollectionRefTime``). CRSD times a pulse
      by its start: TxTime = t_p − τ/2 = p / PRF, TXmt = τ, an LFM with FxFreq0 = f₀ + Δf/2 and
      FxRate = −Δf/τ (sarjax's chirp exp(−j b (r' − R)²) falls in frequency).
    * **Transmit phase**: zero at the chirp centre, f₀ (t − t_p) + (FxRate/2)(t − t_p)²
      cycles, so PhiX0 = −f₀ τ/2 + FxRate τ²/8 cycles at TxTime.
    * **Receive**: sample k of pulse p is at RcvStart + k / f_s, RcvStart = t_p + 2 r'₀ / c
      (r'₀ the first range sample). The demodulation reference is f₀ (t − t_p) cycles,
      so RefFreq = f₀, RefPhi0 = 2 f₀ r'₀ / c cycles at RcvStart, DFIC0 = FICRate = 0:
      a scatterer at range R gives the phase −4πR/λ at the centre of its echo.
    * **Positions**: TxPos = the antenna of pulse p (true track for ``track="true"``,
      deviations included, or nominal), RcvPos = TxPos + TxVel (RcvStart − TxTime), the
      antenna at the start of the receive window. sarjax's default echo model is
      stop-and-go (``stop_and_go=True``: one antenna position per pulse, TxPos), so a
      processor matching the data should use TxPos for both legs.
    * **Antenna**: coordinate frame x along the nominal track, z abeam (zero Doppler)
      towards the reference ground range, y = z × x; the one-way pattern is the
      square root of sarjax's two-way W²(u) along x with u = L·DCX/λ (flat across);
      the squint φ_d and the pointing error δ_az steer the electrical boresight:
      EB DCX = sin(φ_d − δ_az) (sarjax's beam centre sits at x' + r tan φ_d − r δ_az;
      at broadside EB DCX = −sin δ_az).

    Args: as :func:`sarjax.export.to_cphd`; ``pattern_samples``: points of the pattern
    table along DCX.

    Returns:
        The path.
    """
    lxml_etree = require("lxml.etree")
    skcrsd = require("sarkit.crsd")
    reference = GeoReference() if reference is None else reference
    check_grid(radar, raw)
    geo = collection(radar, raw, motion, track, reference)
    data = np.ascontiguousarray(np.asarray(raw.data), dtype=np.complex64)
    n_pulses, n_samples = data.shape
    f0 = scalar(radar.carrier_frequency, "radar.carrier_frequency")
    bandwidth = float(radar.bandwidth)
    fs = float(radar.sampling_rate)
    tau = float(radar.chirp_duration)
    near = float(np.asarray(raw.range)[0])
    rate = -bandwidth / tau
    wavelength = SPEED_OF_LIGHT / f0
    length = float(radar.antenna_length)
    t_centre = geo.tx_time + tau / 2  # the chirp centres; TxTime (start) = t_p − τ/2 ≥ 0
    apc, vel = geo.apc_ecf, geo.velocity_ecf

    # antenna frame of each pulse: the nominal axes, ACZ looking abeam (zero Doppler) at
    # the reference ground range; the squint φ_d and the pointing error δ_az steer the
    # electrical boresight along DCX (beam centre at x = x' + r tan φ_d − r δ_az)
    along = np.broadcast_to(geo.frame.axes[0], (n_pulses, 3))
    abeam = np.array([0.0, geo.ground_reference, -float(radar.height)])
    look = geo.frame.vector_to_ecf(abeam / np.linalg.norm(abeam))
    acy = np.broadcast_to(np.cross(look, along), (n_pulses, 3))
    n = raw.data.shape[0]
    _, _, pointing = (np.asarray(v, float) for v in
                      (motion.resolve(n) if motion is not None else (0, 0, np.zeros(n))))
    pointing = np.broadcast_to(pointing, (n,))
    squint = float(radar.squint)
    boresight = np.stack([np.sin(squint - pointing), np.zeros(n)], axis=-1)

    ppp_layout, ppp_bytes = _layout(_PPP)
    pvp_layout, pvp_bytes = _layout(_PVP)
    ppp = np.zeros(n_pulses, np.dtype(list(_PPP)))
    ppp["TxTime"]["Int"], ppp["TxTime"]["Frac"] = _int_frac(geo.tx_time)
    ppp["TxPos"], ppp["TxVel"] = apc, vel
    ppp["FX1"], ppp["FX2"] = f0 - bandwidth / 2, f0 + bandwidth / 2
    ppp["TXmt"] = tau
    ppp["PhiX0"]["Int"], ppp["PhiX0"]["Frac"] = _int_frac(
        np.full(n_pulses, -f0 * tau / 2 + rate * tau**2 / 8))
    ppp["FxFreq0"] = f0 + bandwidth / 2
    ppp["FxRate"] = rate
    ppp["TxRadInt"] = 1.0
    ppp["TxACX"], ppp["TxACY"], ppp["TxEB"] = along, acy, boresight
    ppp["FxResponseIndex"] = 0

    rcv_start = t_centre + 2 * near / SPEED_OF_LIGHT
    pvp = np.zeros(n_pulses, np.dtype(list(_PVP)))
    pvp["RcvStart"]["Int"], pvp["RcvStart"]["Frac"] = _int_frac(rcv_start)
    # where the antenna is at RcvStart (moving on at its velocity, ≈ 3 mm airborne)
    pvp["RcvPos"] = apc + vel * (rcv_start - geo.tx_time)[:, None]
    pvp["RcvVel"] = vel
    pvp["FRCV1"], pvp["FRCV2"] = f0 - fs / 2, f0 + fs / 2
    pvp["RefPhi0"]["Int"], pvp["RefPhi0"]["Frac"] = _int_frac(
        np.full(n_pulses, 2 * f0 * near / SPEED_OF_LIGHT))
    pvp["RefFreq"] = f0
    pvp["RcvACX"], pvp["RcvACY"], pvp["RcvEB"] = along, acy, boresight
    pvp["SIGNAL"] = 1
    pvp["AmpSF"] = 1.0
    pvp["TxPulseIndex"] = np.arange(n_pulses)

    # one-way pattern table along DCX (three columns across: flat), element: flat
    half = min(4 * wavelength / length, 0.99)
    dcx = np.linspace(-half, half, pattern_samples | 1)
    two_way = np.abs(np.asarray(radar.pattern(length * dcx / wavelength), float))
    gain_db = np.maximum(5 * np.log10(np.maximum(two_way, 1e-30)), -150.0)  # ½ · 10 log W²
    gain_db -= gain_db[dcx.size // 2]
    gp_dtype = np.dtype([("Gain", ">f4"), ("Phase", ">f4")])
    array_gp = np.zeros((dcx.size, 3), gp_dtype)
    array_gp["Gain"] = gain_db[:, None]
    element_gp = np.zeros((3, 3), gp_dtype)
    fx_response = np.zeros((1, 3), np.dtype([("Amp", ">f4"), ("Phase", ">f4")]))
    fx_response["Amp"] = 1.0
    support = {"array_pattern": (array_gp, dict(X0=float(dcx[0]), Y0=-0.5,
                                                XSS=float(dcx[1] - dcx[0]), YSS=0.5)),
               "element_pattern": (element_gp, dict(X0=-0.5, Y0=-0.5, XSS=0.5, YSS=0.5)),
               "fx_response": (fx_response, None)}

    area = scene_area(radar, raw, geo, reference, time_offset=tau / 2)
    params = parameters(radar, raw, track, {
        "reference.latitude_deg": reference.latitude,
        "reference.longitude_deg": reference.longitude,
        "reference.heading_deg": reference.heading,
        "convention.pulse_time": "chirp centre t_p = TxTime + TXmt/2",
        "convention.sample_time": "RcvStart + k / Fs, RcvStart = t_p + 2 r'0 / c",
        "convention.phase": "reference f0 (t - t_p) cycles: a scatterer at range R has "
                            "phase -4 pi R / lambda at the centre of its echo",
        "convention.positions": "TxPos: antenna of pulse p (stop-and-go echo model); "
                                "RcvPos: TxPos + TxVel (RcvStart - TxTime)",
        "convention.boresight": "EB DCX = sin(squint - pointing error)",
        **(attrs or {})})
    start = reference.collection_start

    with quiet_sarkit():
        root = lxml_etree.Element(f"{{{CRSD_NAMESPACE}}}CRSDsar",
                                  nsmap={None: CRSD_NAMESPACE})
        xml = skcrsd.ElementWrapper(root)
        xml["ProductInfo"] = {
            "ProductName": core_name, "Classification": classification,
            "ReleaseInfo": release_info,
            "CreationInfo": [{"Application": "sarjax",
                              "DateTime": _dt.datetime(2000, 1, 1, tzinfo=_dt.UTC)}],
        }
        product = root.find(f"{{{CRSD_NAMESPACE}}}ProductInfo")
        for name, value in params.items():
            elem = lxml_etree.SubElement(product, f"{{{CRSD_NAMESPACE}}}Parameter",
                                         name=str(name))
            elem.text = str(value)
        xml["SARInfo"] = {"CollectType": "MONOSTATIC", "RadarMode": {"ModeType": "STRIPMAP"}}
        xml["TransmitInfo"] = {"SensorName": "sarjax", "EventName": core_name}
        xml["ReceiveInfo"] = {"SensorName": "sarjax", "EventName": core_name}
        tx_time = geo.tx_time
        image_area = {"X1Y1": [area["x1"], area["y1"]], "X2Y2": [area["x2"], area["y2"]],
                      "Polygon": area["polygon"]}
        xml["Global"] = {
            "CollectionRefTime": start,
            "Transmit": {"TxTime1": float(tx_time[0]), "TxTime2": float(tx_time[-1]),
                         "FxMin": f0 - bandwidth / 2, "FxMax": f0 + bandwidth / 2},
            "Receive": {"RcvStartTime1": float(rcv_start[0]),
                        "RcvStartTime2": float(rcv_start[-1]),
                        "FrcvMin": f0 - fs / 2, "FrcvMax": f0 + fs / 2},
        }
        xml["SceneCoordinates"] = {
            "EarthModel": "WGS_84",
            "IARP": {"ECF": area["iarp_ecf"], "LLH": area["iarp_llh"]},
            "ReferenceSurface": {"Planar": {"uIAX": area["u_iax"], "uIAY": area["u_iay"]}},
            "ImageArea": image_area,
            "ImageAreaCornerPoints": area["llh_corners"][:, :2],
            "ImageGrid": {
                "Identifier": "grid",
                "IARPLocation": [-area["x1"] / area["line_spacing"] - 0.5,
                                 -area["y1"] / area["sample_spacing"] - 0.5],
                "IAXExtent": {"LineSpacing": area["line_spacing"], "FirstLine": 0,
                              "NumLines": area["num_lines"]},
                "IAYExtent": {"SampleSpacing": area["sample_spacing"], "FirstSample": 0,
                              "NumSamples": area["num_samples"]},
            },
        }
        offset, support_xml = 0, []
        for name, (array, _) in support.items():
            support_xml.append({"SAId": name, "NumRows": array.shape[0],
                                "NumCols": array.shape[1],
                                "BytesPerElement": array.dtype.itemsize,
                                "ArrayByteOffset": offset})
            offset += array.nbytes
        xml["Data"] = {
            "Support": {"NumSupportArrays": len(support), "SupportArray": support_xml},
            "Transmit": {"NumBytesPPP": ppp_bytes, "NumTxSequences": 1,
                         "TxSequence": [{"TxId": _SEQUENCE, "NumPulses": n_pulses,
                                         "PPPArrayByteOffset": 0}]},
            "Receive": {"SignalArrayFormat": "CF8", "NumBytesPVP": pvp_bytes,
                        "NumCRSDChannels": 1,
                        "Channel": [{"ChId": _CHANNEL, "NumVectors": n_pulses,
                                     "NumSamples": n_samples, "SignalArrayByteOffset": 0,
                                     "PVPArrayByteOffset": 0}]},
        }
        ref_point = {"ECF": area["iarp_ecf"], "IAC": [0.0, 0.0]}
        reference = n_pulses // 2

        def polarization(position, acx, acy, leg):
            # the antenna's ACY-polarised field seen from the reference point in the H, V
            # basis (CRSD D&I 9.4.4; pure V abeam, an H part when squinted)
            amph, ampv, phaseh, phasev = skcrsd.compute_h_v_pol_parameters(
                position[reference], acx[reference], acy[reference], area["iarp_ecf"], leg,
                0.0, 1.0, 0.0, 0.0)
            return {"PolarizationID": "V", "AmpH": float(amph), "AmpV": float(ampv),
                    "PhaseH": float(phaseh), "PhaseV": float(phasev)}

        tx_pol = polarization(ppp["TxPos"], ppp["TxACX"], ppp["TxACY"], 1)
        rcv_pol = polarization(pvp["RcvPos"], pvp["RcvACX"], pvp["RcvACY"], -1)
        xml["TxSequence"] = {
            "RefTxId": _SEQUENCE, "TxWFType": "LFM",
            "Parameters": [{
                "Identifier": _SEQUENCE, "RefPulseIndex": n_pulses // 2,
                "FxResponseId": "fx_response", "FxBWFixed": True, "FxC": f0,
                "FxBW": bandwidth, "TXmtMin": tau, "TXmtMax": tau,
                "TxTime1": float(tx_time[0]), "TxTime2": float(tx_time[-1]),
                "TxAPCId": "apc", "TxAPATId": "pattern", "TxRefPoint": ref_point,
                "TxPolarization": tx_pol, "TxRefRadIntensity": 1.0,
                "TxRadIntErrorStdDev": 0.0, "TxRefLAtm": 1.0,
            }],
        }
        xml["Channel"] = {
            "RefChId": _CHANNEL,
            "Parameters": [{
                "Identifier": _CHANNEL, "RefVectorIndex": n_pulses // 2,
                "RefFreqFixed": True, "FrcvFixed": True, "SignalNormal": True,
                "F0Ref": f0, "Fs": fs, "BWInst": bandwidth,
                "RcvStartTime1": float(rcv_start[0]), "RcvStartTime2": float(rcv_start[-1]),
                "FrcvMin": f0 - fs / 2, "FrcvMax": f0 + fs / 2,
                "RcvAPCId": "apc", "RcvAPATId": "pattern", "RcvRefPoint": ref_point,
                "RcvPolarization": rcv_pol, "RcvRefIrradiance": 1.0,
                "RcvIrradianceErrorStdDev": 0.0, "RcvRefLAtm": 1.0,
                "PNCRSD": 1.0, "BNCRSD": 1.0,
                "SARImage": {"TxId": _SEQUENCE, "RefVectorPulseIndex": n_pulses // 2,
                             "TxPolarization": tx_pol,
                             "DwellTimes": {"Polynomials": {"CODId": "cod",
                                                            "DwellId": "dwell"}},
                             "ImageArea": image_area},
            }],
        }
        xml["DwellPolynomials"] = {
            "NumCODTimes": 1, "CODTime": [{"Identifier": "cod",
                                           "CODTimePoly": area["cod_poly"]}],
            "NumDwellTimes": 1, "DwellTime": [{"Identifier": "dwell",
                                               "DwellTimePoly": area["dwell_poly_2d"]}],
        }
        gp_format = "Gain=F4;Phase=F4;"
        xml["SupportArray"] = {
            "GainPhaseArray": [{"Identifier": name, "ElementFormat": gp_format, **grid}
                               for name, (_, grid) in support.items() if grid is not None],
            "FxResponseArray": [{"Identifier": "fx_response",
                                 "ElementFormat": "Amp=F4;Phase=F4;",
                                 "Fx0FXR": f0 - bandwidth, "FxSSFXR": bandwidth}],
        }
        xml["PPP"] = ppp_layout
        xml["PVP"] = pvp_layout
        xml["Antenna"] = {
            "NumACFs": 1, "NumAPCs": 1, "NumAPATs": 1,
            "AntCoordFrame": [{"Identifier": "acf"}],
            "AntPhaseCenter": [{"Identifier": "apc", "ACFId": "acf",
                                "APCXYZ": [0.0, 0.0, 0.0]}],
            "AntPattern": [{
                "Identifier": "pattern", "FreqZero": f0, "ArrayGPId": "array_pattern",
                "ElemGPId": "element_pattern",
                "EBFreqShift": {"DCXSF": 0.0, "DCYSF": 0.0},
                "MLFreqDilation": {"DCXSF": 0.0, "DCYSF": 0.0},
                "GainBSPoly": [0.0],
                "AntPolRef": {"AmpX": 0.0, "AmpY": 1.0, "PhaseX": 0.0, "PhaseY": 0.0},
            }],
        }
        tree = root.getroottree()
        xml["ReferenceGeometry"] = skcrsd.compute_reference_geometry(tree, pvps=pvp,
                                                                     ppps=ppp)
        schema = lxml_etree.XMLSchema(
            file=str(skcrsd.VERSION_INFO[CRSD_NAMESPACE]["schema"]))
        if not schema.validate(tree):
            raise RuntimeError("internal error: the CRSD XML is not schema-valid: "
                               f"{schema.error_log.last_error}")
        metadata = skcrsd.Metadata(xmltree=tree)

    def write(tmp):
        with open(tmp, "wb") as f, skcrsd.Writer(f, metadata) as writer:
            for name, (array, _) in support.items():
                writer.write_support_array(name, array)
            writer.write_ppp(_SEQUENCE, ppp)
            writer.write_pvp(_CHANNEL, pvp)
            writer.write_signal(_CHANNEL, data)

    return atomic_write(path, write, overwrite=overwrite)
