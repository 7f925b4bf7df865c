"""Our flight adjustment side by side with COLMAP (pycolmap) on the senseFly snowpeak photos.

COLMAP: extract_features (SIFT, CPU, --max-image-size), match_spatial (pairs from the EXIF
GPS pose priors extract_features writes, within --max-distance-m), incremental_mapping (every
model of 3+ images kept), then align_reconstruction_to_locations of each model to the photos'
GPS positions in the flight's UTM zone (geoinfo's latitude, longitude, altitude_wgs84, which are
the EXIF values). Each step is timed (wall clock), seeded, on the machine's cores.

Ours: `aerorect mosaic PHOTOS --out WORK/ours/mosaic.tif --adjust` end to end (the ratio's
time: adjustment and mosaic), then `aerorect batch PHOTOS --out-dir WORK/ours/batch --adjust`
(timed too) because only batch writes adjusted_poses.csv + .prj. Without --ground-height-m or
--dem among the extra arguments, `--ground-height-m 160` (snowpeak's ground, ellipsoidal) is
added. A failure of ours is printed and the COLMAP numbers are still reported.

Compared, per photo COLMAP registered, as world-from-camera rotations in the UTM grid (E, N,
up) with OpenCV/COLMAP camera axes (x right, y down, z forward):
  ours vs COLMAP: omega-phi-kappa = Rx(o) Ry(p) Rz(k), PATB camera (x right, y up, z back);
    angle of the relative rotation (deg) and camera-centre distance (m);
  recorded vs COLMAP: the geoinfo heading/pitch/roll as Pix4D body angles, ned_from_body =
    Rz(yaw) Ry(pitch) Rx(roll), camera x = body y, image top = body x, camera back = -body z,
    turned from true to grid north by the meridian convergence; also the yaw/pitch/roll
    differences and the angle left after removing the mean camera-frame (mounting) offset.
Median and rms over photos, then a summary table (also WORK/summary.json).

    python3 bench/flight_vs_colmap.py [WORK_DIR] [--max-image-size 3200] [--threads N]
        [--sift-peak-threshold T] [-- EXTRA AERORECT ARGS]

--threads defaults to the machine's cores, --sift-peak-threshold to COLMAP's own (0.0067).
bench/sim_vs_colmap.py runs the same COLMAP steps (run_colmap) and ours (run_ours) on a
rendered flight of known poses.

WORK_DIR defaults to /tmp/aerorect-flight-vs-colmap; AERORECT=path overrides the binary. The
timings are wall clock on whatever else the machine runs: keep it idle (the load average is
printed).
"""
import argparse, csv, json, math, os, resource, shutil, subprocess, sys, time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402

ensure_venv(["pycolmap", "pyproj", "numpy"], ["pycolmap", "pyproj", "numpy"])
import numpy as np  # noqa: E402
import pycolmap  # noqa: E402
import pyproj  # noqa: E402

DATA = os.environ.get("AERORECT_SHARED_DATA", os.path.join(ROOT, "..", "shared", "data"))
SNOW = os.path.join(DATA, "flights", "snowpeak", "img")
GEOINFO = os.path.join(DATA, "flights", "snowpeak", "snowpea1_geoinfo.txt")
EXE = os.environ.get("AERORECT", os.path.join(ROOT, "target", "release", "aerorect"))
ENU_FROM_NED = np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, -1]])
BODY_FROM_PATB = np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, -1]])  # camera x = body y, y = body x
PATB_FROM_CV = np.diag([1.0, -1, -1])  # PATB (x right, y up, z back) from OpenCV/COLMAP axes


def rot(axis, deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def angle_deg(a, b):
    return math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(a.T @ b) - 1) / 2))))


def recorded_grid_from_cv(yaw, pitch, roll, gamma):
    ned_from_body = rot(2, yaw) @ rot(1, pitch) @ rot(0, roll)
    return rot(2, -gamma) @ ENU_FROM_NED @ ned_from_body @ BODY_FROM_PATB @ PATB_FROM_CV


def body_ypr(grid_from_cv, gamma):
    """The Pix4D yaw, pitch, roll (deg) of a camera, the inverse of recorded_grid_from_cv."""
    r = ENU_FROM_NED.T @ rot(2, gamma) @ grid_from_cv @ PATB_FROM_CV @ BODY_FROM_PATB.T
    return (math.degrees(math.atan2(r[1, 0], r[0, 0])), math.degrees(math.asin(-r[2, 0])),
            math.degrees(math.atan2(r[2, 1], r[2, 2])))


def wrap(d):
    return (d + 180) % 360 - 180


def stats(v):
    v = np.abs(np.asarray(v, float))
    return (float(np.median(v)), float(np.sqrt(np.mean(v ** 2)))) if len(v) else (math.nan, math.nan)


def read_geoinfo(names):
    with open(GEOINFO) as f:
        rows = [l.rstrip("\n").split("\t") for l in f if not l.startswith("#")]
    head = rows[0]
    recs = {r[0]: {k: float(r[head.index(k)]) for k in head[1:]} for r in rows[1:] if r[0] in names}
    missing = set(names) - set(recs)
    if missing:
        sys.exit(f"{GEOINFO} lacks {sorted(missing)}")
    return recs


def cpu_s(who=None):
    """CPU seconds (user + system) this process's threads (or, with RUSAGE_CHILDREN, its
    finished children) have used: a time less moved than the wall clock by other work on a
    shared machine."""
    r = resource.getrusage(resource.RUSAGE_SELF if who is None else who)
    return r.ru_utime + r.ru_stime


def write_position_priors(db, loc):
    """Writes every image's position (loc: {name: (E, N, up)}) into the database as a Cartesian
    pose prior, for images whose files carry no EXIF GPS (extract_features wrote none). The
    positions go in about their rounded mean, so that no large UTM values reach the spatial
    pairing's single-precision neighbour search; match_spatial needs only their distances."""
    origin = np.round(np.mean(list(loc.values()), axis=0))
    with pycolmap.Database.open(db) as d:
        for im in d.read_all_images():
            d.write_pose_prior(pycolmap.PosePrior(
                corr_data_id=im.data_id, position=np.asarray(loc[im.name], float) - origin,
                coordinate_system=pycolmap.PosePriorCoordinateSystem.CARTESIAN))
        return d.num_pose_priors()


def run_colmap(work, image_dir, names, loc, args, camera=None):
    """COLMAP from photos to geo-registered poses: ({name: (world_from_cv, centre)}, times, info).

    loc ({name: UTM (E, N, up)}) is what the models are aligned to, and the pose priors
    match_spatial pairs by when the photos carry no EXIF GPS (written into the database inside
    the extract_features step's time). camera (model, "p1,p2,...") fixes the one camera's
    model and parameters and keeps the bundle adjustments from refining them; without it COLMAP
    starts from EXIF (its default SIMPLE_RADIAL) and refines."""
    cdir = os.path.join(work, "colmap")
    shutil.rmtree(cdir, ignore_errors=True)
    os.makedirs(cdir)
    db = os.path.join(cdir, "database.db")
    threads = args.threads
    pycolmap.logging.minloglevel = 1  # warnings and errors only
    if hasattr(pycolmap, "set_random_seed"):
        pycolmap.set_random_seed(0)
    times, t0, c0 = {}, time.perf_counter(), cpu_s()
    ext = pycolmap.FeatureExtractionOptions()
    ext.num_threads, ext.max_image_size, ext.use_gpu = threads, args.max_image_size, False
    if args.sift_peak_threshold is not None:
        ext.sift.peak_threshold = args.sift_peak_threshold
    reader = pycolmap.ImageReaderOptions()
    if camera:
        reader.camera_model, reader.camera_params = camera
    t = time.perf_counter()
    pycolmap.extract_features(db, image_dir, image_names=names, camera_mode=pycolmap.CameraMode.SINGLE,
                              reader_options=reader, extraction_options=ext, device=pycolmap.Device.cpu)
    with pycolmap.Database.open(db) as d:
        priors = d.num_pose_priors()
    written = 0
    if priors == 0:
        priors = written = write_position_priors(db, loc)
    times["extract_features"] = time.perf_counter() - t
    match = pycolmap.FeatureMatchingOptions()
    match.num_threads, match.use_gpu = threads, False
    pairing = pycolmap.SpatialPairingOptions()
    pairing.num_threads, pairing.max_distance = threads, args.max_distance_m
    t = time.perf_counter()
    pycolmap.match_spatial(db, matching_options=match, pairing_options=pairing, device=pycolmap.Device.cpu)
    times["match_spatial"] = time.perf_counter() - t
    with pycolmap.Database.open(db) as d:
        pairs = d.num_verified_image_pairs()
    opts = pycolmap.IncrementalPipelineOptions()
    opts.num_threads, opts.min_model_size, opts.random_seed = threads, 3, 0
    if camera:
        opts.ba_refine_focal_length = opts.ba_refine_extra_params = False
        opts.mapper.abs_pose_refine_focal_length = opts.mapper.abs_pose_refine_extra_params = False
    t = time.perf_counter()
    models = pycolmap.incremental_mapping(db, image_dir, os.path.join(cdir, "sparse"), opts)
    times["incremental_mapping"] = time.perf_counter() - t
    t = time.perf_counter()
    poses, info = {}, {"pose_priors": priors, "priors_written": written, "verified_pairs": pairs, "models": []}
    for k, rec in sorted(models.items()):
        regs = [rec.image(i) for i in rec.reg_image_ids()]
        got = [im.name for im in regs]
        pts = np.array([loc[n] for n in got])
        spread = np.linalg.svd(pts[:, :2] - pts[:, :2].mean(0), compute_uv=False)
        m = {"model": k, "images": sorted(got), "gps_spread_m": [round(float(s), 1) for s in spread]}
        sim = pycolmap.align_reconstruction_to_locations(
            rec, got, pts, 3, pycolmap.RANSACOptions(max_error=args.align_error_m)) if len(got) >= 3 else None
        if sim is None:
            m["aligned"] = "no: GPS positions collinear" if spread[-1] < 1 else False
            info["models"].append(m)
            continue
        rec.transform(sim)
        m["aligned"], m["scale"] = True, float(sim.scale)
        for im in regs:
            w = im.cam_from_world().inverse()
            poses[im.name] = (w.rotation.matrix(), np.asarray(w.translation))
        m["gps_residual_m"] = float(np.median([np.linalg.norm(poses[n][1] - loc[n]) for n in got]))
        info["models"].append(m)
    times["align_to_locations"] = time.perf_counter() - t
    times["total"] = time.perf_counter() - t0
    info["cpu_s"] = cpu_s() - c0
    return poses, times, info


def run_ours(work, photos, extra, args):
    """Times mosaic --adjust and batch --adjust; ({name: (world_from_cv, centre)}, times, error)."""
    odir = os.path.join(work, "ours")
    shutil.rmtree(odir, ignore_errors=True)
    os.makedirs(odir)
    waited = 0
    while not os.access(EXE, os.X_OK):
        if waited >= args.wait_s:
            return {}, {}, f"{EXE} is absent (waited {waited} s)"
        print(f"{EXE} is absent; waiting", flush=True)
        time.sleep(30)
        waited += 30
    times, err = {}, None
    for step, cmd in [("mosaic", ["mosaic", *photos, "--out", os.path.join(odir, "mosaic.tif"), "--adjust"]),
                      ("batch", ["batch", *photos, "--out-dir", os.path.join(odir, "batch"), "--adjust"])]:
        shown = [cmd[0], f"<{len(photos)} photos>", *cmd[1 + len(photos):]] if len(photos) > 12 else \
            [os.path.basename(c) if c in photos else c for c in cmd]
        print("$ aerorect " + " ".join(shown + extra), flush=True)
        t, c = time.perf_counter(), cpu_s(resource.RUSAGE_CHILDREN)
        p = subprocess.run([EXE, *cmd, *extra], capture_output=True, text=True)
        times[step] = time.perf_counter() - t
        times[step + "_cpu"] = cpu_s(resource.RUSAGE_CHILDREN) - c
        tail = "\n".join(l[:240] for l in (p.stdout + p.stderr).strip().splitlines()[-12:])
        print("  " + tail.replace("\n", "\n  "))
        if p.returncode != 0:
            err = (err + "; " if err else "") + f"{step} exit {p.returncode}: {tail.splitlines()[-1] if tail else ''}"
    csv_path = os.path.join(odir, "batch", "adjusted_poses.csv")
    if not os.path.exists(csv_path):
        return {}, times, err or "no adjusted_poses.csv"
    return poses_from_csv(csv_path, args.epsg), times, err


def poses_from_csv(csv_path, epsg):
    """A pose table (filename,x,y,z,omega,phi,kappa with its .prj) as {name: (world_from_cv,
    centre)}, the centres taken into EPSG:epsg."""
    with open(os.path.splitext(csv_path)[0] + ".prj") as f:
        crs = pyproj.CRS.from_wkt(f.read())
    to_utm = pyproj.Transformer.from_crs(crs, pyproj.CRS.from_epsg(epsg), always_xy=True)
    if crs.to_epsg() != epsg:
        print(f"warning: {csv_path} is in {crs.name}, not EPSG:{epsg}: rotations compared as they are")
    poses = {}
    with open(csv_path) as f:
        for r in csv.DictReader(f):
            x, y = to_utm.transform(float(r["x"]), float(r["y"]))
            r_opk = rot(0, float(r["omega"])) @ rot(1, float(r["phi"])) @ rot(2, float(r["kappa"]))
            poses[r["filename"]] = (r_opk @ PATB_FROM_CV, np.array([x, y, float(r["z"])]))
    return poses


def main():
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[: argv.index("--")] if "--" in argv else argv
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("work_dir", nargs="?", default="/tmp/aerorect-flight-vs-colmap")
    ap.add_argument("--max-image-size", type=int, default=3200, help="COLMAP's SIFT long side (px)")
    ap.add_argument("--max-distance-m", type=float, default=200.0, help="match_spatial's radius")
    ap.add_argument("--align-error-m", type=float, default=10.0, help="RANSAC inlier distance of the GPS alignment")
    ap.add_argument("--wait-s", type=int, default=600, help="how long to wait for target/release/aerorect")
    ap.add_argument("--skip-ours", action="store_true")
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1, help="COLMAP's threads")
    ap.add_argument("--sift-peak-threshold", type=float, help="COLMAP's SIFT peak threshold (its default 0.0067)")
    args = ap.parse_args(argv)
    if not any(a in extra for a in ("--ground-height-m", "--dem")):
        extra += ["--ground-height-m", "160"]
    work = os.path.abspath(args.work_dir)
    os.makedirs(work, exist_ok=True)
    names = sorted(n for n in os.listdir(SNOW) if n.upper().endswith(".JPG"))
    photos = [os.path.join(SNOW, n) for n in names]
    geo = read_geoinfo(names)
    g0 = geo[names[0]]
    zone = int((g0["longitude"] + 180) // 6) + 1
    args.epsg = (32600 if g0["latitude"] >= 0 else 32700) + zone
    tf = pyproj.Transformer.from_crs(4326, args.epsg, always_xy=True)
    loc, gamma = {}, {}
    for n, g in geo.items():
        e, nn = tf.transform(g["longitude"], g["latitude"])
        loc[n] = np.array([e, nn, g["altitude_wgs84"]])
        e2, n2 = tf.transform(g["longitude"], g["latitude"] + 10 / 111320)  # 10 m north
        gamma[n] = math.degrees(math.atan2(e2 - e, n2 - nn))  # true north's bearing on the grid
    print(f"{len(names)} photos, EPSG:{args.epsg}, grid convergence {np.mean(list(gamma.values())):+.2f} deg; "
          f"pycolmap {pycolmap.__version__}, {args.threads} threads, SIFT max_image_size {args.max_image_size}, "
          f"load average {os.getloadavg()[0]:.1f}")

    colmap, ctimes, info = run_colmap(work, SNOW, names, loc, args)
    print(f"COLMAP: {info['pose_priors']} EXIF pose priors, {info['verified_pairs']} verified pairs, "
          f"{len(colmap)}/{len(names)} registered and geo-registered")
    for m in info["models"]:
        print(f"  model {m['model']}: {len(m['images'])} images {' '.join(i[4:8] for i in m['images'])}, "
              f"GPS spread {m['gps_spread_m']} m, aligned {m['aligned']}"
              + (f", scale {m['scale']:.3g}, median GPS residual {m['gps_residual_m']:.2f} m" if m["aligned"] is True else ""))
    print("  " + ", ".join(f"{k} {v:.1f} s" for k, v in ctimes.items()))

    print("\nrecorded (geoinfo) vs COLMAP, deg: angle, d_yaw d_pitch d_roll (COLMAP - recorded), angle w/o mean offset")
    rec = {n: recorded_grid_from_cv(geo[n]["heading"], geo[n]["pitch"], geo[n]["roll"], gamma[n]) for n in colmap}
    offs = [rec[n].T @ colmap[n][0] for n in colmap]  # camera-frame offsets
    mean_off = None
    if offs:
        u, _, vt = np.linalg.svd(sum(offs))
        mean_off = u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt
    rows = []
    for n in sorted(colmap):
        y0, p0, r0 = geo[n]["heading"], geo[n]["pitch"], geo[n]["roll"]
        y1, p1, r1 = body_ypr(colmap[n][0], gamma[n])
        row = (angle_deg(rec[n], colmap[n][0]), wrap(y1 - y0), p1 - p0, wrap(r1 - r0),
               angle_deg(rec[n] @ mean_off, colmap[n][0]))
        rows.append(row)
        print(f"  {n}: {row[0]:6.2f}  {row[1]:+6.2f} {row[2]:+6.2f} {row[3]:+6.2f}  {row[4]:6.2f}")
    cols = list(zip(*rows)) if rows else [[]] * 5
    rec_vs = {k: stats(c) for k, c in zip(["angle", "yaw", "pitch", "roll", "angle_without_offset"], cols)}
    for k, (med, rms) in rec_vs.items():
        print(f"  {k}: median {med:.2f}, rms {rms:.2f}")
    if mean_off is not None:
        print(f"  mean mounting offset (camera frame) {angle_deg(np.eye(3), mean_off):.2f} deg")

    ours, otimes, err = ({}, {}, "skipped") if args.skip_ours else run_ours(work, photos, extra, args)
    print("\nours vs COLMAP: angle (deg), centre distance (m)" + (f"\n  ours failed: {err}" if err else ""))
    common = sorted(set(ours) & set(colmap))
    ang = [angle_deg(ours[n][0], colmap[n][0]) for n in common]
    dist = [float(np.linalg.norm(ours[n][1] - colmap[n][1])) for n in common]
    for n, a, d in zip(common, ang, dist):
        print(f"  {n}: {a:6.2f} {d:7.2f}")
    ours_vs, dist_s = stats(ang), stats(dist)

    ours_t = otimes.get("mosaic", math.nan) if not (err or "").startswith("mosaic") else math.nan
    ratio = ctimes["total"] / ours_t if ours_t == ours_t and ours_t > 0 else math.nan
    print("\n| quantity | value |\n|---|---|")
    table = [("photos registered by COLMAP", f"{len(colmap)} / {len(names)}"),
             ("ours vs COLMAP angle, median / rms (deg)", f"{ours_vs[0]:.2f} / {ours_vs[1]:.2f} ({len(common)} photos)"),
             ("recorded vs COLMAP angle, median / rms (deg)", f"{rec_vs['angle'][0]:.2f} / {rec_vs['angle'][1]:.2f}"),
             ("ours vs COLMAP centre distance, median / rms (m)", f"{dist_s[0]:.2f} / {dist_s[1]:.2f}"),
             ("COLMAP time (s), no mosaic", f"{ctimes['total']:.1f} (CPU {info['cpu_s']:.1f})"),
             ("our time (s), mosaic --adjust end to end", f"{ours_t:.1f} (CPU {otimes.get('mosaic_cpu', math.nan):.1f})"),
             ("our batch --adjust time (s), for the poses", f"{otimes.get('batch', math.nan):.1f}"),
             ("ratio COLMAP / ours (target >= 10)", f"{ratio:.2f}"),
             ("ours", "ok" if not err else f"FAILED: {err}")]
    for k, v in table:
        print(f"| {k} | {v} |")
    summary = dict(pycolmap=pycolmap.__version__, epsg=args.epsg, max_image_size=args.max_image_size,
                   colmap_times_s=ctimes, colmap=info, recorded_vs_colmap_deg=rec_vs,
                   ours_vs_colmap_deg=ours_vs, ours_vs_colmap_centre_m=dist_s, ours_times_s=otimes,
                   ratio_colmap_over_ours=ratio, ours_error=err, extra_args=extra)
    with open(os.path.join(work, "summary.json"), "w") as f:
        json.dump(summary, f, indent=1, default=str)
    print(f"\nsummary: {os.path.join(work, 'summary.json')}")


if __name__ == "__main__":
    main()
