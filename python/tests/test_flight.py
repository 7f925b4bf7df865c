"""The flight adjustment and the mosaic from Python: the mosaic is `aerorect mosaic`'s file
byte for byte; the adjusted flight reports real tie points, shrinks the pair's misalignment,
and writes each frame on batch --adjust's grid."""

from __future__ import annotations

import numpy as np
import pytest
import rasterio

import aerorect
from conftest import crop_photo, photo, run

EAST = 200 * 0.16 / (111320 * np.cos(np.radians(53.9)))  # 200 px at 80 m / 500 px


@pytest.fixture()
def pair(tmp_path):
    a = crop_photo(tmp_path, "a.jpg", 0, 400)
    b = crop_photo(tmp_path, "b.jpg", 200, 400, lon=27.55 + EAST, roll=0.5)
    return a, b


def test_mosaic_is_the_cli(tmp_path, cli):
    a = photo(tmp_path, "a.jpg", lat=53.9)
    b = photo(tmp_path, "b.jpg", lat=53.90015)
    r = aerorect.mosaic([a, b], tmp_path / "py.tif", gsd_m=0.2)
    run(cli, "mosaic", a, b, "--out", tmp_path / "cli.tif", "--gsd-m", "0.2")
    assert (tmp_path / "py.tif").read_bytes() == (tmp_path / "cli.tif").read_bytes()
    with rasterio.open(tmp_path / "py.tif") as src:
        assert src.count == 4 and src.res == pytest.approx((0.2, 0.2))
        assert [src.width, src.height] == r["size"]


def test_adjusted_flight(tmp_path, cli, pair):
    f = aerorect.adjust_flight(pair, gsd_m=0.2)
    assert len(f) == 2
    rep = f.report
    assert rep["adjustment"]["tie_points"] > 20
    p = rep["pairs"][0]
    # The roll error misaligns the pair by decimetres; the adjustment removes nearly all of it.
    assert p["misalignment_before_m"] > 0.1
    assert p["misalignment_after_m"] < p["misalignment_before_m"] / 5
    f.write_frame(1, tmp_path / "b.tif")
    run(cli, "batch", *pair, "--out-dir", tmp_path / "cli", "--gsd-m", "0.2", "--adjust")
    with rasterio.open(tmp_path / "b.tif") as x, rasterio.open(tmp_path / "cli" / "b.tif") as y:
        assert (x.transform, x.crs, x.shape) == (y.transform, y.crs, y.shape)
        d = np.abs(x.read().astype(int) - y.read().astype(int))
        assert d.max() <= 2 and (d > 0).mean() < 0.01
    m = f.mosaic(tmp_path / "m.tif")
    assert m["frames"][0]["cells"] > 0 and m["frames"][1]["cells"] > 0
    with pytest.raises(aerorect.AerorectError, match="frame 2: the flight has 2 frames"):
        f.write_frame(2, tmp_path / "x.tif")


def test_ground_control_report_is_the_cli(tmp_path, cli, pair):
    # Points where the recorded metadata puts them (gcp-predict's ODM list of a grid of
    # lon/lat points), given back as ground control; two kept as check points.
    lines = ["EPSG:4326"]
    for k, (dx, dy) in enumerate([(0.0, 0.0), (3e-5, 2e-5), (-2e-5, 3e-5), (4e-5, -3e-5)]):
        lines.append(f"{27.55 + EAST / 2 + dx} {53.9 + dy} 0 0 0 {pair[0].name} P{k}")
    raw = tmp_path / "raw.txt"
    raw.write_text("\n".join(lines) + "\n")
    run(cli, "gcp-predict", raw, "--photos", *pair, "--out-dir", tmp_path / "pred")
    gcps = tmp_path / "pred" / "gcp_predicted.txt"
    assert len(gcps.read_text().splitlines()) > 4
    f = aerorect.adjust_flight(pair, gsd_m=0.2, gcps=[gcps], checkpoints=["P1", "P3"])
    acc = f.report["accuracy"]
    run(cli, "batch", *pair, "--out-dir", tmp_path / "cli", "--gsd-m", "0.2", "--adjust",
        "--gcps", gcps, "--checkpoints", "P1,P3")
    import json
    assert acc == json.loads((tmp_path / "cli" / "accuracy.json").read_text())
    roles = {p["name"]: p["role"] for p in acc["points"]}
    assert roles == {"P0": "control", "P1": "check", "P2": "control", "P3": "check"}
    with pytest.raises(aerorect.AerorectError, match="check point 'Q' is not a point of"):
        aerorect.adjust_flight(pair, gsd_m=0.2, gcps=[gcps], checkpoints=["Q"])
