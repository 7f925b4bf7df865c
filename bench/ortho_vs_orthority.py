#!/usr/bin/env python3
"""Orthorectification, aerorect beside Orthority (PyPI `orthority`, the `oty` CLI), same frames.

DJI case: each ../shared/data/drone-xmp/DJI_*.JPG from its own EXIF/XMP. Orthority (`oty exif`)
gets a flat DEM GeoTIFF written here at the camera altitude Orthority uses (EXIF GPSAltitude,
taken as the height of EPSG:4979) minus XMP RelativeAltitude, so both tools see the same height
above ground; ours is `aerorect rectify PHOTO OUT.tif --gsd-m G`. Two Orthority rows per frame:
  oty-exif   Orthority's own camera (FC220: 35 mm equivalent, 26/36 x 4000 = 2889 px)
  oty-ourcam the same pose with aerorect's pinhole intrinsics (`oty frame` on Orthority's
             exported exterior parameters), so the shift measures georeferencing alone.
NGI case: ../shared/data/ngi (4 frames, DEM, omega/phi/kappa poses, interior yaml): `oty frame`
beside `aerorect rectify FRAME OUT --camera CAM.toml --pose x,y,z,o,p,k --crs WKT --dem dem.tif
--gsd-m 5`; while our CLI lacks those flags the case is reported "not available yet".

Per frame: median ground shift of Orthority's ortho relative to ours (phase correlation of
TILE px tiles on our grid, tiles with nodata or without texture skipped): dx, dy (px, x east,
y south) and its length in metres, and the median tile |shift|; a similarity fitted to the tile
shifts about the camera's nadir point: the shift there ("nadir m"), the rotation (degrees,
counter-clockwise; grid convergence shows here) and the scale (a focal-length difference shows
here) and the rms of the tile shifts about that fit (m); the valid ground area ratio ours / Orthority's; wall time end to end (process start
included) of each tool and the ratio ours / Orthority's. Orthority refuses frames whose field
of view reaches the horizon: such rows say so and do not count as failures. Both write north-up grids whose pixel corners are
multiples of the resolution (ours always, Orthority with --aligned-pixels), so Orthority's ortho
is copied onto our grid without resampling; pixel centres sit at +0.5 in both.

Same settings for both where they exist: bilinear interpolation, lossless
output on Orthority's side (--compress deflate, no overviews: -nbo), all cores.
Creates its own venv (bench/.venv) with orthority (it brings rasterio and numpy).
usage: python3 bench/ortho_vs_orthority.py [--frames N|NAME,..] [--keep DIR] [--gsd-m G]
       [--tile 128] [--binary PATH] [--no-build]
"""
import argparse, glob, json, os, re, shutil, subprocess, sys, tempfile, time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402
from bench_util import write_flat_dem, xmp_float  # noqa: E402

ensure_venv(["orthority"], ["orthority", "rasterio", "numpy", "yaml"])
import numpy as np  # noqa: E402
import rasterio  # noqa: E402
import yaml  # noqa: E402
from rasterio.crs import CRS  # noqa: E402
from rasterio.warp import Resampling, reproject  # noqa: E402

SHARED = os.path.join(ROOT, "..", "shared", "data")
OTY = os.path.join(sys.prefix, "bin", "oty")
# Orthority's output settings closest to ours: no overviews, lossless, bilinear.
OTY_COMMON = ["--aligned-pixels", "--interp", "bilinear", "--compress", "deflate", "-nbo", "-o"]
NOT_YET = re.compile(r"unexpected argument|unrecognized|unknown (argument|option|flag)|not supported", re.I)


class ToolFailed(Exception):
    pass


# Orthority's documented refusal of frames that see the sky: expected, reported, not a failure.
OTY_REFUSES = re.compile(r"field of view that includes, or is above, the horizontal")


def run_timed(cmd, cwd=None):
    """Runs cmd, returns (seconds, completed process); the time includes process start."""
    t = time.perf_counter()
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    return time.perf_counter() - t, p


def check(p, what):
    if p.returncode != 0:
        raise ToolFailed(f"{what} failed (exit {p.returncode}):\n{p.stderr.strip()[-2000:]}")


# ---------------------------------------------------------------- measurements


def load_gray(path):
    """(gray float32, valid bool, transform, crs) of a georeferenced RGB(A) image."""
    with rasterio.open(path) as ds:
        bands = min(ds.count, 3)
        data = ds.read(list(range(1, bands + 1))).astype(np.float32)
        valid = ds.read_masks(1) > 0
        return data.mean(axis=0), valid, ds.transform, ds.crs


def onto_grid(path, transform, shape, crs):
    """Orthority's ortho on our grid: copied when the grids share pixel corners, else bilinear."""
    with rasterio.open(path) as ds:
        bands = min(ds.count, 3)
        src = ds.read(list(range(1, bands + 1))).astype(np.float32).mean(axis=0)
        mask = (ds.read_masks(1) > 0).astype(np.uint8)
        aligned = ds.crs == crs and np.allclose(
            [ds.transform.a, ds.transform.e], [transform.a, transform.e]
        ) and all(abs(f - round(f)) < 1e-6 for f in (
            (ds.transform.c - transform.c) / transform.a, (ds.transform.f - transform.f) / transform.e))
        rs = Resampling.nearest if aligned else Resampling.bilinear
        gray = np.zeros(shape, np.float32)
        valid = np.zeros(shape, np.uint8)
        reproject(src, gray, src_transform=ds.transform, src_crs=ds.crs, dst_transform=transform,
                  dst_crs=crs, resampling=rs)
        reproject(mask, valid, src_transform=ds.transform, src_crs=ds.crs, dst_transform=transform,
                  dst_crs=crs, resampling=Resampling.nearest, src_nodata=None, dst_nodata=0)
        return gray, valid > 0, aligned, ds.transform, int(mask.sum())


def phase_shift(a, b):
    """(dx, dy, peak) of b relative to a: a feature at (x, y) in a is at (x + dx, y + dy) in b."""
    n = a.shape[0]
    win = np.outer(np.hanning(n), np.hanning(n))
    fa = np.fft.fft2((a - a.mean()) * win)
    fb = np.fft.fft2((b - b.mean()) * win)
    cross = np.conj(fa) * fb
    cross /= np.abs(cross) + 1e-12
    r = np.fft.ifft2(cross).real
    iy, ix = np.unravel_index(np.argmax(r), r.shape)

    def sub(rm, r0, rp):  # parabolic peak interpolation
        d = rm - 2 * r0 + rp
        return 0.0 if d == 0 else 0.5 * (rm - rp) / d

    dy = iy + sub(r[(iy - 1) % n, ix], r[iy, ix], r[(iy + 1) % n, ix])
    dx = ix + sub(r[iy, (ix - 1) % n], r[iy, ix], r[iy, (ix + 1) % n])
    dx = dx - n if dx > n / 2 else dx
    dy = dy - n if dy > n / 2 else dy
    return dx, dy, r[iy, ix]


def compare(ours_path, theirs_path, tile, origin=None, world_crs=None):
    """Shift of Orthority's ortho relative to ours; the similarity is fitted about origin (the
    camera's ground nadir, east/north) when given, else about the tiles' centroid. world_crs: the
    CRS both tools were given, used for our grid when our file's CRS tag reads differently."""
    ours, ours_valid, transform, crs = load_gray(ours_path)
    crs_note = None
    if world_crs is not None and crs != world_crs:
        crs_note = f"our CRS tag reads as {crs.to_string()[:40]!r}, taken as the given CRS"
        crs = world_crs
    theirs, theirs_valid, aligned, their_transform, their_count = onto_grid(
        theirs_path, transform, ours.shape, crs)
    g = abs(transform.a)
    rows = []
    h, w = ours.shape
    stride = tile
    # at most ~2500 tiles: widen the stride on very large footprints
    while (h // stride) * (w // stride) > 2500:
        stride += tile // 2
    for y in range(0, h - tile + 1, stride):
        for x in range(0, w - tile + 1, stride):
            if not (ours_valid[y:y + tile, x:x + tile].all() and theirs_valid[y:y + tile, x:x + tile].all()):
                continue
            a, b = ours[y:y + tile, x:x + tile], theirs[y:y + tile, x:x + tile]
            if a.std() < 4 or b.std() < 4:  # no texture
                continue
            dx, dy, peak = phase_shift(a, b)
            if peak < 0.07 or max(abs(dx), abs(dy)) > tile / 4:  # noise peaks stay near 0.04
                continue
            rows.append((x + tile / 2, y + tile / 2, dx, dy))
    out = dict(tiles=len(rows), aligned=aligned, gsd=g, crs_note=crs_note,
               area_ours=float(ours_valid.sum()) * g * g,
               area_theirs=their_count * abs(their_transform.a * their_transform.e))
    out["area_ratio"] = out["area_ours"] / out["area_theirs"] if out["area_theirs"] else float("nan")
    if len(rows) < 3:
        return out
    r = np.array(rows)
    mdx, mdy = np.median(r[:, 2]), np.median(r[:, 3])
    out.update(dx_px=mdx, dy_px=mdy, shift_px=float(np.hypot(mdx, mdy)),
               shift_m=float(np.hypot(mdx, mdy) * g),
               median_abs_m=float(np.median(np.hypot(r[:, 2], r[:, 3])) * g))
    # similarity about origin, east/north metres: d = t + a p + b J p (J turns +90 deg), so b is
    # the rotation (counter-clockwise, radians), 1 + a the scale and t the shift at origin
    e = transform.c + (r[:, 0] + 0.5) * g
    n = transform.f - (r[:, 1] + 0.5) * g
    e0, n0 = origin if origin is not None else (e.mean(), n.mean())
    e, n = e - e0, n - n0
    de, dn = r[:, 2] * g, -r[:, 3] * g
    one, zero = np.ones_like(e), np.zeros_like(e)
    A = np.vstack([np.column_stack([one, zero, e, -n]), np.column_stack([zero, one, n, e])])
    d = np.concatenate([de, dn])
    keep = np.ones(len(e), bool)
    for _ in range(5):  # drop tiles that disagree with the fit (weak peaks far off nadir)
        k2 = np.concatenate([keep, keep])
        sol, *_ = np.linalg.lstsq(A[k2], d[k2], rcond=None)
        res = np.hypot(*(A @ sol - d).reshape(2, -1))
        new_keep = res <= max(3 * np.median(res[keep]), 1.5 * g)
        if (new_keep == keep).all() or new_keep.sum() < 3:
            break
        keep = new_keep
    out.update(rot_deg=float(np.degrees(sol[3])), scale=float(1 + sol[2]),
               at_origin_m=float(np.hypot(sol[0], sol[1])), fit_tiles=int(keep.sum()),
               fit_rms_m=float(np.sqrt(np.mean(res[keep] ** 2))))
    return out


# ---------------------------------------------------------------- DJI case


def find_key(d, key):
    """The first value under key in nested dicts (the report's layout may move)."""
    if isinstance(d, dict):
        if key in d:
            return d[key]
        for v in d.values():
            found = find_key(v, key)
            if found is not None:
                return found
    return None



def dji_frame(photo, args, work):
    from orthority.exif import Exif

    name = os.path.splitext(os.path.basename(photo))[0]
    g = args.gsd_m
    ours_tif, ours_json = os.path.join(work, f"{name}_ours.tif"), os.path.join(work, f"{name}_ours.json")
    t_ours, p = run_timed([args.binary, "rectify", photo, ours_tif, "--gsd-m", str(g), "--report", ours_json])
    check(p, f"aerorect rectify {name}")
    report = json.load(open(ours_json))
    info = report.get("info", {})
    with rasterio.open(ours_tif) as ds:
        crs, b = ds.crs, ds.bounds
    exif = Exif(photo)
    lat, lon, alt = exif.lla
    rel = xmp_float(photo, "RelativeAltitude")
    if rel is None:
        raise ToolFailed(f"{name}: no XMP RelativeAltitude")
    ground = alt - rel
    margin = max(50.0, 0.1 * max(b.right - b.left, b.top - b.bottom))
    dem = os.path.join(work, f"{name}_dem.tif")
    write_flat_dem(dem, crs, (b.left - margin, b.bottom - margin, b.right + margin, b.top + margin), ground,
                   compress="deflate")
    crs_arg = f"EPSG:{crs.to_epsg()}" if crs.to_epsg() else crs.to_wkt()
    results = []
    # Orthority from EXIF/XMP alone
    d1 = os.path.join(work, f"{name}_oty_exif")
    os.makedirs(d1, exist_ok=True)
    t1, p = run_timed([OTY, "exif", photo, "--dem", dem, "--crs", crs_arg, "--res", str(g),
                       *OTY_COMMON, "--out-dir", d1])
    pitch = info.get("gimbal_yaw_pitch_roll_deg", [None, None])[1]
    note = f"pitch {pitch:g}, {rel:.1f} m above ground at {ground:.2f} m" if pitch is not None else ""
    if info.get("clipped"):
        note += ", ours clipped near the horizon"
    if p.returncode != 0 and OTY_REFUSES.search(p.stderr):
        return name, t_ours, [("oty-exif", t1, None)], note + "; Orthority refuses: sees the horizon"
    check(p, f"oty exif {name}")
    theirs1 = glob.glob(os.path.join(d1, "*_ORTHO.tif"))[0]
    nadir = info.get("easting_northing_m")
    results.append(("oty-exif", t1, compare(ours_tif, theirs1, args.tile, nadir)))
    # Orthority with our pinhole camera on its own exterior parameters
    d2 = os.path.join(work, f"{name}_oty_ourcam")
    os.makedirs(d2, exist_ok=True)
    _, p = run_timed([OTY, "exif", photo, "--crs", crs_arg, "--export-params", "--out-dir", d2, "-o"])
    check(p, f"oty exif --export-params {name}")
    intr = find_key(info.get("camera", {}), "intrinsics")
    if not intr:
        print(f"{name}: our report has no camera intrinsics, no oty-ourcam row", file=sys.stderr)
    else:
        wpx, hpx = report["input_size"]
        int_path = os.path.join(d2, "int_param.yaml")
        cams = yaml.safe_load(open(int_path))
        for cam in cams.values():
            cam.update(type="pinhole", im_size=[wpx, hpx], focal_len=[intr["fx"], intr["fy"]],
                       sensor_size=[float(wpx), float(hpx)],
                       cx=(intr["cx"] - (wpx - 1) / 2) / max(wpx, hpx),
                       cy=(intr["cy"] - (hpx - 1) / 2) / max(wpx, hpx))
            for k in ("k1", "k2", "k3", "p1", "p2"):
                cam.pop(k, None)
        yaml.safe_dump(cams, open(int_path, "w"))
        t2, p = run_timed([OTY, "frame", photo, "--int-param", int_path, "--ext-param",
                           os.path.join(d2, "ext_param.geojson"), "--dem", dem, "--crs", crs_arg,
                           "--res", str(g), *OTY_COMMON, "--out-dir", d2])
        check(p, f"oty frame (our camera) {name}")
        theirs2 = glob.glob(os.path.join(d2, "*_ORTHO.tif"))[0]
        results.append(("oty-ourcam", t2, compare(ours_tif, theirs2, args.tile, nadir)))
    return name, t_ours, results, note


# ---------------------------------------------------------------- NGI case


def ngi_camera_toml(path, out):
    cams = yaml.safe_load(open(path))
    cam = next(iter(cams.values()))
    (w, h), (sw, sh) = cam["im_size"], cam["sensor_size"]
    f = cam["focal_len"]
    cx = (w - 1) / 2 + cam.get("cx", 0.0) * max(w, h)
    cy = (h - 1) / 2 + cam.get("cy", 0.0) * max(w, h)
    with open(out, "w") as o:
        o.write(f"focal_length_mm = {float(f)!r}\n")
        o.write(f"pixel_pitch_um = [{sw / w * 1000!r}, {sh / h * 1000!r}]\n")
        o.write(f"principal_point_px = [{cx!r}, {cy!r}]\n")
        o.write(f"image_size_px = [{w}, {h}]\n")


def ngi_frame(row, args, work, wkt):
    crs = CRS.from_wkt(wkt)
    ngi = os.path.join(SHARED, "ngi")
    name = row["filename"]
    frame = os.path.join(ngi, name + ".tif")
    cam = os.path.join(work, "ngi_camera.toml")
    ngi_camera_toml(os.path.join(ngi, "ngi_int_param.yaml"), cam)
    ours_tif = os.path.join(work, f"{name}_ours.tif")
    pose = ",".join(row[k] for k in ("x", "y", "z", "omega", "phi", "kappa"))
    t_ours, p = run_timed([args.binary, "rectify", frame, ours_tif, "--camera", cam, f"--pose={pose}",
                           "--crs", wkt, "--dem", os.path.join(ngi, "dem.tif"), "--gsd-m", "5"])
    ours_ok = p.returncode == 0
    if not ours_ok and not NOT_YET.search(p.stderr):
        check(p, f"aerorect rectify {name}")
    d = os.path.join(work, f"{name}_oty")
    os.makedirs(d, exist_ok=True)
    t_oty, p2 = run_timed([OTY, "frame", frame, "--int-param", os.path.join(ngi, "ngi_int_param.yaml"),
                           "--ext-param", os.path.join(ngi, "ngi_xyz_opk.csv"), "--dem",
                           os.path.join(ngi, "dem.tif"), "--res", "5", *OTY_COMMON, "--out-dir", d])
    check(p2, f"oty frame {name}")
    theirs = glob.glob(os.path.join(d, "*_ORTHO.tif"))[0]
    if not ours_ok:
        return name, None, [("oty-frame", t_oty, None)], "ours: not available yet (" + p.stderr.strip().splitlines()[0][:90] + ")"
    return name, t_ours, [("oty-frame", t_oty, compare(ours_tif, theirs, args.tile, (float(row["x"]), float(row["y"])), crs))], ""


# ---------------------------------------------------------------- output


def print_table(case, rows):
    print(f"\n== {case}")
    print(f"{'frame':<28} {'peer':<10} {'tiles':>5} {'dx px':>7} {'dy px':>7} {'shift m':>8} "
          f"{'med|d| m':>8} {'nadir m':>7} {'rot deg':>8} {'scale':>7} {'fit rms':>7} {'area o/t':>8} {'ours s':>7} {'oty s':>7} {'t o/t':>6}  note")
    shifts, ratios, areas = [], [], []
    for name, t_ours, results, note in rows:
        for peer, t_oty, m in results:
            tr = t_ours / t_oty if t_ours and m is not None else float("nan")
            if m is None or "shift_m" not in m:
                area = m["area_ratio"] if m else float("nan")
                note = note or "too few textured tiles in common"
                print(f"{name:<28} {peer:<10} {(m or {}).get('tiles', 0):>5} {'-':>7} {'-':>7} {'-':>8} {'-':>8} "
                      f"{'-':>7} {'-':>8} {'-':>7} {'-':>7} {area:>8.3f} {t_ours or float('nan'):>7.2f} {t_oty:>7.2f} {tr:>6.2f}  {note}")
                continue
            print(f"{name:<28} {peer:<10} {m['tiles']:>5} {m['dx_px']:>7.2f} {m['dy_px']:>7.2f} {m['shift_m']:>8.3f} "
                  f"{m['median_abs_m']:>8.3f} {m['at_origin_m']:>7.3f} {m['rot_deg']:>8.3f} {m['scale']:>7.4f} {m['fit_rms_m']:>7.3f} {m['area_ratio']:>8.3f} "
                  f"{t_ours:>7.2f} {t_oty:>7.2f} {tr:>6.2f}  {note}{'' if m['aligned'] else ' (resampled)'}")
            if m.get("crs_note"):
                print(f"{'':<28} note: {m['crs_note']}")
            shifts.append((peer, m["shift_m"]))
            ratios.append((peer, tr))
            areas.append((peer, m["area_ratio"]))
    for peer in sorted({p for p, _ in shifts}):
        s = [v for p, v in shifts if p == peer]
        t = [v for p, v in ratios if p == peer]
        a = [v for p, v in areas if p == peer]
        print(f"summary {case} vs {peer}: {len(s)} frames, median shift {np.median(s):.3f} m "
              f"(max {max(s):.3f}), median area ratio {np.median(a):.3f}, median time ratio ours/oty "
              f"{np.median(t):.2f}")
    if not shifts:
        print(f"summary {case}: no comparison ({'ours not available yet' if all(r[1] is None for r in rows) else 'no frame with enough tiles'})")


def select(paths, frames):
    if not frames:
        return paths
    if frames.isdigit():
        return paths[: int(frames)]
    want = frames.split(",")
    return [p for p in paths if any(w in os.path.basename(p) for w in want)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", help="first N frames of each case, or comma-separated name parts")
    ap.add_argument("--keep", help="keep every output in this directory")
    ap.add_argument("--gsd-m", type=float, default=0.1, help="DJI output resolution (both tools)")
    ap.add_argument("--tile", type=int, default=128)
    ap.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "aerorect"))
    ap.add_argument("--no-build", action="store_true", help="use --binary as it is")
    ap.add_argument("--case", choices=["dji", "ngi", "all"], default="all")
    args = ap.parse_args()
    if not args.no_build:
        subprocess.check_call(["cargo", "build", "--release", "-q", "-p", "aerorect-cli"], cwd=ROOT)
    work = args.keep or tempfile.mkdtemp(prefix="ortho_vs_oty_")
    os.makedirs(work, exist_ok=True)
    failed = False
    try:
        if args.case in ("dji", "all"):
            rows = []
            for photo in select(sorted(glob.glob(os.path.join(SHARED, "drone-xmp", "DJI_*.JPG"))), args.frames):
                try:
                    rows.append(dji_frame(photo, args, work))
                except ToolFailed as ex:
                    print(f"FAILED {photo}: {ex}", file=sys.stderr)
                    failed = True
            print_table(f"DJI (flat DEM, {args.gsd_m} m)", rows)
        if args.case in ("ngi", "all"):
            ngi = os.path.join(SHARED, "ngi")
            if not os.path.isdir(ngi):
                print("SKIP NGI: ../shared/data/ngi is absent")
            else:
                import csv
                wkt = CRS.from_string(open(os.path.join(ngi, "ngi_xyz_opk.prj")).read().strip()).to_wkt()
                poses = list(csv.DictReader(open(os.path.join(ngi, "ngi_xyz_opk.csv"))))
                names = [r["filename"] for r in poses]
                keep = set(os.path.basename(p) for p in select(names, args.frames))
                rows = []
                for row in poses:
                    if row["filename"] not in keep:
                        continue
                    try:
                        rows.append(ngi_frame(row, args, work, wkt))
                    except ToolFailed as ex:
                        print(f"FAILED {row['filename']}: {ex}", file=sys.stderr)
                        failed = True
                print_table("NGI (DEM, 5 m)", rows)
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
        else:
            print(f"\noutputs kept in {work}")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
