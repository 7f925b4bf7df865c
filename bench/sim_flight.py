#!/usr/bin/env python3
"""A simulated flight end to end: frames rendered with known poses over hills
(`cargo run --example simulate_flight`), every attitude recorded 1 degree off (sigma),
then `aerorect batch --adjust` and `aerorect mosaic --adjust` on them. Prints the
adjustment's time (whole flight and the solve), peak memory, the attitude errors before
and after against the truth, and the mosaic's time.

    python3 bench/sim_flight.py NX NY [WORK_DIR [SIGMA_DEG [TIES]]]   # e.g. 10 10, 40 25
    python3 bench/sim_flight.py 10 10 out/fw fixed-wing:5          # then fixed-wing-gps-only

SIGMA_DEG (default 1) is the recorded attitudes' error; TIES is `--ties` (both, features,
correlation; default both). SIGMA_DEG `gps-only` records no attitude at all: the frames get
an ODM geo.txt of positions only, each 3 m off (seeded), and start at nadir along their GPS
track. SIGMA_DEG `gcp` keeps the 1 degree errors, puts every position 3 m off in common plus
1 m of noise (`pert_gps.csv`) and adds the simulation's ground control (`gcp_list.txt`: five
GCPs and ten check points `C0`..`C9`, marks at 0.5 px of noise): `batch --adjust --gcps`,
then the check points' RMSE before and after (accuracy.json).

SIGMA_DEG `fixed-wing[:SIGMA]` flies a fixed wing instead (`simulate_flight ... fixed-wing`):
the image top to the nose, strips flown east and west in turn, every frame rolled and pitched
U(-5, 5) degrees, the nose 30 degrees off the track into the wind (the crab flips sign with the
strip), positions recorded N(0, 3 m) off east and north and N(0, 2 m) up, attitudes recorded
N(0, SIGMA) off (default 5 degrees), frames 22 m apart in 45 m strips. The recorded poses are a
GPS's, so `--adjust-positions-m 3` corrects them (a pose table's positions are otherwise held)
and `--attitude-sigma-deg SIGMA`. `fixed-wing-gps-only` is the same flight with no attitude at
all: an ODM geo.txt of the recorded (3 m off) positions, each frame starting at nadir along its
GPS track (30 degrees off the nose, 5 off the tilt). Both report the attitude error against the
truth as a total angle, split into tilt (the optical axis) and heading, and the positions'
error, then the block's heading as a whole (the mean signed kappa error and the frames' spread
about it; the turn of the adjusted and of the recorded GPS centres against the truth's): the
ties fix the frames' turns relative to each other, so that common turn is what the GPS, the
attitude priors and the DEM under the ties decide. A fixed-wing directory (`fixed_wing.txt`)
serves both fixed-wing modes, not the others.

Needs only the standard library (and cargo). Run with the machine otherwise quiet.
SIM_FLIGHT_MOSAIC=0 skips the mosaic; SIM_FLIGHT_NO_DEM=H flies without the DEM, the ground
taken level at H m (`--ground-height-m H`; the hills' mean is 25); SIM_FLIGHT_GPS_DRIFT=Z (GPS-only
modes) makes the recorded fixes drift as a consumer GPS's can: up Z m over the flight, linearly in
frame order, and 15 m east and 10 m south with it (mode `gcp` too: its pose table's positions); SIM_FLIGHT_PASSES=N gives `--adjust-passes N`;
AERORECT_FLIGHT_TIMING=1 prints where the adjustment's
time went (stderr of `batch`).
"""
import csv
import json
import math
import os
import random
import re
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "aerorect")


def rot(o, p, k):
    o, p, k = map(math.radians, (o, p, k))
    rx = [[1, 0, 0], [0, math.cos(o), -math.sin(o)], [0, math.sin(o), math.cos(o)]]
    ry = [[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]]
    rz = [[math.cos(k), -math.sin(k), 0], [math.sin(k), math.cos(k), 0], [0, 0, 1]]
    mul = lambda a, b: [[sum(a[i][t] * b[t][j] for t in range(3)) for j in range(3)] for i in range(3)]
    return mul(mul(rx, ry), rz)


def angle_deg(a, b):
    ra, rb = rot(*a), rot(*b)
    tr = sum(ra[t][i] * rb[t][i] for i in range(3) for t in range(3))
    return math.degrees(math.acos(max(-1.0, min(1.0, (tr - 1) / 2))))


def tilt_deg(a, b):
    """The angle between the two poses' optical axes (roll and pitch together)."""
    ra, rb = rot(*a), rot(*b)
    dot = sum(ra[t][2] * rb[t][2] for t in range(3))
    return math.degrees(math.acos(max(-1.0, min(1.0, dot))))


def heading_deg(a, b):
    """The difference of the two poses' kappas (their headings at nadir), within +-180."""
    return abs((a[2] - b[2] + 180.0) % 360.0 - 180.0)


def track_starts(positions):
    """What aerorect starts a frame with no attitude from: nadir, the image top along its GPS
    track from the previous to the next frame in name order (photo_source::track_headings;
    kappa is minus the heading)."""
    names = sorted(positions)
    out = {}
    for k, n in enumerate(names):
        a, b = positions[names[max(k - 1, 0)]], positions[names[min(k + 1, len(names) - 1)]]
        heading = math.degrees(math.atan2(b[0] - a[0], b[1] - a[1]))
        out[n] = [0.0, 0.0, -heading]
    return out


def drift(geo, up_m):
    """Rewrites an ODM geo.txt so that its fixes drift linearly in frame order: up_m up, and
    15 m east and 10 m south for every 110 m up."""
    lines = open(geo).read().splitlines()
    rows = [l.split() for l in lines[1:]]
    rows.sort(key=lambda r: r[0])
    with open(geo, "w") as g:
        g.write(lines[0] + "\n")
        for k, r in enumerate(rows):
            t = up_m * k / max(len(rows) - 1, 1)
            x, y, z = float(r[1]) + t * 15 / 110, float(r[2]) - t * 10 / 110, float(r[3]) + t
            g.write(f"{r[0]} {x:.3f} {y:.3f} {z:.3f}\n")


def drift_csv(src, dst, up_m):
    """drift() for a pose table: `src`'s positions drift as a consumer GPS's, written to `dst`."""
    with open(src) as f:
        rows = list(csv.DictReader(f))
    rows.sort(key=lambda r: r["filename"])
    with open(dst, "w", newline="") as g:
        w = csv.DictWriter(g, fieldnames=list(rows[0].keys()))
        w.writeheader()
        for k, r in enumerate(rows):
            t = up_m * k / max(len(rows) - 1, 1)
            r["x"] = f"{float(r['x']) + t * 15 / 110:.3f}"
            r["y"] = f"{float(r['y']) - t * 10 / 110:.3f}"
            r["z"] = f"{float(r['z']) + t:.3f}"
            w.writerow(r)
    shutil.copyfile(os.path.splitext(src)[0] + ".prj", os.path.splitext(dst)[0] + ".prj")


def centres(path):
    with open(path) as f:
        return {r["filename"]: [float(r[k]) for k in ("x", "y", "z")] for r in csv.DictReader(f)}


def position_errors(a, b):
    """Horizontal and vertical distances between the same frames' centres."""
    return ([math.hypot(a[n][0] - b[n][0], a[n][1] - b[n][1]) for n in b],
            [abs(a[n][2] - b[n][2]) for n in b])


def poses(path):
    with open(path) as f:
        return {r["filename"]: [float(r[k]) for k in ("omega", "phi", "kappa")] for r in csv.DictReader(f)}


def timed(args, cwd):
    """Runs args under /usr/bin/time; returns (seconds, peak RSS MB, stdout)."""
    t = time.perf_counter()
    p = subprocess.run(["/usr/bin/time", "-f", "%M"] + args, cwd=cwd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"failed: {' '.join(args)}\n{p.stderr[-3000:]}")
    lines = p.stderr.strip().splitlines()
    sys.stderr.write("".join(l + "\n" for l in lines if l.startswith("flight timing:")))
    peak_kb = int(lines[-1])
    return time.perf_counter() - t, peak_kb / 1024, p.stdout


def block_rotation_deg(a, b):
    """The turn about the vertical (degrees, anticlockwise) that best takes b's centres onto
    a's, each about its own centroid (least squares): how far a block is turned as a whole."""
    n = list(b)
    ca = [sum(a[k][i] for k in n) / len(n) for i in (0, 1)]
    cb = [sum(b[k][i] for k in n) / len(n) for i in (0, 1)]
    s = c = 0.0
    for k in n:
        (x1, y1), (x2, y2) = [b[k][i] - cb[i] for i in (0, 1)], [a[k][i] - ca[i] for i in (0, 1)]
        s, c = s + x1 * y2 - y1 * x2, c + x1 * x2 + y1 * y2
    return math.degrees(math.atan2(s, c))


def common_heading(adj, truth):
    """The mean signed kappa error (the whole block's heading error, degrees) and the spread
    (standard deviation) of the frames' own kappa errors about it."""
    d = [(adj[n][2] - truth[n][2] + 180.0) % 360.0 - 180.0 for n in truth]
    m = sum(d) / len(d)
    return m, math.sqrt(sum((v - m) ** 2 for v in d) / max(len(d) - 1, 1))


def stats(v):
    v = sorted(v)
    return f"median {v[len(v) // 2]:.3f}, max {v[-1]:.3f}"


def main():
    nx, ny = int(sys.argv[1]), int(sys.argv[2])
    work = sys.argv[3] if len(sys.argv) > 3 else os.path.join(ROOT, "out", f"sim-flight-{nx}x{ny}")
    sigma = sys.argv[4] if len(sys.argv) > 4 else "1"
    fixed_wing = sigma.startswith("fixed-wing")
    gps_only, gcp = sigma in ("gps-only", "fixed-wing-gps-only"), sigma == "gcp"
    if fixed_wing:
        sigma = "5" if gps_only or ":" not in sigma else sigma.split(":", 1)[1]
    elif gps_only or gcp:
        sigma = "1"
    ties = sys.argv[5] if len(sys.argv) > 5 else "both"
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "aerorect-cli"], cwd=ROOT, check=True)
    if not os.path.exists(os.path.join(work, "pert.csv")):
        subprocess.run(["cargo", "run", "--release", "-q", "-p", "aerorect", "--example",
                        "simulate_flight", "--", str(nx), str(ny), work, sigma]
                       + (["fixed-wing"] if fixed_wing else []), cwd=ROOT, check=True)
    marked = os.path.exists(os.path.join(work, "fixed_wing.txt"))
    if marked != fixed_wing:
        sys.exit(f"{work} holds a {'fixed-wing' if marked else 'nadir'} flight: "
                 "give another WORK_DIR for this mode")
    if fixed_wing and not gps_only:
        line = open(os.path.join(work, "fixed_wing.txt")).read()
        m = re.search(r"recorded attitude N\(0, ([0-9.]+) deg\)", line)
        if not m or float(m.group(1)) != float(sigma):
            sys.exit(f"{work} was simulated with other attitude errors ({line.strip()}): give another WORK_DIR")
    frames = sorted(os.path.join("frames", f) for f in os.listdir(os.path.join(work, "frames")))
    common = ["--poses", "pert.csv", "--camera", "cam.toml", "--dem", "dem.tif", "--gsd-m", "0.25", "--adjust",
              "--ties", ties, "--attitude-sigma-deg", str(max(1.0, float(sigma)))]
    if fixed_wing and not gps_only:
        common += ["--adjust-positions-m", "3"]
    if gps_only and fixed_wing:
        # The positions the fixed wing recorded (3 m off), its attitudes dropped.
        with open(os.path.join(work, "pert.csv")) as f, open(os.path.join(work, "geo.txt"), "w") as g:
            g.write("EPSG:32633\n")
            for r in csv.DictReader(f):
                g.write(f"{r['filename']} {r['x']} {r['y']} {r['z']}\n")
        common[0:2] = ["--geo", "geo.txt"]
    elif gps_only:
        rng = random.Random(1)
        with open(os.path.join(work, "truth.csv")) as f, open(os.path.join(work, "geo.txt"), "w") as g:
            g.write("EPSG:32633\n")
            for r in csv.DictReader(f):
                x, y, z = (float(r[k]) + rng.gauss(0, 3) for k in ("x", "y", "z"))
                g.write(f"{r['filename']} {x:.3f} {y:.3f} {z:.3f}\n")
        common[0:2] = ["--geo", "geo.txt"]
    if gps_only and os.environ.get("SIM_FLIGHT_GPS_DRIFT"):
        drift(os.path.join(work, "geo.txt"), float(os.environ["SIM_FLIGHT_GPS_DRIFT"]))
    if gcp and os.environ.get("SIM_FLIGHT_GPS_DRIFT"):
        drift_csv(os.path.join(work, "pert_gps.csv"), os.path.join(work, "pert_gps_drift.csv"),
                  float(os.environ["SIM_FLIGHT_GPS_DRIFT"]))
    if os.environ.get("SIM_FLIGHT_PASSES"):
        common += ["--adjust-passes", os.environ["SIM_FLIGHT_PASSES"]]
    if os.environ.get("SIM_FLIGHT_NO_DEM"):
        at = common.index("--dem")
        common[at:at + 2] = ["--ground-height-m", os.environ["SIM_FLIGHT_NO_DEM"]]
    if gcp:
        checks = open(os.path.join(work, "checkpoints.txt")).read().strip()
        common[1] = "pert_gps_drift.csv" if os.environ.get("SIM_FLIGHT_GPS_DRIFT") else "pert_gps.csv"
        common += ["--gcps", "gcp_list.txt", "--checkpoints", checks]
    secs, peak, _ = timed([BIN, "batch", *frames, "--out-dir", "out", "--force", *common], work)
    if gcp:
        acc = json.load(open(os.path.join(work, "out", "accuracy.json")))
        gsd = acc["mean_gsd_m"]
        for what in ("control", "check"):
            b, r = acc[f"{what}_before"], acc[what]
            print(f"  {what} points ({r['count']}): RMSE XY / Z {b['xy_m']:.3f} / {b['z_m']:.3f} m recorded -> "
                  f"{r['xy_m']:.3f} / {r['z_m']:.3f} m adjusted = {r['xy_m'] / gsd:.2f} / {r['z_m'] / gsd:.2f} GSD "
                  f"(GSD {gsd:.3f} m)")
        print(f"  ASPRS 2014 horizontal: {acc['asprs_horizontal']}")
    rep = json.load(open(os.path.join(work, "out", "adjustment.json")))
    truth = poses(os.path.join(work, "truth.csv"))
    if gps_only:
        with open(os.path.join(work, "geo.txt")) as g:
            geo = {p[0]: [float(v) for v in p[1:4]] for p in (l.split() for l in g.readlines()[1:])}
        rec = track_starts(geo)
    else:
        rec = poses(os.path.join(work, "pert.csv"))
    adj = poses(os.path.join(work, "out", "adjusted_poses.csv"))
    before = [angle_deg(rec[n], truth[n]) for n in truth]
    after = [angle_deg(adj[n], truth[n]) for n in truth]
    a = rep["adjustment"]
    print(f"{len(frames)} frames ({nx} x {ny}), {a['tie_points']} tie points, {rep['passes']} matching rounds")
    print(f"  batch --adjust: {secs:.1f} s end to end (flight matched and adjusted in {rep['seconds']:.1f} s, "
          f"last solve {a['seconds']:.2f} s), peak RSS {peak:.0f} MB")
    print(f"  tie rms {a['rms_before_px']:.2f} -> {a['rms_after_px']:.3f} px; "
          f"reliable pairs {sum(p['reliable'] for p in rep['pairs'])} of {len(rep['pairs'])}, "
          f"unconnected {len(rep['unconnected'])}")
    start = "none recorded, nadir along the GPS track: " if gps_only else ""
    print(f"  attitude error vs truth, deg: before {start}{stats(before)}; after {stats(after)}")
    if fixed_wing:
        for what, f in (("tilt (optical axis)", tilt_deg), ("heading", heading_deg)):
            print(f"    {what}: before {stats([f(rec[n], truth[n]) for n in truth])}; "
                  f"after {stats([f(adj[n], truth[n]) for n in truth])}")
        true_c = centres(os.path.join(work, "truth.csv"))
        rec_c = geo if gps_only else centres(os.path.join(work, "pert.csv"))
        adj_c = centres(os.path.join(work, "out", "adjusted_poses.csv"))
        (hb, vb), (ha, va) = position_errors(rec_c, true_c), position_errors(adj_c, true_c)
        print(f"  position error vs truth, m: horizontal before {stats(hb)}, after {stats(ha)}; "
              f"vertical before {stats(vb)}, after {stats(va)}")
        # Ties fix the frames' turns relative to each other; the block's heading as a whole
        # is only the GPS's, the attitude priors' and the DEM's (heights under the ties).
        mean, spread = common_heading(adj, truth)
        print(f"  block heading vs truth, deg: kappa error mean {mean:+.3f} (frames' sd about it "
              f"{spread:.3f}); turn of the centres: adjusted {block_rotation_deg(adj_c, true_c):+.3f}, "
              f"recorded GPS {block_rotation_deg(rec_c, true_c):+.3f}")
    lost = {u.split("/")[-1] for u in rep["unconnected"]}
    if lost:
        tied = [angle_deg(adj[n], truth[n]) for n in truth if n not in lost]
        print(f"  ... of the {len(tied)} tied frames: {stats(tied)}; untied (left as recorded, "
              f"recorded error {', '.join(f'{angle_deg(rec[n], truth[n]):.2f}' for n in sorted(lost))} deg): "
              f"{', '.join(sorted(lost))}")
    mis = [p["misalignment_after_m"] for p in rep["pairs"] if p["misalignment_after_m"] is not None]
    print(f"  pair misalignment after (m, on the ties): {stats(mis)}")
    if os.environ.get("SIM_FLIGHT_MOSAIC") == "0":
        return
    secs, peak, _ = timed([BIN, "mosaic", *frames, "--out", "mosaic.tif", *common], work)
    print(f"  mosaic --adjust: {secs:.1f} s end to end, peak RSS {peak:.0f} MB")


if __name__ == "__main__":
    main()
