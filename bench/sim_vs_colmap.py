"""Our flight adjustment and COLMAP (pycolmap) side by side on a rendered flight with known poses.

The flight is `simulate_flight`'s (see bench/sim_flight.py): NX x NY frames of 480 x 360 px
(grey PNGs with no EXIF) over hills, the truth in truth.csv, the poses as recorded in pert.csv.
MODE `nadir[:SIGMA]` is the default DJI-style flight (nadir within 0.5 deg, recorded attitudes
N(0, SIGMA) deg off, default 1; its recorded positions are the true ones), `fixed-wing[:SIGMA]`
the fixed wing (rolled and pitched U(-5, 5) deg, crabbed 30 deg, positions N(0, 3 m) off east
and north and N(0, 2 m) up, attitudes N(0, SIGMA) off, default 5).

COLMAP: flight_vs_colmap.run_colmap on the frames with the recorded (pert.csv) positions:
the frames carry no EXIF GPS, so those positions are written into COLMAP's database as
Cartesian pose priors right after extract_features (inside its timed step); match_spatial pairs
by them (--max-distance-m, default 100 m; frames are 22-55 m apart), incremental_mapping, then
align_reconstruction_to_locations to the same positions. COLMAP gets the camera as we do
(cam.toml: PINHOLE f = 420 px, centre 239.5, 179.5) and does not refine it. SIFT at its
--max-image-size (default 3200 px: the frames' own 480 px), --threads (default the machine's
cores), seed 0, and --sift-peak-threshold 0.003: COLMAP's default 0.0067 finds about 45 points
in a frame of these low-contrast renders (790 at 0.003) and registers 6 of the 100 nadir and
32 of the 100 fixed-wing frames (10x10), 0.003 all of them.

Ours: with sim_flight.py's arguments (--poses pert.csv --camera cam.toml --dem dem.tif --gsd-m
0.25 --ties both --attitude-sigma-deg max(1, SIGMA), and --adjust-positions-m 3 for the fixed
wing), `aerorect mosaic --adjust` timed end to end (the ratio's time), then `aerorect batch
--adjust` (timed too) for adjusted_poses.csv.

Compared per frame, as world-from-camera rotations (UTM 33N; OpenCV axes): recorded, ours and
COLMAP against the truth, and ours against COLMAP: the angle of the relative rotation (deg) and
the camera-centre distance (m); median and rms over the frames each pair has; the block's
common world-frame turn between the two (the chordal mean) and the angles left without it
(the frames' own errors apart from the geo-registration's); then a summary table (also
WORK/summary.json).

    python3 bench/sim_vs_colmap.py NX NY [MODE] [WORK_DIR] [--threads 2] [--max-image-size N]
    python3 bench/sim_vs_colmap.py 10 10 fixed-wing:5 /tmp/sim-vs-colmap-fw --threads 2

WORK_DIR defaults to /tmp/aerorect-sim-vs-colmap-MODE-NXxNY; the flight is rendered into
WORK_DIR/sim once (SIMULATE_FLIGHT=path to a built simulate_flight example, else
target/release/examples/simulate_flight, else `cargo run --example simulate_flight`).
AERORECT=path overrides our binary. Timings are wall clock, with each side's CPU seconds (user
+ system; COLMAP's threads in this process, ours as child processes) next to them: keep the
machine quiet (the load average is printed before and after).
"""
import argparse, json, math, os, subprocess, sys, tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import flight_vs_colmap as fvc  # noqa: E402  (re-runs this script inside bench/.venv)
import numpy as np  # noqa: E402
import pycolmap  # noqa: E402

EPSG = 32633  # simulate_flight's CRS


def parse_mode(mode):
    """(fixed_wing, sigma_deg) from `nadir[:SIGMA]` or `fixed-wing[:SIGMA]`."""
    kind, _, sigma = mode.partition(":")
    if kind not in ("nadir", "fixed-wing"):
        sys.exit(f"mode {mode!r}: expected nadir[:SIGMA] or fixed-wing[:SIGMA]")
    fixed_wing = kind == "fixed-wing"
    return fixed_wing, float(sigma) if sigma else (5.0 if fixed_wing else 1.0)


def render(sim, nx, ny, fixed_wing, sigma):
    """Renders the flight into sim unless it is there already (of the same kind)."""
    if not os.path.exists(os.path.join(sim, "pert.csv")):
        args = [str(nx), str(ny), sim, str(sigma)] + (["fixed-wing"] if fixed_wing else [])
        exe = os.environ.get("SIMULATE_FLIGHT",
                             os.path.join(fvc.ROOT, "target", "release", "examples", "simulate_flight"))
        cmd = [exe] if os.access(exe, os.X_OK) else \
            ["cargo", "run", "--release", "-q", "-p", "aerorect", "--example", "simulate_flight", "--"]
        subprocess.run(cmd + args, cwd=fvc.ROOT, check=True)
    if os.path.exists(os.path.join(sim, "fixed_wing.txt")) != fixed_wing:
        sys.exit(f"{sim} holds another kind of flight: give another WORK_DIR")


def pinhole(cam_toml):
    with open(cam_toml, "rb") as f:
        c = tomllib.load(f)
    return "PINHOLE", ",".join(str(c[k]) for k in ("fx_px", "fy_px", "cx_px", "cy_px"))


def compare(a, b):
    """Per frame both hold: {name: (angle deg, centre distance m)}."""
    return {n: (fvc.angle_deg(a[n][0], b[n][0]), float(np.linalg.norm(a[n][1] - b[n][1])))
            for n in sorted(set(a) & set(b))}


def common_turn(a, b):
    """The world-frame turn D that best takes b's rotations onto a's (a ~ D b, the chordal mean
    of a b^T over the frames both hold) and each frame's angle (deg) left after it: the block's
    turn as a whole (what the geo-registration decides) apart from the frames' own errors."""
    common = sorted(set(a) & set(b))
    if not common:
        return math.nan, {}
    u, _, vt = np.linalg.svd(sum(a[n][0] @ b[n][0].T for n in common))
    d = u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt
    return fvc.angle_deg(np.eye(3), d), {n: fvc.angle_deg(a[n][0], d @ b[n][0]) for n in common}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("nx", type=int)
    ap.add_argument("ny", type=int)
    ap.add_argument("mode", nargs="?", default="nadir")
    ap.add_argument("work_dir", nargs="?")
    ap.add_argument("--max-image-size", type=int, default=3200, help="COLMAP's SIFT long side (px)")
    ap.add_argument("--max-distance-m", type=float, default=100.0, help="match_spatial's radius")
    ap.add_argument("--align-error-m", type=float, default=10.0, help="RANSAC inlier distance of the GPS alignment")
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1, help="COLMAP's threads")
    ap.add_argument("--sift-peak-threshold", type=float, default=0.003,
                    help="COLMAP's SIFT peak threshold (its default 0.0067 finds ~45 points a frame here)")
    ap.add_argument("--wait-s", type=int, default=0, help="how long to wait for our binary")
    ap.add_argument("--skip-ours", action="store_true", help="COLMAP only")
    args = ap.parse_args()
    args.epsg = EPSG
    fixed_wing, sigma = parse_mode(args.mode)
    work = os.path.abspath(args.work_dir or f"/tmp/aerorect-sim-vs-colmap-{args.mode.replace(':', '-')}-"
                                            f"{args.nx}x{args.ny}")
    sim = os.path.join(work, "sim")
    os.makedirs(work, exist_ok=True)
    render(sim, args.nx, args.ny, fixed_wing, sigma)
    frames_dir = os.path.join(sim, "frames")
    names = sorted(os.listdir(frames_dir))
    photos = [os.path.join(frames_dir, n) for n in names]
    truth = fvc.poses_from_csv(os.path.join(sim, "truth.csv"), EPSG)
    rec = fvc.poses_from_csv(os.path.join(sim, "pert.csv"), EPSG)
    loc = {n: rec[n][1] for n in names}
    camera = pinhole(os.path.join(sim, "cam.toml"))
    load0 = os.getloadavg()
    print(f"{len(names)} frames ({args.nx} x {args.ny}, {args.mode}), pycolmap {pycolmap.__version__}, "
          f"{args.threads} threads, SIFT max_image_size {args.max_image_size}, camera {camera}, "
          f"load average {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}", flush=True)

    colmap, ctimes, info = fvc.run_colmap(work, frames_dir, names, loc, args, camera=camera)
    print(f"COLMAP: {info['pose_priors']} pose priors ({info['priors_written']} written from pert.csv), "
          f"{info['verified_pairs']} verified pairs, {len(colmap)}/{len(names)} registered and geo-registered")
    for m in info["models"]:
        print(f"  model {m['model']}: {len(m['images'])} images, GPS spread {m['gps_spread_m']} m, "
              f"aligned {m['aligned']}" + (f", scale {m['scale']:.3g}, median GPS residual "
                                           f"{m['gps_residual_m']:.2f} m" if m["aligned"] is True else ""))
    print("  " + ", ".join(f"{k} {v:.1f} s" for k, v in ctimes.items()), flush=True)

    extra = ["--poses", os.path.join(sim, "pert.csv"), "--camera", os.path.join(sim, "cam.toml"),
             "--dem", os.path.join(sim, "dem.tif"), "--gsd-m", "0.25", "--ties", "both",
             "--attitude-sigma-deg", str(max(1.0, sigma))] + (["--adjust-positions-m", "3"] if fixed_wing else [])
    ours, otimes, err = ({}, {}, "skipped") if args.skip_ours else fvc.run_ours(work, photos, extra, args)
    load1 = os.getloadavg()

    pairs = {"recorded vs truth": compare(rec, truth), "ours vs truth": compare(ours, truth),
             "COLMAP vs truth": compare(colmap, truth), "ours vs COLMAP": compare(ours, colmap)}
    print("\nper frame: angle (deg) / centre distance (m); '-' where the frame has no such pose")
    print("  frame          " + "".join(f"{k:>20}" for k in pairs))
    for n in names:
        cells = [f"{p[n][0]:8.3f} / {p[n][1]:7.2f}" if n in p else f"{'-':>18}" for p in pairs.values()]
        print(f"  {n}  " + "".join(f"{c:>20}" for c in cells))
    summary = {}
    for k, p in pairs.items():
        (am, ar), (dm, dr) = fvc.stats([v[0] for v in p.values()]), fvc.stats([v[1] for v in p.values()])
        summary[k] = dict(frames=len(p), angle_deg_median=am, angle_deg_rms=ar, centre_m_median=dm, centre_m_rms=dr)
    for k, (a, b) in {"ours vs truth": (ours, truth), "COLMAP vs truth": (colmap, truth),
                      "ours vs COLMAP": (ours, colmap)}.items():
        turn, left = common_turn(a, b)
        summary[k]["common_turn_deg"] = turn
        summary[k]["angle_deg_median_without_turn"], summary[k]["angle_deg_rms_without_turn"] = \
            fvc.stats(list(left.values()))

    ours_t = otimes.get("mosaic", math.nan) if not (err or "").startswith("mosaic") else math.nan
    ratio = ctimes["total"] / ours_t if ours_t == ours_t and ours_t > 0 else math.nan
    print("\n| pair | frames | angle median / rms (deg) | block's common turn (deg) | angle without it, "
          "median / rms (deg) | centre median / rms (m) |\n|---|---|---|---|---|---|")
    for k, v in summary.items():
        turn = f"{v['common_turn_deg']:.3f} | {v['angle_deg_median_without_turn']:.3f} / " \
               f"{v['angle_deg_rms_without_turn']:.3f}" if "common_turn_deg" in v else "- | -"
        print(f"| {k} | {v['frames']} | {v['angle_deg_median']:.3f} / {v['angle_deg_rms']:.3f} | {turn} | "
              f"{v['centre_m_median']:.2f} / {v['centre_m_rms']:.2f} |")
    print("\n| step | time (s) |\n|---|---|")
    for k, v in ctimes.items():
        print(f"| COLMAP {k} | {v:.1f} |")
    cpu_ratio = info["cpu_s"] / otimes["mosaic_cpu"] if ours_t == ours_t and otimes.get("mosaic_cpu") else math.nan
    print(f"| ours mosaic --adjust, end to end | {ours_t:.1f} |\n| ours batch --adjust (for the poses) | "
          f"{otimes.get('batch', math.nan):.1f} |\n| ratio COLMAP total / ours mosaic (target >= 10) | {ratio:.2f} |")
    print(f"| CPU s (user + system): COLMAP total / ours mosaic / ours batch | {info['cpu_s']:.1f} / "
          f"{otimes.get('mosaic_cpu', math.nan):.1f} / {otimes.get('batch_cpu', math.nan):.1f} |\n"
          f"| CPU ratio COLMAP / ours mosaic | {cpu_ratio:.2f} |")
    print(f"\nCOLMAP registered {len(colmap)} / {len(names)}; ours {'ok' if not err else 'FAILED: ' + err}; "
          f"load average before {load0[0]:.2f}, after {load1[0]:.2f} (1 min)")
    out = dict(frames=len(names), mode=args.mode, pycolmap=pycolmap.__version__, threads=args.threads,
               max_image_size=args.max_image_size, max_distance_m=args.max_distance_m, camera=camera,
               colmap_times_s=ctimes, colmap=info, ours_times_s=otimes, ours_error=err, extra_args=extra,
               ratio_colmap_over_ours=ratio, cpu_ratio_colmap_over_ours=cpu_ratio, comparisons=summary, load_average=[load0, load1],
               per_frame={k: {n: list(v) for n, v in p.items()} for k, p in pairs.items()})
    with open(os.path.join(work, "summary.json"), "w") as f:
        json.dump(out, f, indent=1, default=str)
    print(f"summary: {os.path.join(work, 'summary.json')}")


if __name__ == "__main__":
    main()
