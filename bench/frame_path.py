#!/usr/bin/env python3
"""End-to-end frame path: one DJI JPEG to a GeoTIFF at native GSD, aerorect beside Orthority
and gdalwarp, wall time per process (start included), median of N runs, the tools interleaved.

  ours      aerorect rectify PHOTO OUT.tif (native GSD, bilinear, Deflate strips), with
            --report: the median of its stage_seconds (read, plan, warp, write) is printed.
  oty       Orthority `oty exif PHOTO --dem FLAT --crs EPSG:x --res G --aligned-pixels
            --interp bilinear --compress deflate -nbo` (as bench/ortho_vs_orthority.py): its
            own camera model from EXIF, a flat DEM at the ground height ours uses (GPS altitude
            minus XMP RelativeAltitude), our GSD and CRS, pixel corners on multiples of the GSD
            like ours; Orthority picks its own bounds (its size is printed beside ours).
  gdalwarp  GDAL's warper on the same output grid as ours (-t_srs, -te, -tr from our file),
            the frame georeferenced by GCPs: a G x G grid of frame pixels (default 16 x 9) and
            the ground points our map gives them (the camera ray of each pixel centre met with
            the level ground, from the pose and intrinsics in our report), written into a VRT
            over the JPEG. gdalwarp -order 3 (a cubic polynomial fitted to those GCPs; the rms of
            that fit against our map is printed, in frame pixels), -r bilinear, -wm 500 (the
            whole frame in one chunk), -multi -wo NUM_THREADS=ALL_CPUS, -co COMPRESS=DEFLATE
            PREDICTOR=2 ZLEVEL=1 (the compression ours writes). No -dstnodata: the destination
            is initialised to 0 all the same, and -dstnodata 0 sends GDAL 3.6 down its masked
            kernel, about 1.6 times slower here (so this is gdalwarp at its fastest, without a
            nodata tag). Its output is checked against ours: the mean |difference| of the pixels
            ours covers and gdalwarp wrote (a wrong geolocation shows as a large one).

Prints a table: tool, median wall s, min, max RSS MB, output MB, size; and the ratios peer /
ours (how many times faster ours is). The machine's load average is printed before and after:
other processes share the cores, so quote medians from one run.
usage: python3 bench/frame_path.py [--frame PATH] [--runs 5] [--gcp 16x9] [--no-build]
       [--binary PATH] [--keep DIR] [--tools ours,oty,gdalwarp]
"""
import argparse, json, os, shutil, statistics, subprocess, sys, tempfile, time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402
from bench_util import write_flat_dem, xmp_float  # noqa: E402

ensure_venv(["orthority"], ["orthority", "rasterio", "numpy"])
import numpy as np  # noqa: E402
import rasterio  # noqa: E402

SHARED = os.path.join(ROOT, "..", "shared", "data")
OTY = os.path.join(sys.prefix, "bin", "oty")
TIME = "/usr/bin/time"


def timed(cmd, cwd=None):
    """(wall seconds, max RSS MB or nan) of cmd; raises on failure."""
    rss_file = tempfile.mktemp(prefix="rss_")
    full = [TIME, "-f", "%M", "-o", rss_file, *cmd] if os.path.exists(TIME) else cmd
    t = time.perf_counter()
    p = subprocess.run(full, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if p.returncode != 0:
        raise RuntimeError(f"{cmd[0]} failed (exit {p.returncode}):\n{p.stderr[-2000:]}")
    rss = float("nan")
    if os.path.exists(rss_file):
        txt = open(rss_file).read().split()
        rss = int(txt[-1]) / 1024 if txt and txt[-1].isdigit() else rss
        os.remove(rss_file)
    return wall, rss



def ground_of_pixels(report, u, v):
    """Our map, inverted: the level-ground point (e, n) seen at frame pixel centres (u, v)."""
    info = report["info"]
    k = info["camera"]["camera"]["intrinsics"]
    pose = info["pose"]
    r = np.array(pose["world_from_camera"])
    c = np.array(pose["centre"])
    ground_z = c[2] - info["height_m"]
    # the camera looks along -z; normalised (x, y) = (d.x / -d.z, d.y / d.z) (aerorect-geo ortho)
    nx = (u - k["cx"] - k["skew"] * 0) / k["fx"]
    ny = (v - k["cy"]) / k["fy"]
    d_cam = np.stack([nx, -ny, -np.ones_like(nx)])
    d = r @ d_cam.reshape(3, -1)
    t = (ground_z - c[2]) / d[2]
    return c[0] + t * d[0], c[1] + t * d[1]


def gcp_vrt(photo, report, grid, crs_wkt, path):
    """A VRT over the JPEG with grid[0] x grid[1] GCPs from our map; returns the rms (frame px)
    of a cubic polynomial (gdalwarp -order 3) fitted to them, checked on a 4x denser grid."""
    w, h = report["input_size"]
    gu, gv = np.meshgrid(np.linspace(0, w - 1, grid[0]), np.linspace(0, h - 1, grid[1]))
    gu, gv = gu.ravel(), gv.ravel()
    e, n = ground_of_pixels(report, gu, gv)
    gcps = "\n".join(
        f'    <GCP Id="{i}" Pixel="{u + 0.5:.17g}" Line="{v + 0.5:.17g}" X="{x:.17g}" Y="{y:.17g}" Z="0"/>'
        for i, (u, v, x, y) in enumerate(zip(gu, gv, e, n)))
    src = os.path.abspath(photo)
    bands = "\n".join(f"""  <VRTRasterBand dataType="Byte" band="{b}">
    <SimpleSource><SourceFilename relativeToVRT="0">{src}</SourceFilename>
      <SourceBand>{b}</SourceBand></SimpleSource>
  </VRTRasterBand>""" for b in (1, 2, 3))
    from xml.sax.saxutils import escape
    with open(path, "w") as f:
        f.write(f"""<VRTDataset rasterXSize="{w}" rasterYSize="{h}">
  <GCPList Projection="{escape(crs_wkt, {'"': '&quot;'})}">
{gcps}
  </GCPList>
{bands}
</VRTDataset>
""")
    # the cubic polynomial gdalwarp fits (ground -> pixel), checked on a denser grid
    def terms(x, y):
        return np.stack([np.ones_like(x), x, y, x * x, x * y, y * y, x ** 3, x * x * y, x * y * y, y ** 3], 1)
    x0, y0, s = e.mean(), n.mean(), max(e.std(), n.std())
    a = terms((e - x0) / s, (n - y0) / s)
    cu = np.linalg.lstsq(a, gu, rcond=None)[0]
    cv = np.linalg.lstsq(a, gv, rcond=None)[0]
    du, dv = np.meshgrid(np.linspace(0, w - 1, 4 * grid[0]), np.linspace(0, h - 1, 4 * grid[1]))
    de, dn = ground_of_pixels(report, du.ravel(), dv.ravel())
    b = terms((de - x0) / s, (dn - y0) / s)
    return float(np.sqrt(np.mean((b @ cu - du.ravel()) ** 2 + (b @ cv - dv.ravel()) ** 2)))


def compare_pixels(ours, theirs):
    """Mean |difference| (gray levels) where both are valid, and that common fraction."""
    with rasterio.open(ours) as a, rasterio.open(theirs) as b:
        if a.shape != b.shape or a.transform != b.transform:
            return float("nan"), 0.0
        x, y = a.read().astype(np.int16), b.read().astype(np.int16)
        valid = (a.read_masks(1) > 0) & (b.read_masks(1) > 0) & (y.max(axis=0) > 0)
        if not valid.any():
            return float("nan"), 0.0
        return float(np.abs(x - y)[:, valid].mean()), float(valid.mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frame", default=os.path.join(SHARED, "drone-xmp", "DJI_0010.JPG"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--gcp", default="16x9", help="GCP grid for gdalwarp, across x down")
    ap.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "aerorect"))
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--keep", help="keep the outputs in this directory")
    ap.add_argument("--tools", default="ours,oty,gdalwarp")
    args = ap.parse_args()
    if not os.path.exists(args.frame):
        print(f"SKIP: {args.frame} is absent")
        return 0
    if not args.no_build:
        subprocess.check_call(["cargo", "build", "--release", "-q", "-p", "aerorect-cli"], cwd=ROOT)
    tools = args.tools.split(",")
    gdalwarp = shutil.which("gdalwarp")
    if "gdalwarp" in tools and not gdalwarp:
        print("gdalwarp: not installed (apt-get install gdal-bin), its row is left out")
        tools.remove("gdalwarp")
    work = args.keep or tempfile.mkdtemp(prefix="frame_path_")
    os.makedirs(work, exist_ok=True)
    name = os.path.splitext(os.path.basename(args.frame))[0]
    ours_tif, ours_json = os.path.join(work, f"{name}_ours.tif"), os.path.join(work, f"{name}_ours.json")
    cmd_ours = [args.binary, "rectify", args.frame, ours_tif, "--report", ours_json]
    timed(cmd_ours)  # warm the page cache and learn the grid
    report = json.load(open(ours_json))
    with rasterio.open(ours_tif) as ds:
        crs, b, g, shape = ds.crs, ds.bounds, ds.transform.a, ds.shape
    epsg = crs.to_epsg()
    crs_arg = f"EPSG:{epsg}" if epsg else crs.to_wkt()
    cmds = {"ours": cmd_ours}
    if "oty" in tools:
        rel = xmp_float(args.frame, "RelativeAltitude")
        from orthority.exif import Exif
        ground = Exif(args.frame).lla[2] - rel
        margin = max(50.0, 0.1 * max(b.right - b.left, b.top - b.bottom))
        dem = os.path.join(work, f"{name}_dem.tif")
        write_flat_dem(dem, crs, (b.left - margin, b.bottom - margin, b.right + margin, b.top + margin), ground)
        oty_dir = os.path.join(work, f"{name}_oty")
        os.makedirs(oty_dir, exist_ok=True)
        cmds["oty"] = [OTY, "exif", args.frame, "--dem", dem, "--crs", crs_arg, "--res", repr(g),
                       "--aligned-pixels", "--interp", "bilinear", "--compress", "deflate", "-nbo",
                       "-o", "--out-dir", oty_dir]
    fit_rms = None
    if "gdalwarp" in tools:
        grid = tuple(int(x) for x in args.gcp.lower().split("x"))
        vrt = os.path.join(work, f"{name}_gcps.vrt")
        fit_rms = gcp_vrt(args.frame, report, grid, crs.to_wkt(), vrt)
        gdal_tif = os.path.join(work, f"{name}_gdalwarp.tif")
        cmds["gdalwarp"] = [gdalwarp, "-q", "-overwrite", "-order", "3", "-r", "bilinear",
                            "-t_srs", crs_arg, "-te", repr(b.left), repr(b.bottom), repr(b.right), repr(b.top),
                            "-tr", repr(g), repr(g), "-wm", "500", "-multi", "-wo", "NUM_THREADS=ALL_CPUS",
                            "-co", "COMPRESS=DEFLATE", "-co", "PREDICTOR=2", "-co", "ZLEVEL=1", vrt, gdal_tif]
    load0 = os.getloadavg()
    walls = {t: [] for t in cmds}
    rss = {t: [] for t in cmds}
    stages = []
    for _ in range(args.runs):
        for t, cmd in cmds.items():
            w, m = timed(cmd)
            walls[t].append(w)
            rss[t].append(m)
            if t == "ours":
                stages.append(json.load(open(ours_json)).get("stage_seconds", {}))
    load1 = os.getloadavg()
    outputs = {"ours": ours_tif}
    if "oty" in cmds:
        found = [f for f in os.listdir(cmds["oty"][-1]) if f.endswith("_ORTHO.tif")]
        outputs["oty"] = os.path.join(cmds["oty"][-1], found[0]) if found else None
    if "gdalwarp" in cmds:
        outputs["gdalwarp"] = cmds["gdalwarp"][-1]
    print(f"frame {args.frame}: {report['input_size'][0]} x {report['input_size'][1]} px -> "
          f"{shape[1]} x {shape[0]} px at {g:.5f} m ({crs_arg}); {args.runs} runs, tools interleaved")
    print(f"load average before {load0[0]:.2f}, after {load1[0]:.2f} ({os.cpu_count()} cores)")
    print(f"\n{'tool':<10} {'median s':>9} {'min s':>7} {'max RSS MB':>10} {'out MB':>7}  size")
    for t in cmds:
        out = outputs.get(t)
        size = "-"
        mb = float("nan")
        if out and os.path.exists(out):
            mb = os.path.getsize(out) / 1e6
            with rasterio.open(out) as ds:
                size = f"{ds.width} x {ds.height} x {ds.count}, {ds.profile.get('compress')}"
        print(f"{t:<10} {statistics.median(walls[t]):>9.3f} {min(walls[t]):>7.3f} "
              f"{statistics.median(rss[t]):>10.0f} {mb:>7.1f}  {size}")
    if stages and all(stages):
        keys = list(stages[0].keys())
        print("ours, median stage seconds: " + ", ".join(
            f"{k} {statistics.median(s[k] for s in stages):.3f}" for k in keys))
    ours_med = statistics.median(walls["ours"])
    for t in cmds:
        if t != "ours":
            print(f"ratio {t} / ours: {statistics.median(walls[t]) / ours_med:.2f}x")
    if "gdalwarp" in cmds:
        diff, frac = compare_pixels(ours_tif, outputs["gdalwarp"])
        print(f"gdalwarp check: cubic-polynomial fit to our map rms {fit_rms:.4f} frame px; "
              f"mean |ours - gdalwarp| {diff:.2f} gray levels over {frac:.1%} of the grid")
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    else:
        print(f"outputs kept in {work}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
