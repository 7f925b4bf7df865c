"""The building blocks on NumPy arrays: each against a closed form or the CLI on the same data
(written as an uncompressed TIFF by rasterio, read back by rasterio)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio

import aerorect
from conftest import ROOT, photo, run


def write_tif(path, array):
    array = array if array.ndim == 3 else array[None]
    with rasterio.open(path, "w", driver="GTiff", width=array.shape[2], height=array.shape[1],
                       count=array.shape[0], dtype=array.dtype) as dst:
        dst.write(array)
    return path


def read_tif(path):
    with rasterio.open(path) as src:
        return src.read()


def scene(rows=240, cols=320, bands=3, dtype=np.uint8, seed=1):
    """A smooth random texture (sums of sinusoids), exactly representable in `dtype`."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:rows, 0:cols].astype(np.float64)
    out = np.zeros((bands, rows, cols))
    for b in range(bands):
        for _ in range(6):
            fx, fy, ph = rng.uniform(0.01, 0.12), rng.uniform(0.01, 0.12), rng.uniform(0, 6.3)
            out[b] += np.sin(fx * x + fy * y + ph)
    out = (out - out.min()) / (out.max() - out.min())
    scale = {np.uint8: 255, np.uint16: 65535, np.float32: 1.0}[dtype]
    return (out * scale).astype(dtype)


CAMERA_TOML = "fx_px = 400.0\nfy_px = 400.0\nimage_size_px = [320, 240]\n"
ATTITUDE = dict(azimuth=20, elevation=20, image_rotation=2, pitch=3, roll=-2, yaw=15)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_rectify_is_the_cli(tmp_path, cli, dtype):
    a = scene(dtype=dtype)
    (tmp_path / "cam.toml").write_text(CAMERA_TOML)
    cam = aerorect.Camera.from_file(tmp_path / "cam.toml")
    out, report = aerorect.rectify(a, cam, ATTITUDE, interp="bicubic")
    inline = ",".join(f"{k}={v}" for k, v in ATTITUDE.items())
    run(cli, "rectify", write_tif(tmp_path / "in.tif", a), tmp_path / "out.tif", "--camera",
        tmp_path / "cam.toml", "--attitude", inline, "--interp", "bicubic", "--report",
        tmp_path / "r.json")
    assert out.dtype == a.dtype
    assert np.array_equal(out, read_tif(tmp_path / "out.tif"))
    theirs = json.loads((tmp_path / "r.json").read_text())
    assert report["homography_output_to_input"] == theirs["homography_output_to_input"]
    # The same from the attitude given as the CLI's inline text.
    out2, _ = aerorect.rectify(a, cam, inline, interp="bicubic")
    assert np.array_equal(out, out2)


def test_warp_by_a_translation_is_a_slice():
    a = scene(bands=2, dtype=np.float32)
    h = [[1, 0, 7], [0, 1, 5], [0, 0, 1]]  # output (c, r) takes input (c + 7, r + 5)
    out = aerorect.warp(a, h, (100, 150), interp="nearest")
    assert out.shape == (2, 100, 150)
    assert np.array_equal(out, a[:, 5:105, 7:157])
    # 2-D in, one band out; outside the input is nodata.
    out = aerorect.warp(a[0], h, (240, 320), interp="bilinear", nodata=-1)
    assert out.shape == (1, 240, 320)
    assert np.all(out[0, 236:, :] == -1) and np.allclose(out[0, :200, :300], a[0, 5:205, 7:307])


def test_shift_finds_a_known_translation():
    rng = np.random.default_rng(3)
    big = rng.random((160, 160))
    k = np.ones(3) / 3
    big = np.apply_along_axis(lambda r: np.convolve(r, k, "same"), 1, big)
    big = np.apply_along_axis(lambda r: np.convolve(r, k, "same"), 0, big).astype(np.float32)
    a = big[16:144, 16:144]
    b = big[13:141, 21:149]  # b[r, c] = a[r - 3, c + 5]: the content moved 5 px left, 3 down
    for method in ["phase", "jtc", "xcorr"]:
        s = aerorect.shift(a, b, method=method)
        assert s["dx"] == pytest.approx(-5, abs=0.05), method
        assert s["dy"] == pytest.approx(3, abs=0.05), method
    with pytest.raises(aerorect.AerorectError, match="unknown method 'nope'"):
        aerorect.shift(a, b, method="nope")


def test_undistort_is_the_cli(tmp_path, cli):
    a = scene()
    (tmp_path / "cam.toml").write_text(
        CAMERA_TOML + '[distortion]\nmodel = "opencv"\nk1 = -0.2\nk2 = 0.05\np1 = 0.001\n')
    cam = aerorect.Camera.from_file(tmp_path / "cam.toml")
    assert cam.distortion["model"] == "opencv" and cam.distortion["k1"] == -0.2
    out, ideal = aerorect.undistort(a, cam, fit=True)
    run(cli, "undistort", write_tif(tmp_path / "in.tif", a), tmp_path / "out.tif", "--camera",
        tmp_path / "cam.toml", "--fit")
    assert np.array_equal(out, read_tif(tmp_path / "out.tif"))
    assert ideal.distortion is None and (ideal.width, ideal.height) == out.shape[:0:-1]
    # The same camera from its intrinsics.
    same = aerorect.Camera.from_intrinsics(400, 400, 159.5, 119.5, 320, 240, cam.distortion)
    assert same == cam


def test_calibrate_is_the_cli(tmp_path, cli):
    pts = ROOT / "data" / "calib" / "left_corners.csv"
    cam, report = aerorect.calibrate(pts, (640, 480), "opencv", fix=["k3"])
    run(cli, "calibrate", "--points", pts, "--image-size", "640x480", "--model", "opencv",
        "--fix", "k3", "--json", tmp_path / "c.json")
    theirs = json.loads((tmp_path / "c.json").read_text())
    assert report["rms_px"] == theirs["rms_px"]
    assert (cam.fx, cam.fy, cam.cx, cam.cy) == (theirs["fx"], theirs["fy"], theirs["cx"],
                                                theirs["cy"])
    # OpenCV's calibrateCamera on these corners: about 0.4 px RMS.
    assert report["rms_px"] < 1.0


def test_camera_from_metadata(tmp_path):
    p = photo(tmp_path, "f.jpg", focal_px=612.5)
    cam = aerorect.Camera.from_metadata(p)
    # DJI's CalibratedFocalLength in pixels of the 640 x 480 image, centre at its middle.
    assert (cam.fx, cam.fy, cam.width, cam.height) == (612.5, 612.5, 640, 480)
    assert (cam.cx, cam.cy) == (319.5, 239.5)
    half = cam.resized(320, 240)
    assert half.fx == pytest.approx(306.25)


def test_bad_arrays_are_refused():
    cam = aerorect.Camera.from_intrinsics(400, 400, 159.5, 119.5, 320, 240)
    with pytest.raises(aerorect.AerorectError, match="float64"):
        aerorect.rectify(np.zeros((240, 320)), cam, ATTITUDE)
    with pytest.raises(aerorect.AerorectError, match="4 dimensions"):
        aerorect.warp(np.zeros((1, 1, 4, 4), np.uint8), np.eye(3).tolist(), (4, 4))
