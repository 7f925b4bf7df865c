"""`rectify_photo`: the same pixels and georeferencing as `aerorect rectify PHOTO OUT`, read back
by rasterio (an independent GeoTIFF reader); the profile writes through rasterio and reads back
unchanged; errors carry the CLI's messages, with the keyword for the flag."""

from __future__ import annotations

import re

import numpy as np
import pytest
import rasterio
from rasterio.transform import Affine

import aerorect
from conftest import cli_error, jpeg_with_xmp, photo, run

CASES = [
    # (photo tags, python kwargs, CLI flags)
    (dict(yaw=25.0, pitch=-60.0), {}, []),
    (dict(yaw=-40.0, pitch=-75.0, roll=2.0), dict(gsd_m=0.25, interp="bicubic"),
     ["--gsd-m", "0.25", "--interp", "bicubic"]),
    (dict(yaw=10.0, pitch=-90.0), dict(gsd_m=0.2, crs="EPSG:3857", nodata=7, alpha=True),
     ["--gsd-m", "0.2", "--crs", "EPSG:3857", "--nodata", "7", "--alpha"]),
    (dict(yaw=0.0, pitch=-80.0), dict(ground_height_m=240.0, boresight_deg=(1, -2, 3),
                                      lever_arm_m=(0.1, 0.2, 0.3)),
     ["--ground-height-m", "240", "--boresight-deg", "1,-2,3", "--lever-arm-m", "0.1,0.2,0.3"]),
]


@pytest.mark.parametrize("tags,kwargs,flags", CASES)
def test_rectify_photo_is_the_cli_pixel_for_pixel(tmp_path, cli, tags, kwargs, flags):
    p = photo(tmp_path, "frame.jpg", **tags)
    array, profile = aerorect.rectify_photo(p, **kwargs)
    out = tmp_path / "cli.tif"
    run(cli, "rectify", p, out, *flags)
    with rasterio.open(out) as src:
        theirs = src.read()
        assert array.shape == theirs.shape == (profile["count"], profile["height"],
                                               profile["width"])
        assert array.dtype == theirs.dtype == np.dtype(profile["dtype"])
        assert np.array_equal(array, theirs)
        assert Affine(*profile["transform"]) == src.transform
        assert rasterio.crs.CRS.from_user_input(profile["crs"]) == src.crs
        assert profile["nodata"] == src.nodata
    # Something was drawn (not an all-nodata frame).
    assert (array[0] != (kwargs.get("nodata", 0))).mean() > 0.3


def test_profile_writes_through_rasterio(tmp_path):
    p = photo(tmp_path, "frame.jpg", yaw=30.0, pitch=-70.0)
    array, profile = aerorect.rectify_photo(p, gsd_m=0.3)
    prof = {**profile, "transform": Affine(*profile["transform"])}
    with rasterio.open(tmp_path / "mine.tif", "w", **prof) as dst:
        dst.write(array)
    with rasterio.open(tmp_path / "mine.tif") as src:
        assert np.array_equal(src.read(), array)
        assert src.transform == prof["transform"]
        assert src.crs == rasterio.crs.CRS.from_user_input(profile["crs"])
        assert src.res == pytest.approx((0.3, 0.3))


def test_report_and_file_writer_agree_with_the_array(tmp_path):
    p = photo(tmp_path, "frame.jpg", yaw=15.0, pitch=-65.0)
    array, profile, report = aerorect.rectify_photo(p, with_report=True)
    assert report["output_size"] == [profile["width"], profile["height"]]
    # 80 m above ground with fx = 500 px: the nadir GSD is 80 / 500 m.
    assert report["info"]["gsd_m"] == pytest.approx(80.0 / 500.0)
    assert profile["transform"][0] == pytest.approx(80.0 / 500.0)
    out = tmp_path / "py.tif"
    r = aerorect.rectify_photo_to_file(p, out)
    assert r["output"] == str(out)
    with rasterio.open(out) as src:
        assert np.array_equal(src.read(), array)


def test_pose_and_crs_are_the_cli(tmp_path, cli):
    p = photo(tmp_path, "frame.jpg")
    pose = (500000.0, 5970000.0, 120.0, 5.0, -3.0, 30.0)
    kw = dict(crs="EPSG:32635", ground_height_m=20.0, gsd_m=0.3)
    array, profile = aerorect.rectify_photo(p, pose=pose, **kw)
    out = tmp_path / "cli.tif"
    run(cli, "rectify", p, out, "--pose", ",".join(map(str, pose)), "--crs", "EPSG:32635",
        "--ground-height-m", "20", "--gsd-m", "0.3")
    with rasterio.open(out) as src:
        assert np.array_equal(src.read(), array)
        assert Affine(*profile["transform"]) == src.transform
    # The grid's centre is near the pose's nadir point (a small tilt, 100 m up).
    t = profile["transform"]
    cx = t[2] + t[0] * profile["width"] / 2
    assert abs(cx - 500000.0) < 100.0


@pytest.mark.parametrize("packet,kwargs,flags", [
    (None, {}, []),
    ("nogps", {}, []),
    ("ok", dict(crs="EPSG:4326"), ["--crs", "EPSG:4326"]),
    ("ok", dict(crs="EPSG:nonsense"), ["--crs", "EPSG:nonsense"]),
    ("ok", dict(interp="cubic-spline"), ["--interp", "cubic-spline"]),
])
def test_errors_carry_the_cli_message(tmp_path, cli, packet, kwargs, flags):
    from conftest import xmp

    if packet == "ok":
        p = photo(tmp_path, "frame.jpg")
    elif packet == "nogps":
        p = jpeg_with_xmp(tmp_path / "frame.jpg", xmp(53.9, 27.55).replace("GpsLat", "GpsLet"))
    else:
        p = jpeg_with_xmp(tmp_path / "frame.jpg", None)
    with pytest.raises(aerorect.AerorectError) as e:
        aerorect.rectify_photo(p, **kwargs)
    got = run(cli, "rectify", p, tmp_path / "o.tif", *flags, ok=False)
    msg = cli_error(got)
    if packet == "ok" and "interp" in kwargs:
        # clap words its own value errors; both name the value.
        assert "cubic-spline" in str(e.value) and "cubic-spline" in got.stderr
    else:
        # The same message; each front end spells the option its own way (--crs X, crs=X;
        # give --camera, give camera).
        keywords = re.sub(r"--([a-z][a-z-]*)", lambda m: m[1].replace("-", "_"),
                          msg.replace("--crs ", "crs=", 1))
        assert str(e.value) == keywords
    assert not (tmp_path / "o.tif").exists()


def test_read_photo_metadata(tmp_path):
    p = photo(tmp_path, "frame.jpg", lat=-33.5, lon=151.25, yaw=12.5, pitch=-45.0, rel=55.0)
    m = aerorect.read_photo_metadata(p)
    assert m["latitude_deg"] == pytest.approx(-33.5)
    assert m["longitude_deg"] == pytest.approx(151.25)
    assert m["dji"]["gimbal_yaw_deg"] == pytest.approx(12.5)
    assert m["dji"]["gimbal_pitch_deg"] == pytest.approx(-45.0)
    assert m["dji"]["relative_altitude_m"] == pytest.approx(55.0)


def test_dem_is_the_cli(tmp_path, cli):
    """Over a sloping DEM (a GeoTIFF rasterio writes, in the photo's UTM zone): the same
    pixels and grid as `rectify --dem`."""
    from rasterio.warp import transform

    xs, ys = transform("EPSG:4326", "EPSG:32635", [27.55], [53.9])
    x0, y0 = xs[0] - 200.0, ys[0] + 200.0
    col = np.arange(200, dtype=np.float32)
    heights = (230.0 + 0.05 * 2.0 * col)[None, :].repeat(200, axis=0)[None]
    dem = tmp_path / "dem.tif"
    with rasterio.open(dem, "w", driver="GTiff", width=200, height=200, count=1,
                       dtype="float32", crs="EPSG:32635",
                       transform=Affine(2.0, 0, x0, 0, -2.0, y0)) as dst:
        dst.write(heights)
    p = photo(tmp_path, "frame.jpg", yaw=30.0, pitch=-70.0)
    array, profile = aerorect.rectify_photo(p, gsd_m=0.25, dem=dem)
    out = tmp_path / "cli.tif"
    run(cli, "rectify", p, out, "--gsd-m", "0.25", "--dem", dem)
    with rasterio.open(out) as src:
        assert np.array_equal(src.read(), array)
        assert Affine(*profile["transform"]) == src.transform
    # Not the level-ground ortho: the terrain moved the grid or the pixels.
    flat, flat_profile = aerorect.rectify_photo(p, gsd_m=0.25, ground_height_m=230.0)
    assert flat.shape != array.shape or not np.array_equal(flat, array)
