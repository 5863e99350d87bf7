"""CPHD and CRSD export: standard checkers, read-back through sarkit and sarpy, and
focusing of the exported CPHD by FastSAR (an independent processor)."""

import shutil
import subprocess
import warnings

import numpy as np
import pytest

import sarjax as sj
from sarjax.demo import TARGET_RANGES, demo_motion
from sarjax.export import GeoReference, to_cphd, to_crsd
from sarjax.export._common import collection

HEIGHT = 4000.0

# sarpy (the second reader, and FastSAR's) warns on every CPHD it opens that its CPHD
# reader is deprecated in favour of sarkit
pytestmark = pytest.mark.filterwarnings(
    "ignore:Call to deprecated class CPHDReader:DeprecationWarning")


@pytest.fixture(scope="module")
def demo_case():
    """The demo acquisition (seed 000 airborne X-band, three targets, cm-level deviations
    and pointing jitter) at its full 1941 pulses: an aperture of two footprints, so the
    full PRF band is focused for all three targets."""
    radar = sj.presets.airborne_xband()
    scene = sj.PointTargets(azimuth=[0.0] * 3, range=list(TARGET_RANGES))
    azimuth = (np.arange(radar.num_pulses) - (radar.num_pulses - 1) / 2) * float(
        radar.azimuth_spacing)
    motion = demo_motion(radar, azimuth)
    raw = sj.simulate(radar, scene, motion)
    return radar, scene, motion, raw


@pytest.fixture(scope="module")
def cphd_file(demo_case, tmp_path_factory):
    radar, _, motion, raw = demo_case
    path = tmp_path_factory.mktemp("cphd") / "demo.cphd"
    to_cphd(path, radar, raw, motion)
    return path


def _consistency(checker, path):
    with warnings.catch_warnings(), open(path, "rb") as f:
        # sarkit 1.8 reads its schema tables through a deprecated importlib call
        warnings.filterwarnings("ignore", message=r"(read|open)_text is deprecated")
        con = checker.from_file(f, thorough=True)
        con.check()
    return con


def test_cphd_passes_sarkit_consistency_checker(cphd_file):
    import sarkit.verification as skver

    con = _consistency(skver.CphdConsistency, cphd_file)
    assert con.failures() == {}
    assert len(con.passes()) >= 50
    exe = shutil.which("cphdcheck")
    if exe is not None:  # the command exits non-zero on any failure or warning
        assert subprocess.run([exe, str(cphd_file), "--thorough"]).returncode == 0


def test_straight_track_cphd_passes_the_checker(tmp_path):
    """No motion: every pulse has the same TOA window, so ``TOAFixed`` is true (the
    checker requires the flag to follow the PVPs)."""
    import sarkit.cphd as skcphd
    import sarkit.verification as skver

    radar = sj.presets.airborne_xband(num_pulses=129, num_range=160)
    r = 5140.0
    scene = sj.PointTargets(azimuth=[0.0], range=[r])
    raw = sj.simulate(radar, scene, None, near_range=r - 80 * 2.99792458)
    path = tmp_path / "straight.cphd"
    to_cphd(path, radar, raw, None)
    con = _consistency(skver.CphdConsistency, path)
    assert con.failures() == {}
    with open(path, "rb") as f:
        xml = skcphd.Reader(f).metadata.xmltree
    flags = {name: xml.findtext(f".//{{*}}Parameters/{{*}}{name}")
             for name in ("FXFixed", "TOAFixed", "SRPFixed")}
    assert flags == {"FXFixed": "true", "TOAFixed": "true", "SRPFixed": "false"}
    exe = shutil.which("cphdcheck")
    if exe is not None:
        assert subprocess.run([exe, str(path), "--thorough"]).returncode == 0


def test_cphd_reads_back_identically_through_sarkit_and_sarpy(demo_case, cphd_file):
    import sarkit.cphd as skcphd
    from sarpy.io.phase_history.converter import open_phase_history

    radar, _, motion, raw = demo_case
    with open(cphd_file, "rb") as f, skcphd.Reader(f) as reader:
        signal, pvp = reader.read_channel("1")
        sgn = reader.metadata.xmltree.findtext("{*}Global/{*}SGN")
    assert sgn == "-1"
    sarpy_reader = open_phase_history(str(cphd_file))
    sarpy_signal = sarpy_reader[:, :]
    assert signal.shape == sarpy_signal.shape == (radar.num_pulses, signal.shape[1])
    np.testing.assert_array_equal(sarpy_signal, signal.astype(np.complex64))
    for name in ("TxPos", "RcvPos", "SRPPos", "TxTime", "SC0", "SCSS"):
        np.testing.assert_array_equal(sarpy_reader.read_pvp_variable(name, 0),
                                      pvp[name].astype(float))
    # the positions are the true track (deviations included), to float64 precision
    geo = collection(radar, raw, motion, "true", GeoReference())
    np.testing.assert_allclose(pvp["TxPos"].astype(float), geo.apc_ecf, rtol=0, atol=1e-8)
    local = geo.frame.to_local(pvp["TxPos"].astype(float))
    dy, dz, _ = (np.asarray(v) for v in motion.resolve(radar.num_pulses))
    np.testing.assert_allclose(local[:, 1], dy, atol=1e-8)
    np.testing.assert_allclose(local[:, 2] - HEIGHT, dz, atol=1e-8)


def test_cphd_phase_convention_for_one_scatterer(tmp_path):
    """SGN = −1: the vector of pulse p is γ W² exp(−j4πf(R_p − R_srp,p)/c) — checked by
    the delay and phase that a least-squares fit over the central band recovers."""
    import sarkit.cphd as skcphd

    radar = sj.presets.airborne_xband(num_pulses=129)
    x_t, r_t = 1.3, 5140.7
    raw = sj.simulate(radar, sj.PointTargets(azimuth=[x_t], range=[r_t]))
    path = to_cphd(tmp_path / "one.cphd", radar, raw, track="nominal")
    with open(path, "rb") as f, skcphd.Reader(f) as reader:
        signal, pvp = reader.read_channel("1")
    geo = collection(radar, raw, None, "nominal", GeoReference())
    target = geo.frame.to_ecf([x_t, np.sqrt(r_t**2 - HEIGHT**2), 0.0])
    c = sj.constants.SPEED_OF_LIGHT
    for p in (10, 64, 120):
        f = pvp["SC0"][p] + pvp["SCSS"][p] * np.arange(signal.shape[1])
        tx, srp = pvp["TxPos"][p].astype(float), pvp["SRPPos"][p].astype(float)
        delta = np.linalg.norm(tx - target) - np.linalg.norm(tx - srp)
        residual = signal[p].astype(complex) * np.exp(4j * np.pi * f * delta / c)
        central = np.abs(f - f.mean()) < 0.3 * np.ptp(f)  # the band edges carry the
        phase = np.unwrap(np.angle(residual[central]))  # Fresnel ripple of the chirp
        slope, _ = np.polyfit(f[central], phase, 1)
        # a residual delay error of 2 mm would show as this slope
        assert abs(slope) * c / (4 * np.pi) < 2e-3
        # the pattern weight W² ≥ 0 carries no phase: arg γ = 0 up to the chirp ripple
        assert abs(np.angle(np.mean(residual[central]))) < 0.1


def _backproject_fastsar(path, geo, targets, *, half=(6.0, 40.0), step=(0.1, 0.5)):
    """FastSAR: read the CPHD (through sarpy) and back-project (exactly, every pulse)
    onto (x, r) grids about each target, placed on the Earth by the file's frame;
    returns one sj.Image per target."""
    import fastsar

    col, meta = fastsar.io.read_cphd(str(path), meta=True)
    axes, points = [], []
    for x_t, r_t in targets:
        xs = x_t + np.arange(-half[0], half[0] + step[0] / 2, step[0])
        rs = r_t + np.arange(-half[1], half[1] + step[1] / 2, step[1])
        xx, rr = np.meshgrid(xs, rs, indexing="ij")
        local = np.stack([xx, np.sqrt(rr**2 - HEIGHT**2), np.zeros_like(xx)], axis=-1)
        axes.append((xs, rs))
        points.append(fastsar.io.ecf_to_local(geo.frame.to_ecf(local), meta))
    images = fastsar.backproject(col["S"], col["ant"], col["fmin"], col["df"],
                                 np.stack(points), ref=meta["ref"], window=False,
                                 upsample=32, backend="jax")
    return [sj.Image(data=image, azimuth=xs, range=rs)
            for image, (xs, rs) in zip(images, axes, strict=True)]


def test_fastsar_focuses_the_cphd(demo_case, cphd_file):
    """FastSAR back-projects the exported file with the true track it carries.

    Positions: within 1 cm of the truth (x, r). The remaining range offsets (up to
    ≈ 1 cm) are the exact simulator's own: its sampled chirp with a hard rect puts a
    range-compressed peak up to ±11 mm off, depending on the sub-sample position, and
    sarjax's own back-projection of the raw data lands within 1 mm of FastSAR's.
    IRW: within 2 % of sarjax's back-projection focuser (same aperture: every pulse;
    sarjax's ω-k keeps only the PRF band, hence a 15 % wider azimuth IRW here).
    """
    radar, _, motion, raw = demo_case
    geo = collection(radar, raw, motion, "true", GeoReference())
    targets = [(0.0, r) for r in TARGET_RANGES]
    for (x_t, r_t), image in zip(targets, _backproject_fastsar(cphd_file, geo, targets),
                                 strict=True):
        theirs = sj.point_target_metrics(image, azimuth=x_t, range=r_t, half_window=60,
                                         sidelobe_cells=5, upsample=32)
        assert np.hypot(theirs.peak_azimuth - x_t, theirs.peak_range - r_t) < 0.01
        ours = sj.point_target_metrics(
            sj.focus(radar, raw, method="backprojection", motion=motion,
                     azimuth=image.azimuth, range=image.range, upsample=32),
            azimuth=x_t, range=r_t, half_window=60, sidelobe_cells=5, upsample=32)
        assert theirs.irw_azimuth == pytest.approx(ours.irw_azimuth, rel=0.02)
        assert theirs.irw_range == pytest.approx(ours.irw_range, rel=0.02)
        assert abs(ours.peak_range - theirs.peak_range) < 1e-3
        assert abs(ours.peak_azimuth - theirs.peak_azimuth) < 1e-3


def test_cphd_refuses_overwrite_and_bad_input(demo_case, cphd_file):
    radar, _, motion, raw = demo_case
    with pytest.raises(FileExistsError):
        to_cphd(cphd_file, radar, raw, motion)
    with pytest.raises(ValueError, match="track"):
        to_cphd(cphd_file.with_suffix(".x"), radar, raw, motion, track="wobbly")
    with pytest.raises(ValueError, match="side_of_track"):
        GeoReference(side_of_track="up")
    with pytest.raises(ValueError, match="spacing"):
        to_cphd(cphd_file.with_suffix(".y"), radar.replace(prf=300.0), raw, motion)
    assert not cphd_file.with_suffix(".x").exists()


def test_crsd_passes_checker_and_reads_back_identically(demo_case, tmp_path):
    import sarkit.crsd as skcrsd
    import sarkit.verification as skver

    radar, _, motion, raw = demo_case
    path = to_crsd(tmp_path / "demo.crsd", radar, raw, motion)
    con = _consistency(skver.CrsdConsistency, path)
    assert con.failures() == {}
    assert len(con.passes()) >= 80
    exe = shutil.which("crsdcheck")
    if exe is not None:
        assert subprocess.run([exe, str(path), "--thorough"]).returncode == 0
    with open(path, "rb") as f, skcrsd.Reader(f) as reader:
        signal, pvp = reader.read_channel("rx")
        ppp = reader.read_ppps("tx")
    np.testing.assert_array_equal(signal, np.asarray(raw.data).astype(np.complex64))
    # timing and phase references (see to_crsd): sample k of pulse p at
    # RcvStart + k / f_s = t_p + 2 r'_k / c with t_p the chirp centre = TxTime + τ/2
    c = sj.constants.SPEED_OF_LIGHT
    tau, fs = float(radar.chirp_duration), float(radar.sampling_rate)
    tx_time = ppp["TxTime"]["Int"] + ppp["TxTime"]["Frac"]
    rcv_start = pvp["RcvStart"]["Int"] + pvp["RcvStart"]["Frac"]
    np.testing.assert_allclose(tx_time, np.arange(radar.num_pulses) / float(radar.prf),
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(rcv_start - (tx_time + tau / 2),
                               2 * float(raw.range[0]) / c, rtol=0, atol=1e-12)
    np.testing.assert_allclose(2 * np.asarray(raw.range[1:2] - raw.range[0]) / c, 1 / fs,
                               rtol=1e-12)
    ref_phase = pvp["RefPhi0"]["Int"] + pvp["RefPhi0"]["Frac"]
    np.testing.assert_allclose(ref_phase, 2 * float(radar.carrier_frequency)
                               * float(raw.range[0]) / c, rtol=1e-15)
    # the pointing error steers the electrical boresight
    np.testing.assert_allclose(pvp["RcvEB"][:, 0], -np.sin(np.asarray(motion.pointing)),
                               atol=1e-15)


def _track_case(kind):
    """(radar, raw, motion, cphd keywords) of one track kind: a point target on the beam
    centre of the middle pulse, its echo inside a 200-sample window."""
    if kind.startswith("high_speed"):
        # a 1 µs chirp (720 samples): the preset's 40 µs (28 800 samples) sets a 36 450-bin
        # FX transform per pulse, 2 s of phase-history work per file and nothing the
        # receive positions under test depend on
        radar = sj.presets.highspeed_xband(num_pulses=513, num_range=200, chirp_duration=1e-6)
    else:
        squint = np.deg2rad(15.0) if kind.startswith("squint") else 0.0
        radar = sj.presets.airborne_xband(num_pulses=1941, num_range=200, squint=squint)
    r, squint = float(radar.reference_range), float(radar.squint)
    radar = radar.replace(near_range=r / np.cos(squint) - 100 * float(radar.range_spacing))
    scene = sj.PointTargets(azimuth=[r * np.tan(squint)], range=[r])
    x = (np.arange(radar.num_pulses) - (radar.num_pulses - 1) / 2) * float(
        radar.azimuth_spacing)
    smooth = dict(max_cycles=1, aperture=float(x[-1] - x[0]) / 2)
    # 2 cm airborne; 2 mm over the high-speed track's 0.1 s (2 cm there would be 30 g,
    # which the checker rightly flags as a velocity no 5th-order polynomial follows)
    rms = 0.002 if kind.startswith("high_speed") else 0.02
    motion = None
    if kind.endswith("moved") or kind == "batch":
        motion = sj.Motion(
            horizontal=sj.smooth_deviation(x, key=1, rms=rms, **smooth),
            vertical=sj.smooth_deviation(x, key=2, rms=rms, **smooth),
            pointing=sj.seed_pointing_jitter(radar, x))
    if kind == "batch":  # two realizations of the horizontal deviation, one shared rest
        motion = sj.Motion(horizontal=np.stack([motion.horizontal, -motion.horizontal]),
                           vertical=motion.vertical, pointing=motion.pointing)
    # high speed: the exact model beyond stop-and-go (what method="high_speed" models;
    # its output is exported the same way, see the default of to_cphd's stop_and_go)
    stop_and_go = not kind.startswith("high_speed")
    raw = sj.simulate(radar, scene, motion, method="time_domain", stop_and_go=stop_and_go)
    return radar, raw, motion, {} if stop_and_go else dict(stop_and_go=False)


@pytest.mark.parametrize("kind", ["squint", "squint_moved", "high_speed",
                                  "high_speed_moved", "batch"])
def test_every_track_kind_passes_the_checkers(kind, tmp_path):
    """CPHD and CRSD of squinted (15°), high-speed (non-stop-and-go: RcvPos where the
    antenna is when the SRP's echo returns) and batched acquisitions, straight and with
    motion, pass ``cphdcheck`` / ``crsdcheck --thorough`` (the straight broadside and
    deviated ones: the tests above)."""
    import sarkit.cphd as skcphd
    import sarkit.verification as skver

    from sarjax.export import realization

    radar, raw, motion, options = _track_case(kind)
    if kind == "batch":
        with pytest.raises(ValueError, match="realization"):
            to_cphd(tmp_path / "all.cphd", radar, raw, motion)
        cases = [realization(raw, motion, b) for b in range(2)]
        np.testing.assert_array_equal(cases[1][1].horizontal, -cases[0][1].horizontal)
    else:
        cases = [(raw, motion)]
    for b, (one, one_motion) in enumerate(cases):
        for fmt, write, checker in (("cphd", to_cphd, skver.CphdConsistency),
                                    ("crsd", to_crsd, skver.CrsdConsistency)):
            path = tmp_path / f"{kind}{b}.{fmt}"
            write(path, radar, one, one_motion, **(options if fmt == "cphd" else {}))
            assert _consistency(checker, path).failures() == {}, (kind, fmt)
            exe = shutil.which(f"{fmt}check")
            if exe is not None:  # exits non-zero on any failure or warning
                done = subprocess.run([exe, str(path), "--thorough"], capture_output=True,
                                      text=True)
                assert done.returncode == 0, done.stdout[-2000:]
    if kind.startswith("high_speed"):
        # beyond stop-and-go the receive position is the antenna at TxTime + τ_srp, and
        # c τ_srp = |TxPos − SRP| + |RcvPos − SRP| (to 1 µm: float64 ECF of ~6e6 m)
        with open(tmp_path / f"{kind}0.cphd", "rb") as f, skcphd.Reader(f) as reader:
            _, pvp = reader.read_channel("1")
        tx, rcv, srp = (pvp[k].astype(float) for k in ("TxPos", "RcvPos", "SRPPos"))
        tau = pvp["RcvTime"].astype(float) - pvp["TxTime"].astype(float)
        c = sj.constants.SPEED_OF_LIGHT
        path_length = np.linalg.norm(tx - srp, axis=-1) + np.linalg.norm(rcv - srp, axis=-1)
        np.testing.assert_allclose(c * tau, path_length, rtol=0, atol=1e-6)
        np.testing.assert_allclose(np.linalg.norm(rcv - tx, axis=-1),
                                   float(radar.velocity) * tau, rtol=1e-6)
        # data labelled as method="high_speed" output get the same positions by default
        import dataclasses

        labelled = dataclasses.replace(raw, method="high_speed")
        to_cphd(tmp_path / "default.cphd", radar, labelled, motion)
        with open(tmp_path / "default.cphd", "rb") as f, skcphd.Reader(f) as reader:
            _, default = reader.read_channel("1")
        np.testing.assert_array_equal(default["RcvPos"], pvp["RcvPos"])
        np.testing.assert_array_equal(default["RcvTime"], pvp["RcvTime"])
