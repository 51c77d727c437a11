"""OpenEXR I/O of the thin-film LUT: bit-exact round trip, header contract, deterministic bytes, bad files."""

import os

import numpy as np
import pytest

from rockdove.lut import ThinFilmLUT
from rockdove.lut.exr import read_exr, write_exr


def _lut(n_thickness=6, n_angle=11, rng=(480.0, 700.0)):
    rgb = np.random.default_rng(1).normal(0.3, 0.4, size=(n_thickness, n_angle, 3)).astype(np.float32)
    rgb[0, 0] = (-0.125, 1e-30, 3.0e5)  # negative, subnormal-ish and large values survive
    return ThinFilmLUT(rgb, rng, angle_warp_gamma=2.75, colour_space="lin_rec709",
                       metadata={"film": "paper", "method": "fourier", "estimatedMaxDeltaE2000": "0.01"})


def test_round_trip_is_bit_exact_with_axes_and_metadata(tmp_path):
    lut = _lut()
    path = write_exr(lut, tmp_path / "lut.exr")
    back = read_exr(path)
    assert back.rgb.dtype == np.float32
    assert np.array_equal(back.rgb.view(np.uint32), lut.rgb.view(np.uint32))
    assert back.thickness_range_nm == lut.thickness_range_nm
    assert back.angle_warp_gamma == lut.angle_warp_gamma
    assert back.colour_space == lut.colour_space
    assert back.metadata == {**lut.metadata, "precision": "float32"}  # the header records the channel type
    c, d = np.array([0.0, 0.013, 0.5, 1.0]), np.array([480.0, 512.3, 699.0, 700.0])
    np.testing.assert_array_equal(back.sample(c, d), lut.sample(c, d))


def test_one_texel_high_round_trip(tmp_path):
    lut = _lut(n_thickness=1, rng=(650.0, 650.0))
    back = read_exr(write_exr(lut, tmp_path / "one.exr"))
    assert back.rgb.shape == (1, 11, 3)
    assert back.thickness_range_nm == (650.0, 650.0)
    assert np.array_equal(back.rgb, lut.rgb)


def test_header_attributes_and_bottom_row_is_thinnest(tmp_path):
    import OpenEXR

    lut = _lut()
    path = write_exr(lut, tmp_path / "lut.exr")
    with OpenEXR.File(str(path)) as f:
        header = dict(f.header())
        pixels = np.array(f.channels()["RGB"].pixels)
    assert header["rockdove:angleAxis"] == "cos_theta = x**gamma, x = j/(N-1)"
    assert float(header["rockdove:angleWarpGamma"]) == 2.75
    assert [float(v) for v in header["rockdove:thicknessRangeNm"].split()] == [480.0, 700.0]
    assert header["rockdove:colourSpace"] == "lin_rec709"
    assert header["rockdove:film"] == "paper"
    assert pixels.shape == (6, 11, 3)  # height n_thickness, width n_angle
    assert np.array_equal(pixels[-1], lut.rgb[0])  # bottom image row = thinnest film
    assert np.array_equal(pixels[0], lut.rgb[-1])


def test_same_lut_gives_identical_bytes(tmp_path):
    lut = _lut()
    a = write_exr(lut, tmp_path / "a.exr")
    b = write_exr(ThinFilmLUT(lut.rgb.copy(), lut.thickness_range_nm, lut.angle_warp_gamma,
                              lut.colour_space, dict(reversed(list(lut.metadata.items())))), tmp_path / "b.exr")
    assert open(a, "rb").read() == open(b, "rb").read()


def test_read_rejects_a_file_that_is_not_exr(tmp_path):
    p = tmp_path / "not.exr"
    p.write_bytes(b"P6\n1 1\n255\n\x00\x00\x00")
    with pytest.raises(ValueError, match="path.*not an OpenEXR file"):
        read_exr(p)


def test_read_rejects_an_exr_that_is_not_a_rockdove_lut(tmp_path):
    import OpenEXR

    p = tmp_path / "plain.exr"
    rgb = np.zeros((4, 5, 3), np.float32)
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, {"RGB": rgb}) as f:
        f.write(str(p))
    with pytest.raises(ValueError, match="not a rockdove LUT"):
        read_exr(p)


def test_read_missing_file_raises_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match="path"):
        read_exr(tmp_path / "missing.exr")


def test_write_rejects_a_non_lut(tmp_path):
    with pytest.raises(ValueError, match="lut must be a ThinFilmLUT"):
        write_exr(np.zeros((2, 2, 3)), tmp_path / "x.exr")


def test_half_precision_writes_half_channels_and_reads_back_exactly(tmp_path):
    import OpenEXR

    lut = ThinFilmLUT(np.random.default_rng(2).uniform(0, 1, (64, 256, 3)).astype(np.float32), (480.0, 700.0),
                      angle_warp_gamma=1.0, colour_space="lin_rec709", metadata={"film": "keratin"})
    full = write_exr(lut, tmp_path / "full.exr")
    half = write_exr(lut, tmp_path / "half.exr", precision="half")
    with OpenEXR.File(half) as f:
        assert f.channels()["RGB"].pixels.dtype == np.float16
        assert f.header()["rockdove:precision"] == "half"
    with OpenEXR.File(full) as f:
        assert f.channels()["RGB"].pixels.dtype == np.float32
        assert f.header()["rockdove:precision"] == "float32"
    back = read_exr(half)
    assert back.rgb.dtype == np.float32 and back.metadata["precision"] == "half"
    assert np.array_equal(back.rgb, lut.rgb.astype(np.float16).astype(np.float32))
    assert not np.array_equal(back.rgb, lut.rgb)  # it did round
    # random data compresses poorly under ZIP, so the size follows the channel width: about half
    assert os.path.getsize(half) < 0.6 * os.path.getsize(full)
    # a LUT whose metadata says half (the build's lut.precision = "half") is written half by default
    tagged = ThinFilmLUT(back.rgb, back.thickness_range_nm, 1.0, "lin_rec709", back.metadata)
    with OpenEXR.File(write_exr(tagged, tmp_path / "tagged.exr")) as f:
        assert f.channels()["RGB"].pixels.dtype == np.float16
    assert open(tmp_path / "tagged.exr", "rb").read() == open(half, "rb").read()


def test_bad_precision_and_header_channel_mismatch(tmp_path):
    import OpenEXR

    with pytest.raises(ValueError, match="precision='double'.*float32.*half"):
        write_exr(_lut(), tmp_path / "x.exr", precision="double")
    p = write_exr(_lut(), tmp_path / "y.exr")
    with OpenEXR.File(p) as f:
        header = dict(f.header())
        rgb = np.ascontiguousarray(np.clip(f.channels()["RGB"].pixels, -1e4, 1e4).astype(np.float16))
    header["rockdove:precision"] = "float32"
    with OpenEXR.File(header, {"RGB": rgb}) as f:
        f.write(str(tmp_path / "z.exr"))
    with pytest.raises(ValueError, match="precision.*half channels"):
        read_exr(tmp_path / "z.exr")
