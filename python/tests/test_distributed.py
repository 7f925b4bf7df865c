"""`aerorect.distributed.rectify_flight`: on a LocalCluster of two worker processes, and
without a client, the same files as `aerorect batch` (names, bytes: pixels and georeferencing),
and batch's refusals and failure report."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
import rasterio

import aerorect
from aerorect.distributed import output_paths, rectify_flight
from conftest import crop_photo, flight_photos, jpeg_with_xmp, photo, run, xmp


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("dask.distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def same_files(ours: Path, theirs: Path) -> list[str]:
    names = sorted(os.listdir(theirs))
    assert sorted(os.listdir(ours)) == names
    for n in names:
        a, b = (ours / n).read_bytes(), (theirs / n).read_bytes()
        if n.endswith(".json"):
            continue  # timings differ
        assert a == b, n
    return names


@pytest.mark.parametrize("use_client", [True, False])
def test_flight_is_batch_file_for_file(tmp_path, cli, client, use_client):
    photos = flight_photos(tmp_path, 6, cols=3)
    ours, theirs = tmp_path / "py", tmp_path / "cli"
    written = rectify_flight(photos, ours, gsd_m=0.2, client=client if use_client else None)
    run(cli, "batch", *photos, "--out-dir", theirs, "--gsd-m", "0.2")
    names = same_files(ours, theirs)
    assert names == sorted(f"DJI_{k:04d}.tif" for k in range(6))
    assert written == [str(ours / f"DJI_{k:04d}.tif") for k in range(6)]
    # Read back by rasterio: georeferenced on the shared 0.2 m grid.
    with rasterio.open(written[0]) as src:
        assert src.res == pytest.approx((0.2, 0.2)) and src.crs.to_epsg() == 32635


def test_png_and_options_are_batch(tmp_path, cli, client):
    photos = flight_photos(tmp_path, 3)
    ours, theirs = tmp_path / "py", tmp_path / "cli"
    rectify_flight(photos, ours, client=client, format="png", interp="nearest", nodata=3,
                   crs="EPSG:3857")
    run(cli, "batch", *photos, "--out-dir", theirs, "--format", "png", "--interp", "nearest",
        "--nodata", "3", "--crs", "EPSG:3857")
    names = same_files(ours, theirs)
    assert "DJI_0000.png" in names and "DJI_0000.pgw" in names


def without_seconds(v):
    if isinstance(v, dict):
        return {k: without_seconds(x) for k, x in v.items() if k != "seconds"}
    if isinstance(v, list):
        return [without_seconds(x) for x in v]
    return v


def test_adjusted_flight_is_batch_adjust(tmp_path, cli, client):
    # Two crops of one photo, 200 px (32 m at 0.16 m/px) apart east, the second recorded with
    # a 0.5 degree roll error: the adjustment has real tie points to work with.
    east = 200 * 0.16 / (111320 * np.cos(np.radians(53.9)))
    a = crop_photo(tmp_path, "a.jpg", 0, 400)
    b = crop_photo(tmp_path, "b.jpg", 200, 400, lon=27.55 + east, roll=0.5)
    ours, theirs = tmp_path / "py", tmp_path / "cli"
    run(cli, "batch", a, b, "--out-dir", theirs, "--gsd-m", "0.2", "--adjust")
    written = rectify_flight([a, b], ours, gsd_m=0.2, adjust=True, client=client)
    assert [Path(w).name for w in written] == ["a.tif", "b.tif", "adjustment.json",
                                               "adjusted_poses.csv", "adjusted_poses.prj"]
    assert sorted(os.listdir(ours)) == sorted(os.listdir(theirs))
    assert (ours / "adjusted_poses.prj").read_bytes() == (theirs / "adjusted_poses.prj").read_bytes()
    mine_poses = np.genfromtxt(ours / "adjusted_poses.csv", delimiter=",", names=True, dtype=None)
    cli_poses = np.genfromtxt(theirs / "adjusted_poses.csv", delimiter=",", names=True, dtype=None)
    for k in ["x", "y", "z", "omega", "phi", "kappa"]:
        assert np.allclose(mine_poses[k], cli_poses[k], rtol=0, atol=1e-4), k
    # `batch --adjust` itself differs from run to run in the last digits of the adjusted
    # angles (about 1e-7 relative: the solver's parallel sums), so the frames are compared
    # through rasterio: the same grids, and pixels within 1 DN almost everywhere.
    for name in ["a.tif", "b.tif"]:
        with rasterio.open(ours / name) as x, rasterio.open(theirs / name) as y:
            assert (x.transform, x.crs, x.shape, x.count) == (y.transform, y.crs, y.shape,
                                                              y.count)
            d = np.abs(x.read().astype(int) - y.read().astype(int))
            assert d.max() <= 2 and (d > 0).mean() < 0.01, name
    mine = without_seconds(json.loads((ours / "adjustment.json").read_text()))
    cli_report = without_seconds(json.loads((theirs / "adjustment.json").read_text()))
    assert approx_equal(mine, cli_report)
    assert mine["adjustment"]["tie_points"] > 20
    assert mine["pairs"][0]["misalignment_after_m"] < mine["pairs"][0]["misalignment_before_m"]


def approx_equal(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(approx_equal(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(approx_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, (int, float)):
        return a == pytest.approx(b, rel=1e-3, abs=1e-6)
    return a == b


def test_existing_outputs_are_skipped_and_failures_listed(tmp_path, client):
    photos = flight_photos(tmp_path, 2)
    bad = jpeg_with_xmp(tmp_path / "bad.jpg", None)
    out = tmp_path / "out"
    out.mkdir()
    (out / "DJI_0000.tif").write_bytes(b"kept")
    with pytest.raises(aerorect.AerorectError) as e:
        rectify_flight(photos + [bad], out, client=client)
    assert "1 of 3 frames failed" in str(e.value) and "bad.jpg" in str(e.value)
    assert (out / "DJI_0000.tif").read_bytes() == b"kept"  # skipped, not rewritten
    with rasterio.open(out / "DJI_0001.tif") as src:
        assert src.count == 3
    rectify_flight(photos, out, client=client, force=True)
    assert (out / "DJI_0000.tif").read_bytes() != b"kept"


def test_colliding_names_are_refused(tmp_path):
    (tmp_path / "x").mkdir()
    (tmp_path / "y").mkdir()
    a = photo(tmp_path / "x", "F.jpg")
    b = photo(tmp_path / "y", "F.jpg")
    with pytest.raises(aerorect.AerorectError, match="would both be written to"):
        rectify_flight([a, b], tmp_path / "out")
    assert not (tmp_path / "out").exists()
    assert output_paths(["/a/b.c.JPG"], "o") == [os.path.join("o", "b.tif")]


def test_fsspec_urls_round_trip(tmp_path, cli):
    fsspec = pytest.importorskip("fsspec")
    photos = flight_photos(tmp_path, 2)
    fs = fsspec.filesystem("memory")
    for p in photos:
        fs.pipe(f"/in/{p.name}", p.read_bytes())
    urls = [f"memory://in/{p.name}" for p in photos]
    written = rectify_flight(urls, "memory://out", gsd_m=0.2)
    assert written == ["memory://out/DJI_0000.tif", "memory://out/DJI_0001.tif"]
    run(cli, "batch", *photos, "--out-dir", tmp_path / "cli", "--gsd-m", "0.2")
    for w in written:
        name = w.rsplit("/", 1)[1]
        assert fs.cat(w.replace("memory://", "/")) == (tmp_path / "cli" / name).read_bytes()


@pytest.mark.parametrize("use_client", [True, False])
def test_mosaic_tile_by_tile_is_the_cli(tmp_path, cli, client, use_client):
    from aerorect.distributed import mosaic

    photos = flight_photos(tmp_path, 6, cols=3)
    r = mosaic(photos, tmp_path / "py.tif", gsd_m=0.2, client=client if use_client else None,
               tiles_per_task=1)
    run(cli, "mosaic", *photos, "--out", tmp_path / "cli.tif", "--gsd-m", "0.2")
    assert (tmp_path / "py.tif").read_bytes() == (tmp_path / "cli.tif").read_bytes()
    assert r["tiles"] >= 2  # several tasks
    whole = aerorect.mosaic(photos, tmp_path / "whole.tif", gsd_m=0.2)
    assert [f["cells"] for f in r["frames"]] == [f["cells"] for f in whole["frames"]]
    assert r["covered_cells"] == whole["covered_cells"] > 0


def test_adjusted_flight_pair_by_pair_is_batch_adjust_to_the_bit(tmp_path, cli, client):
    # Three crops of one photo, 120 px (19.2 m at 0.16 m/px) apart east: three overlapping
    # pairs, each matched by its own task; two crops recorded with attitude errors.
    distributed = pytest.importorskip("dask.distributed")
    east = 120 * 0.16 / (111320 * np.cos(np.radians(53.9)))
    photos = [
        crop_photo(tmp_path, "a.jpg", 0, 400),
        crop_photo(tmp_path, "b.jpg", 120, 400, lon=27.55 + east, roll=0.5),
        crop_photo(tmp_path, "c.jpg", 240, 400, lon=27.55 + 2 * east, pitch=-89.6),
    ]
    ours, theirs = tmp_path / "py", tmp_path / "cli"
    run(cli, "batch", *photos, "--out-dir", theirs, "--gsd-m", "0.2", "--adjust")
    with distributed.get_task_stream(client) as ts:
        written = rectify_flight(photos, ours, gsd_m=0.2, adjust=True, client=client)
    prefixes = [t["key"][0] if isinstance(t["key"], tuple) else t["key"] for t in ts.data]
    pair_tasks = [k for k in prefixes if str(k).startswith("_flight_pair-")]
    frame_tasks = [k for k in prefixes if str(k).startswith("_flight_write-")]
    feature_tasks = [k for k in prefixes if str(k).startswith("_flight_features-")]
    feature_pair_tasks = [k for k in prefixes if str(k).startswith("_flight_feature_match-")]
    assert [Path(w).name for w in written] == ["a.tif", "b.tif", "c.tif", "adjustment.json",
                                               "adjusted_poses.csv", "adjusted_poses.prj"]
    assert sorted(os.listdir(ours)) == sorted(os.listdir(theirs))  # no staging folder left
    for name in ["a.tif", "b.tif", "c.tif", "adjusted_poses.csv", "adjusted_poses.prj"]:
        assert (ours / name).read_bytes() == (theirs / name).read_bytes(), name
    mine = json.loads((ours / "adjustment.json").read_text())
    cli_report = json.loads((theirs / "adjustment.json").read_text())
    # Everything but the timings to the bit: tie points, residuals, adjusted poses.
    assert without_seconds(mine) == without_seconds(cli_report)
    passes = mine["passes"]
    assert mine["adjustment"]["tie_points"] > 20 and len(mine["pairs"]) == 3
    # The first round: features per frame, matches per pair, each its own task; every later
    # round matched its three pairs in three tasks; every frame was written by its own task.
    assert len(feature_tasks) == 3 and len(feature_pair_tasks) == 3
    assert len(pair_tasks) == 3 * (passes - 1) and len(frame_tasks) == 3


def box_photo(dir_: Path, name: str, col0: int, row0: int, side: int, **kw) -> Path:
    """A side x side crop of data/aero1.jpg at (col0, row0), placed on the ground as far from
    the first crop as its pixels are (0.16 m/px: 500 px focal length, 80 m up, north up)."""
    from conftest import AERO1

    with rasterio.open(AERO1) as src:
        a = src.read()[:, row0:row0 + side, col0:col0 + side]
    tmp = dir_ / (name + ".crop.jpg")
    with rasterio.open(tmp, "w", driver="JPEG", width=side, height=side, count=3,
                       dtype="uint8", QUALITY=95) as dst:
        dst.write(a)
    lat = 53.9 - row0 * 0.16 / 111320
    lon = 27.55 + col0 * 0.16 / (111320 * np.cos(np.radians(53.9)))
    out = jpeg_with_xmp(dir_ / name, xmp(lat=lat, lon=lon, **kw), source=tmp)
    for side_file in dir_.glob(name + ".crop.jpg*"):
        side_file.unlink()
    return out


def test_a_large_flight_matched_in_two_steps_is_batch_adjust_to_the_bit(tmp_path, cli, client):
    # 54 overlapping crops of one photo under a 5 degree attitude prior: too wide to guide
    # the feature matching, so a net of pairs is matched and solved first and the other
    # pairs are guided by that solve (two steps, MIN_STEPPED_FRAMES = 50), each step its own
    # tasks; the result is batch --adjust's to the bit.
    distributed = pytest.importorskip("dask.distributed")
    photos = [box_photo(tmp_path, f"f{r}{c}.jpg", 20 + 55 * c, 10 + 54 * r, 160,
                        roll=0.3 * ((r + c) % 3 - 1), pitch=-90 + 0.2 * (c % 2))
              for r in range(6) for c in range(9)]
    ours, theirs = tmp_path / "py", tmp_path / "cli"
    run(cli, "batch", *photos, "--out-dir", theirs, "--gsd-m", "0.2", "--adjust",
        "--attitude-sigma-deg", "5")
    with distributed.get_task_stream(client) as ts:
        rectify_flight(photos, ours, gsd_m=0.2, adjust=True, client=client,
                       attitude_sigma_deg=5.0)
    prefixes = [t["key"][0] if isinstance(t["key"], tuple) else t["key"] for t in ts.data]
    count = lambda name: sum(str(k).startswith(name + "-") for k in prefixes)  # noqa: E731
    assert count("_flight_step_guide") == 1 and count("_flight_step_features") == 54
    assert sorted(os.listdir(ours)) == sorted(os.listdir(theirs))
    for name in os.listdir(theirs):
        if name != "adjustment.json":
            assert (ours / name).read_bytes() == (theirs / name).read_bytes(), name
    mine = json.loads((ours / "adjustment.json").read_text())
    assert without_seconds(mine) == without_seconds(
        json.loads((theirs / "adjustment.json").read_text()))
    # Both steps tied: every frame is connected, by more reliable pairs than a chain needs.
    assert sum(p["reliable"] for p in mine["pairs"]) > 2 * 54 and not mine["unconnected"]


def test_adjusted_flight_with_a_tie_surface_is_batch_adjust_to_the_bit(tmp_path, cli, client):
    # (extended) Two DJI frames: their rounds end with the solve over every tie, whose 181
    # ties make a tie surface, so the progress the frame tasks take is about 200 kB (Dask
    # makes a `map` keyword that large a graph node of its own: it is scattered instead).
    pytest.importorskip("dask.distributed")
    data = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "drone-xmp"
    photos = [data / "DJI_0010.JPG", data / "DJI_0012.JPG"]
    if not all(p.exists() for p in photos):
        pytest.skip("SKIP: no ../shared/data/drone-xmp")
    ours, theirs = tmp_path / "py", tmp_path / "cli"
    run(cli, "batch", *photos, "--out-dir", theirs, "--gsd-m", "0.1", "--adjust")
    rectify_flight([str(p) for p in photos], ours, gsd_m=0.1, adjust=True, client=client)
    for name in ["DJI_0010.tif", "DJI_0012.tif", "adjusted_poses.csv", "adjusted_poses.prj"]:
        assert (ours / name).read_bytes() == (theirs / name).read_bytes(), name
    mine = json.loads((ours / "adjustment.json").read_text())
    cli_report = json.loads((theirs / "adjustment.json").read_text())
    assert without_seconds(mine) == without_seconds(cli_report)
    assert mine["surface"] is not None and mine["rounds"][-1]["final_solve"]["tie_points"] > 100
