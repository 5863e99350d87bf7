"""SICD export of focused images: sarkit's consistency checker, read-back through sarkit
and sarpy, geometry shared with the CPHD export of the same run, and the CLI path."""

import dataclasses

import numpy as np
import pytest

import sarjax as sj
import sarjax.cli
from sarjax.export import GeoReference, to_cphd, to_sicd

R0 = 5140.0  # the airborne preset's reference range [m]
N_PULSES, N_RANGE = 257, 160
TARGETS = ((0.0, R0), (6.0, R0 + 45.0))  # (x, r) [m]; the first is the brighter

# sarkit 1.8 reads its schema tables through a deprecated importlib call; sarpy (the
# second reader) warns that its SICD reader is deprecated in favour of sarkit
pytestmark = [
    pytest.mark.filterwarnings(r"ignore:(read|open)_text is deprecated:DeprecationWarning"),
    pytest.mark.filterwarnings("ignore:Call to deprecated class SICDReader:DeprecationWarning"),
]

# the one checker result that is not a pass: a Warning, not an Error. The image is on the
# pulse grid (Δx = v/PRF) and ω-k processes the whole PRF band, so the columns are
# critically sampled (OSR = 1) and the checker would like ≥ 1.1
EXPECTED_WARNINGS = {"check_iprbw_to_ss_osr_col"}


@pytest.fixture(scope="module")
def run():
    """A small demo-like acquisition (airborne X-band, two targets, straight track)
    with the middle range sample at the reference range r₀, focused by ω-k."""
    radar = sj.presets.airborne_xband(num_pulses=N_PULSES, num_range=N_RANGE)
    scene = sj.PointTargets(azimuth=[x for x, _ in TARGETS], range=[r for _, r in TARGETS],
                            reflectivity=[1.0, 0.5])
    near = R0 - (N_RANGE // 2) * float(radar.range_spacing)
    raw = sj.simulate(radar, scene, None, near_range=near)
    image = sj.focus(radar, raw)
    return radar, raw, image


@pytest.fixture(scope="module")
def sicd_file(run, tmp_path_factory):
    radar, _, image = run
    return to_sicd(image, tmp_path_factory.mktemp("sicd") / "demo.nitf", radar)


def _check(path):
    import sarkit.verification as skver

    with open(path, "rb") as f:
        con = skver.SicdConsistency.from_file(f)
        con.check()
    failed = {name: [d for d in result["details"] if not d["passed"]]
              for name, result in con.failures().items()}
    errors = [(name, d["details"]) for name, details in failed.items() for d in details
              if d["severity"] == "Error"]
    return con, failed, errors


def _read_sicd(path):
    import sarkit.sicd as sksicd

    with open(path, "rb") as f, sksicd.NitfReader(f) as reader:
        return reader.read_image(), reader.metadata.xmltree


@pytest.mark.parametrize("side", ["R", "L"])
def test_sicd_passes_sarkit_consistency_checker(run, tmp_path, side):
    radar, _, image = run
    path = to_sicd(image, tmp_path / f"{side}.nitf", radar,
                   reference=GeoReference(side_of_track=side, heading=30.0))
    con, failed, errors = _check(path)
    assert errors == []
    assert set(failed) <= EXPECTED_WARNINGS
    assert len(con.passes()) >= 50


def test_sicd_reads_back_identically_through_sarkit_and_sarpy(run, sicd_file):
    from sarpy.io.complex.converter import open_complex

    _, _, image = run
    pixels, xml = _read_sicd(sicd_file)
    # rows: slant range, columns: along track (increasing x for a right-looking track)
    expected = np.asarray(image.data).T.astype(np.complex64)
    assert pixels.dtype.kind == "c" and pixels.dtype.itemsize == 8  # complex float32
    assert pixels.shape == (N_RANGE, N_PULSES)
    np.testing.assert_array_equal(pixels, expected)
    np.testing.assert_array_equal(open_complex(str(sicd_file))[:, :], pixels)
    assert xml.findtext("{*}CollectionInfo/{*}Classification") == "UNCLASSIFIED"
    assert xml.findtext("{*}ImageData/{*}PixelType") == "RE32F_IM32F"
    assert xml.findtext("{*}Grid/{*}Type") == "RGZERO"
    assert xml.findtext("{*}ImageFormation/{*}ImageFormAlgo") == "RMA"


def test_sicd_geometry_matches_the_cphd_of_the_same_run(run, sicd_file, tmp_path):
    """The SCP (image centre: x of the middle pulse, r = r₀) is the CPHD's IARP, the SRP
    of its middle pulse; every pixel projects (through sarkit's own R/Rdot projection of
    the SICD metadata) to the ground point the CPHD frame gives its (x, r).

    Tolerances: 1 mm for the SCP (float64 rounding of ECF coordinates is ~1e-9 m);
    5 mm for the projection onto the frame's ground plane (the tangent plane at the
    IARP, through the SCP): the exact answer there, so what remains is the
    projection's iteration and rounding.
    """
    import sarkit.cphd as skcphd
    import sarkit.sicd as sksicd

    from sarjax.export._common import collection

    radar, raw, image = run
    cphd = to_cphd(tmp_path / "demo.cphd", radar, raw, track="nominal")
    with open(cphd, "rb") as f, skcphd.Reader(f) as reader:
        _, pvp = reader.read_channel("1")
        iarp = reader.metadata.xmltree.findtext("{*}SceneCoordinates/{*}IARP/{*}ECF/{*}X")
    srp_mid = pvp["SRPPos"][N_PULSES // 2].astype(float)
    _, xml = _read_sicd(sicd_file)
    helper = sksicd.XmlHelper(xml)
    scp = helper.load("{*}GeoData/{*}SCP/{*}ECF")
    np.testing.assert_allclose(scp, srp_mid, rtol=0, atol=1e-3)
    assert float(iarp) == pytest.approx(scp[0], abs=1e-3)
    # pixels of the two targets and two corners → ECF by sarkit's projection
    x, r = np.asarray(image.azimuth), np.asarray(image.range)
    index = np.array([[np.argmin(abs(r - rt)), np.argmin(abs(x - xt))]
                      for xt, rt in TARGETS] + [[0, 0], [N_RANGE - 1, N_PULSES - 1]])
    xrow_ycol = sksicd.rowcol_to_xrowycol(xml, index)
    frame = collection(radar, raw, None, "nominal", GeoReference()).frame
    projected, _, ok = sksicd.image_to_ground_plane(xml, xrow_ycol, scp, frame.up)
    assert ok
    h = float(radar.height)
    truth = frame.to_ecf(np.stack([x[index[:, 1]], np.sqrt(r[index[:, 0]] ** 2 - h**2),
                                   np.zeros(len(index))], axis=-1))
    np.testing.assert_allclose(projected, truth, rtol=0, atol=5e-3)


def test_sicd_focused_target_at_its_pixel(run, sicd_file):
    """The brightest pixel of the file is the first target's (x, r) (read through
    sarkit; one pixel = the grid step, the simulator puts targets on the grid here)."""
    radar, _, image = run
    pixels, _ = _read_sicd(sicd_file)
    row, col = np.unravel_index(np.argmax(np.abs(pixels)), pixels.shape)
    assert abs(float(image.range[row]) - TARGETS[0][1]) <= float(radar.range_spacing)
    assert abs(float(image.azimuth[col]) - TARGETS[0][0]) <= float(radar.azimuth_spacing)


def test_sicd_bad_input(run, tmp_path):
    radar, _, image = run
    cases = [
        (dict(azimuth_weighting="hamming"), "azimuth_weighting"),
        (dict(classification=""), "classification"),
    ]
    for kwargs, needle in cases:
        with pytest.raises(ValueError, match=needle):
            to_sicd(image, tmp_path / "bad.nitf", radar, **kwargs)
    with pytest.raises(ValueError, match="image.data"):
        to_sicd(sj.Image(data=np.abs(np.asarray(image.data)), azimuth=image.azimuth,
                         range=image.range), tmp_path / "bad.nitf", radar)
    uneven = sj.Image(data=image.data, azimuth=np.asarray(image.azimuth) ** 3,
                      range=image.range)
    with pytest.raises(ValueError, match="image.azimuth spacing"):
        to_sicd(uneven, tmp_path / "bad.nitf", radar)
    with pytest.raises(ValueError, match="squint"):
        to_sicd(image, tmp_path / "bad.nitf", radar.replace(squint=0.1))
    assert not (tmp_path / "bad.nitf").exists()


def test_cli_exports_a_focused_image_file(run, tmp_path, capsys):
    radar, raw, _ = run
    raw_file, image_file = tmp_path / "raw.nc", tmp_path / "image.nc"
    out = tmp_path / "image.nitf"
    sj.io.save(raw_file, raw, radar=radar)
    assert sarjax.cli.main(["focus", str(raw_file), "-o", str(image_file)]) == 0
    assert sarjax.cli.main(["export", str(image_file), "--format", "sicd", "-o",
                            str(out)]) == 0
    assert "SICD" in capsys.readouterr().out
    _, _, errors = _check(out)
    assert errors == []
    pixels, _ = _read_sicd(out)
    np.testing.assert_array_equal(
        pixels, np.asarray(sj.io.load(image_file).product.data).T.astype(np.complex64))
    # a raw-data file is refused for SICD (it needs an image)
    assert sarjax.cli.main(["export", str(raw_file), "--format", "sicd", "-o",
                            str(tmp_path / "x.nitf")]) == 2
    assert "expected Image" in capsys.readouterr().err


def test_sicd_leaves_out_rows_nearer_than_the_platform_height(run, tmp_path):
    """A window that starts short of the platform height (the airborne preset's starts
    104 m short): those rows see no ground and are left out; the rest pass the checker
    with no error. Its corners then lie near nadir, where the ground position is far from
    linear in the slant-plane grid: the checker's comparison of the (exactly projected)
    corners with the SCP's linear grid is a second warning there."""
    radar, _, image = run
    dr = float(radar.range_spacing)
    start = float(radar.height) - 5.5 * dr  # rows 0 … 5 nearer than H
    near = dataclasses.replace(image, range=start + dr * np.arange(image.range.size))
    path = to_sicd(near, tmp_path / "near.nitf", radar)
    con, failed, errors = _check(path)
    assert errors == [] and set(failed) <= EXPECTED_WARNINGS | {"check_image_corners"}
    pixels, _ = _read_sicd(path)
    assert pixels.shape == (image.range.size - 6, image.azimuth.size)
    np.testing.assert_array_equal(pixels, np.asarray(image.data)[:, 6:].T.astype(np.complex64))
