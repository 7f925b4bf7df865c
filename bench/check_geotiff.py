#!/usr/bin/env python3
"""An independent reader's view of aerorect's GeoTIFFs: GDAL through rasterio.

Rectifies DJI frames from ../shared/data/drone-xmp from their metadata (aerorect rectify, no
--camera/--attitude) and checks with rasterio that each GeoTIFF has the CRS (EPSG), the
geotransform, the size and the nodata value of aerorect's JSON report, that GDAL reads the
pixel-is-area raster type, and that PROJ puts the camera's GPS position at the report's
easting/northing. Exits non-zero on any mismatch.
usage: python3 bench/check_geotiff.py [--gsd-m G] [FRAMES...]
"""
import argparse, glob, json, os, subprocess, sys, tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402

ensure_venv(["rasterio", "numpy"], ["rasterio", "numpy"])
import rasterio  # noqa: E402
from rasterio.warp import transform  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gsd-m", type=float, default=0.2)
    ap.add_argument("frames", nargs="*")
    args = ap.parse_args()
    frames = args.frames or sorted(glob.glob(os.path.join(ROOT, "..", "shared", "data", "drone-xmp", "*.JPG")))
    if not frames:
        print("SKIP: no frames (../shared/data/drone-xmp is absent)")
        return 0
    binary = os.path.join(ROOT, "target", "release", "aerorect")
    if not os.path.exists(binary):
        subprocess.check_call(["cargo", "build", "--release", "-q"], cwd=ROOT)
    tmp = tempfile.mkdtemp()
    bad = 0
    for f in frames:
        name = os.path.splitext(os.path.basename(f))[0]
        out, rep = os.path.join(tmp, name + ".tif"), os.path.join(tmp, name + ".json")
        subprocess.run([binary, "rectify", f, out, "--gsd-m", str(args.gsd_m), "--report", rep],
                       check=True, capture_output=True)
        r = json.load(open(rep))
        geo = r["info"]["geo"]
        epsg = geo["crs"]["Epsg"]  # drone output is always a UTM EPSG code
        x0, y0 = geo["top_left"]
        sx, sy = geo["pixel_size"]
        with rasterio.open(out) as ds:
            checks = {
                "crs": (ds.crs.to_epsg(), epsg),
                "transform": (tuple(round(v, 6) for v in ds.transform[:6]), (round(sx, 6), 0.0, round(x0, 6), 0.0, round(-sy, 6), round(y0, 6))),
                "size": ((ds.width, ds.height), tuple(r["output_size"])),
                "nodata": (ds.nodata, geo["nodata"]),
                "area_or_point": (ds.tags().get("AREA_OR_POINT"), "Area"),
            }
        e, n = transform("EPSG:4326", f"EPSG:{epsg}", [r["info"]["longitude_deg"]], [r["info"]["latitude_deg"]])
        en = r["info"]["easting_northing_m"]
        checks["camera position (PROJ vs aerorect, mm)"] = (round(1000 * max(abs(e[0] - en[0]), abs(n[0] - en[1]))), 0)
        ok = all(a == b for a, b in checks.values())
        bad += not ok
        print(f"{name}: {'OK' if ok else 'MISMATCH'}  EPSG:{checks['crs'][0]} size {checks['size'][0]} "
              f"transform {checks['transform'][0]} nodata {checks['nodata'][0]} {checks['area_or_point'][0]}")
        for k, (a, b) in checks.items():
            if a != b:
                print(f"   {k}: rasterio {a} != aerorect {b}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
