#!/usr/bin/env python3
"""GDAL's view of aerorect's cloud-optimised GeoTIFFs: rio-cogeo's validator and rasterio.

Writes inputs with rasterio (plain striped GeoTIFFs: RGB u8, RGBA u8, u16 with nodata holes;
../shared/data/ngi/dem.tif, f32 with NaN nodata, when present), turns each into a COG with
aerorect's `write_cog` example (crates/aerorect-io/examples/write_cog.rs), then checks every
output: `rio cogeo validate` says it is a valid cloud optimized GeoTIFF (no errors, no
warnings), GDAL sees it tiled with the expected overview factors, the CRS, transform and
nodata of the input, the full resolution equal to the input (Deflate; JPEG within its
error), every overview equal to the 2x2 mean of the valid children computed here in numpy
(JPEG within its error), and the internal mask equal to the alpha band > 0 (nearest in the
overviews). Prints OK/FAIL per file; exits non-zero on any FAIL.

Result stored in crates/aerorect-io/tests/cog.rs (rio-cogeo 7.0.4, rasterio 1.4.4, GDAL 3.10.3).
usage: python3 bench/check_cog.py
"""
import os, subprocess, sys, tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402

ensure_venv(["rasterio", "numpy", "rio-cogeo"], ["rasterio", "numpy", "rio_cogeo"])
import numpy as np  # noqa: E402
import rasterio  # noqa: E402
from rasterio.transform import from_origin  # noqa: E402
from rasterio.warp import transform  # noqa: E402
from rio_cogeo.cogeo import cog_validate  # noqa: E402

DEM = os.path.join(ROOT, "..", "shared", "data", "ngi", "dem.tif")


def pattern(h, w, bands, top):
    y, x = np.mgrid[0:h, 0:w].astype(np.uint64)
    out = []
    for b in range(bands):
        hsh = ((x * 2654435761) ^ (y * 40503) ^ (b * 97)) >> 7
        out.append((x + 2 * y + hsh % 17 + b * 31) % (top + 1))
    return np.stack(out)


def smooth(h, w, bands):
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    return np.stack([np.round(128 + 90 * np.sin(x / 37 + b) * np.cos(y / 53)) for b in range(bands)]).astype(np.uint8)


def write_input(path, data, nodata=None, crs="EPSG:32635"):
    count, h, w = data.shape
    with rasterio.open(path, "w", driver="GTiff", width=w, height=h, count=count, dtype=data.dtype,
                       crs=crs, transform=from_origin(500000, 5975000, 0.5, 0.5), nodata=nodata) as ds:
        ds.write(data)


def half(planes, valid, integer):
    """2x2 mean of the valid children (a (bands, h, w) array, valid (bands, h, w) bools)."""
    b, h, w = planes.shape
    h2, w2 = (h + 1) // 2, (w + 1) // 2
    s = np.zeros((b, h2 * 2, w2 * 2))
    n = np.zeros_like(s)
    s[:, :h, :w] = np.where(valid, planes, 0)
    n[:, :h, :w] = valid
    s = s.reshape(b, h2, 2, w2, 2).sum(axis=(2, 4))
    n = n.reshape(b, h2, 2, w2, 2).sum(axis=(2, 4))
    with np.errstate(invalid="ignore", divide="ignore"):
        m = s / n
    if integer:
        m = np.floor(m + 0.5)
    return m, n > 0


def check(name, src, cog, args, kind):
    """kind: 'exact', 'jpeg' or 'float'. Returns a list of failures."""
    fails = []
    run = subprocess.run([EXAMPLE, src, cog, *args], capture_output=True, text=True)
    if run.returncode != 0:
        return [f"write_cog failed: {run.stderr.strip()}"]
    valid, errors, warnings = cog_validate(cog, quiet=True)
    cli = subprocess.run([os.path.join(os.path.dirname(sys.executable), "rio"), "cogeo", "validate", cog],
                         capture_output=True, text=True)
    print(f"  rio cogeo validate: {cli.stdout.strip() or cli.stderr.strip()}")
    if not valid or errors or warnings or "is a valid cloud optimized GeoTIFF" not in cli.stdout:
        fails.append(f"rio-cogeo: valid={valid} errors={errors} warnings={warnings}")
    with rasterio.open(src) as s, rasterio.open(cog) as c:
        inp = s.read()
        alpha_mask = "--mask-alpha" in args
        bands = s.count - 1 if alpha_mask else s.count
        if c.count != bands:
            fails.append(f"{c.count} bands, expected {bands}")
        if not c.profile.get("tiled"):
            fails.append("not tiled")
        if c.transform != s.transform:
            fails.append(f"transform differs: {c.transform}")
        if c.crs != s.crs:
            # aerorect keeps the horizontal CRS of a compound one (the NGI DEM's): same
            # coordinates through PROJ is the test.
            xs, ys = [s.bounds.left, s.bounds.right], [s.bounds.bottom, s.bounds.top]
            gx, gy = transform(s.crs, c.crs, xs, ys)
            if max(abs(a - b) for a, b in zip(gx + gy, xs + ys)) > 1e-6:
                fails.append(f"CRS differs: {c.crs}")
            else:
                print("  CRS: the horizontal part of the input's (PROJ maps it to the same coordinates)")
        nd = s.nodata
        if not (c.nodata == nd or (nd is not None and c.nodata is not None and np.isnan(nd) and np.isnan(c.nodata))):
            fails.append(f"nodata {c.nodata}, expected {nd}")
        full = c.read()
        ref = inp[:bands].astype(np.float64)
        got = full.astype(np.float64)
        if kind == "jpeg":
            err = np.abs(got - ref)
            if err.mean() > 1.5:
                fails.append(f"full resolution: JPEG mean error {err.mean():.2f}")
        elif not np.array_equal(got, ref, equal_nan=True):
            fails.append("full resolution differs from the input")
        if alpha_mask:
            mask = inp[-1] > 0
            if not np.array_equal(c.dataset_mask() > 0, mask):
                fails.append("internal mask differs from alpha > 0")
            valid_px = np.broadcast_to(mask, ref.shape)
        elif nd is not None:
            valid_px = ~np.isnan(ref) if np.isnan(nd) else ref != nd
        else:
            valid_px = np.ones(ref.shape, bool)
        factors = c.overviews(1)
        h, w = c.height, c.width
        expect, f = [], 1
        while h > TILE[name] or w > TILE[name]:
            f, h, w = f * 2, (h + 1) // 2, (w + 1) // 2
            expect.append(f)
        if factors != expect:
            fails.append(f"overview factors {factors}, expected {expect}")
        level, lvalid, msk = ref, valid_px, (inp[-1] > 0 if alpha_mask else None)
        for i, _ in enumerate(factors):
            level, ok = half(level, lvalid, kind != "float")
            if alpha_mask:
                msk = msk[::2, ::2]
                lvalid = np.broadcast_to(msk, level.shape)
            else:
                fill = np.nan if nd is None or np.isnan(nd) else nd
                level = np.where(ok, level, fill if nd is not None else 0)
                lvalid = ok if nd is not None else np.ones(level.shape, bool)
            with rasterio.open(cog, OVERVIEW_LEVEL=i) as o:
                ov = o.read().astype(np.float64)
                if alpha_mask and not np.array_equal(o.dataset_mask() > 0, msk):
                    fails.append(f"overview {i}: mask differs from the nearest alpha")
            cmp_valid = lvalid if alpha_mask else np.ones(level.shape, bool)
            if kind == "exact":
                same = np.array_equal(np.where(cmp_valid, ov, 0), np.where(cmp_valid, level, 0), equal_nan=True)
            elif kind == "float":
                same = np.allclose(ov, level, rtol=1e-5, atol=1e-3, equal_nan=True)
            else:
                same = np.abs(np.where(cmp_valid, ov - level, 0)).mean() < 2.0
            if not same:
                fails.append(f"overview {i} ({o.width} x {o.height}) differs from the 2x2 mean")
    return fails


TILE = {}


def main():
    global EXAMPLE
    subprocess.check_call(["cargo", "build", "--release", "-q", "-p", "aerorect-io", "--example", "write_cog"], cwd=ROOT)
    EXAMPLE = os.path.join(ROOT, "target", "release", "examples", "write_cog")
    tmp = tempfile.mkdtemp()
    cases = []
    p = os.path.join(tmp, "rgb.tif")
    write_input(p, pattern(1100, 1500, 3, 255).astype(np.uint8))
    cases.append(("rgb_deflate", p, ["--tile", "256"], "exact", 256))
    cases.append(("bigtiff", p, ["--tile", "512", "--bigtiff"], "exact", 512))
    p = os.path.join(tmp, "rgba.tif")
    rgba = np.concatenate([smooth(900, 1200, 3), np.where(np.arange(1200)[None, None, :] > 100, 255, 0).repeat(900, 1).astype(np.uint8)])
    write_input(p, rgba)
    cases.append(("rgb_jpeg_mask", p, ["--tile", "256", "--jpeg", "90", "--mask-alpha"], "jpeg", 256))
    p = os.path.join(tmp, "u16.tif")
    d = pattern(1500, 2000, 1, 4000).astype(np.uint16) + 1
    y, x = np.mgrid[0:1500, 0:2000]
    d[0, (x < 300) | ((x + y) % 7 == 0)] = 0
    write_input(p, d, nodata=0)
    cases.append(("u16_nodata", p, [], "exact", 512))
    if os.path.exists(DEM):
        cases.append(("dem_f32", DEM, ["--tile", "128"], "float", 128))
    else:
        print("dem_f32: SKIP (../shared/data/ngi/dem.tif is absent)")
    bad = 0
    for name, src, args, kind, tile in cases:
        TILE[name] = tile
        cog = os.path.join(tmp, name + ".tif")
        print(f"{name}: {' '.join(args) or '(defaults)'}")
        fails = check(name, src, cog, args, kind)
        with rasterio.open(cog) as c:
            desc = f"{c.width} x {c.height} {c.dtypes[0]} x{c.count}, {c.compression.value if c.compression else 'none'}, overviews {c.overviews(1)}"
        print(f"  {'OK' if not fails else 'FAIL'}  {desc}, {os.path.getsize(cog)} bytes")
        for f in fails:
            print(f"    {f}")
        bad += bool(fails)
    print(f"{len(cases) - bad}/{len(cases)} OK")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
