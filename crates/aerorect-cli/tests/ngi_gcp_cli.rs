//! Extended: ground control on NGI's four aerial frames (two strips, a 24 m DEM). Ground
//! points are taken from the DEM where the published exterior orientation sees them and
//! projected into every frame by it (the marks); the poses are then perturbed (a common GPS
//! offset of 5 m plus 1 m per frame, 0.1-0.2 degrees per angle) and `batch --adjust --gcps`
//! must bring them back to the published ones and the check points, kept out of the solve,
//! within a pixel on the ground.
#![allow(clippy::unwrap_used)]

mod common;
use aerorect::core::{Camera, CameraRotation, ImageSize, Intrinsics, Vec3};
use common::{aerorect, fails, ok};
use std::collections::BTreeMap;

/// The published poses: name -> [x, y, z, omega, phi, kappa].
fn published(csv: &str) -> BTreeMap<String, [f64; 6]> {
    csv.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let v: Vec<f64> = f[1..7].iter().map(|s| s.trim().parse().unwrap()).collect();
            (f[0].to_string(), [v[0], v[1], v[2], v[3], v[4], v[5]])
        })
        .collect()
}

fn rotation(p: &[f64; 6]) -> aerorect::core::Mat3 {
    *CameraRotation::omega_phi_kappa(p[3], p[4], p[5])
        .unwrap()
        .ground_from_camera()
}

fn angle_deg(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    let m = rotation(a).transpose() * rotation(b);
    ((m.trace() - 1.0) / 2.0)
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// NGI's camera: 120 mm on 144 um pixels, principal point at the centre.
fn camera() -> Camera {
    let f = 120.0 / 0.144;
    Camera::new(
        Intrinsics::new(f, f, 319.5, 575.5).unwrap(),
        None,
        ImageSize::new(640, 1152),
    )
}

fn pixel(p: &[f64; 6], x: Vec3) -> Option<[f64; 2]> {
    let d = rotation(p).transpose() * (x - Vec3::new(p[0], p[1], p[2]));
    camera()
        .pixel_from_camera_point(d)
        .filter(|q| q[0] >= 0.0 && q[1] >= 0.0 && q[0] <= 639.0 && q[1] <= 1151.0)
}

/// The ground point under pixel (u, v) of pose `p`: the ray met with the DEM.
fn ground(p: &[f64; 6], (u, v): (f64, f64), dem: &aerorect::geo::Dem) -> Vec3 {
    let ray = rotation(p) * camera().ray_from_pixel(u, v).unwrap();
    let c = Vec3::new(p[0], p[1], p[2]);
    let mut x = c + ray * ((300.0 - c.z) / ray.z);
    for _ in 0..30 {
        let h = dem.height_at(x.x, x.y).unwrap();
        x = c + ray * ((h - c.z) / ray.z);
    }
    x
}

#[test]
fn ground_control_brings_perturbed_ngi_poses_back_and_checks_within_a_pixel() {
    let (Some(dir), Some(dem_path)) = (
        aerorect_testkit::shared_data("ngi"),
        aerorect_testkit::shared_data("ngi/dem.tif"),
    ) else {
        return;
    };
    let truth = published(&std::fs::read_to_string(dir.join("ngi_xyz_opk.csv")).unwrap());
    let dem = aerorect::georef::load_dem(&dem_path).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    // Points on a grid of each frame's pixels, marked in every frame that sees them.
    let mut csv = String::from("name,image,u,v,x,y,z,check\n");
    let (mut points, mut checks) = (0, 0);
    for p in truth.values() {
        for (u, v) in [
            (120.0, 200.0),
            (520.0, 200.0),
            (320.0, 576.0),
            (120.0, 950.0),
            (520.0, 950.0),
        ] {
            let g = ground(p, (u, v), &dem);
            let check = points % 3 == 2;
            let name = format!("P{points}");
            for (n, q) in &truth {
                if let Some(px) = pixel(q, g) {
                    csv += &format!(
                        "{name},{n}.tif,{},{},{},{},{},{check}\n",
                        px[0], px[1], g.x, g.y, g.z
                    );
                }
            }
            points += 1;
            checks += usize::from(check);
        }
    }
    assert!(checks >= 5);
    std::fs::write(tmp.path().join("gcps.csv"), csv).unwrap();
    // Common GPS offset of 5 m and per-frame error; attitudes off 0.1-0.2 degrees.
    let offsets = [
        [1.2, -0.4, 0.3, 0.12, -0.15, 0.1],
        [-0.6, 0.9, -1.1, -0.18, 0.11, -0.14],
        [0.3, 1.3, 0.8, 0.15, 0.16, -0.12],
        [-1.0, -0.7, -0.2, -0.11, -0.17, 0.19],
    ];
    let mut pert = String::from("filename,x,y,z,omega,phi,kappa\n");
    for ((name, p), d) in truth.iter().zip(offsets) {
        pert += &format!(
            "{name},{},{},{},{},{},{}\n",
            p[0] + 3.0 + d[0],
            p[1] - 4.0 + d[1],
            p[2] + d[2],
            p[3] + d[3],
            p[4] + d[4],
            p[5] + d[5]
        );
    }
    std::fs::write(tmp.path().join("pert.csv"), pert).unwrap();
    std::fs::copy(dir.join("ngi_xyz_opk.prj"), tmp.path().join("pert.prj")).unwrap();
    std::fs::write(
        tmp.path().join("cam.toml"),
        "focal_length_mm = 120.0\npixel_pitch_um = [144.0, 144.0]\nimage_size_px = [640, 1152]\n",
    )
    .unwrap();
    let frames: Vec<String> = truth
        .keys()
        .map(|n| dir.join(format!("{n}.tif")).display().to_string())
        .collect();
    let dem_arg = dem_path.display().to_string();
    let run = |extra: &[&str], out: &str| {
        let mut args: Vec<&str> = vec!["batch"];
        args.extend(frames.iter().map(String::as_str));
        args.extend([
            "--out-dir",
            out,
            "--poses",
            "pert.csv",
            "--camera",
            "cam.toml",
            "--dem",
            &dem_arg,
            "--gsd-m",
            "5",
            "--adjust",
        ]);
        args.extend(extra);
        aerorect(&args, tmp.path())
    };
    let stdout = ok(&run(&["--gcps", "gcps.csv"], "out"));
    eprintln!("{stdout}");
    let adjusted =
        published(&std::fs::read_to_string(tmp.path().join("out/adjusted_poses.csv")).unwrap());
    for (name, t) in &truth {
        let a = adjusted[&format!("{name}.tif")];
        let moved = Vec3::new(a[0] - t[0], a[1] - t[1], a[2] - t[2]).norm();
        let turn = angle_deg(t, &a);
        eprintln!("{name}: {moved:.2} m and {turn:.4} deg from the published pose");
        // Marks at 1 px are 6 m on the ground: a frame's position and attitude trade within
        // that (5 m from 4,800 m is 0.06 degrees) without moving the ground.
        assert!(moved < 4.0 && turn < 0.05, "{name}: {moved} m, {turn} deg");
    }
    let acc: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tmp.path().join("out/accuracy.json")).unwrap(),
    )
    .unwrap();
    let before = acc["check_before"]["xy_m"].as_f64().unwrap();
    let after = acc["check"]["xy_m"].as_f64().unwrap();
    let z = acc["check"]["z_m"].as_f64().unwrap();
    eprintln!("check points XY {before:.2} -> {after:.2} m, Z {z:.2} m");
    assert!(before > 5.0, "{before}");
    assert!(after < 5.6 && z < 3.0 * 5.6, "{after} {z}");
    assert_eq!(acc["check"]["count"].as_u64().unwrap() as usize, checks);
    // A check point named on the command line that the file does not hold is refused.
    fails(
        &run(&["--gcps", "gcps.csv", "--checkpoints", "Q9"], "out2"),
        &["Q9", "gcps.csv"],
    );
    assert!(!tmp.path().join("out2/adjustment.json").exists());
}

/// The NGI flight's inputs in `dir` (published poses, camera) and the batch arguments over them.
struct Ngi {
    frames: Vec<String>,
    dem: String,
    truth: BTreeMap<String, [f64; 6]>,
    ground: aerorect::geo::Dem,
}

fn ngi(tmp: &std::path::Path) -> Option<Ngi> {
    let dir = aerorect_testkit::shared_data("ngi")?;
    let dem = dir.join("dem.tif");
    let truth = published(&std::fs::read_to_string(dir.join("ngi_xyz_opk.csv")).unwrap());
    std::fs::copy(dir.join("ngi_xyz_opk.csv"), tmp.join("poses.csv")).unwrap();
    std::fs::copy(dir.join("ngi_xyz_opk.prj"), tmp.join("poses.prj")).unwrap();
    std::fs::write(
        tmp.join("cam.toml"),
        "focal_length_mm = 120.0\npixel_pitch_um = [144.0, 144.0]\nimage_size_px = [640, 1152]\n",
    )
    .unwrap();
    Some(Ngi {
        frames: truth
            .keys()
            .map(|n| dir.join(format!("{n}.tif")).display().to_string())
            .collect(),
        ground: aerorect::georef::load_dem(&dem).unwrap(),
        dem: dem.display().to_string(),
        truth,
    })
}

impl Ngi {
    fn batch(&self, tmp: &std::path::Path, gcps: &str, extra: &[&str]) -> std::process::Output {
        let mut args: Vec<&str> = vec!["batch"];
        args.extend(self.frames.iter().map(String::as_str));
        args.extend([
            "--out-dir",
            "out",
            "--poses",
            "poses.csv",
            "--camera",
            "cam.toml",
            "--dem",
            &self.dem,
            "--gsd-m",
            "10",
            "--adjust",
            "--ties",
            "features",
            "--gcps",
            gcps,
        ]);
        args.extend(extra);
        aerorect(&args, tmp)
    }

    /// Our CSV rows of the ground point under pixel (u, v) of frame `k`, marked in every frame
    /// that sees it.
    fn rows(&self, name: &str, k: usize, (u, v): (f64, f64), check: bool) -> String {
        let p = self.truth.values().nth(k).unwrap();
        let g = ground(p, (u, v), &self.ground);
        let mut out = String::new();
        for (n, q) in &self.truth {
            if let Some(px) = pixel(q, g) {
                out += &format!(
                    "{name},{n}.tif,{},{},{},{},{},{check}\n",
                    px[0], px[1], g.x, g.y, g.z
                );
            }
        }
        out
    }
}

const HEADER: &str = "name,image,u,v,x,y,z,check\n";

#[test]
fn bad_ground_control_is_named_with_its_file_line_and_value() {
    let tmp = tempfile::tempdir().unwrap();
    let Some(n) = ngi(tmp.path()) else {
        return;
    };
    let t = tmp.path();
    // Two control points: solved as a shift, and said so.
    let two = format!(
        "{HEADER}{}{}",
        n.rows("A", 0, (200.0, 300.0), false),
        n.rows("B", 2, (400.0, 800.0), false)
    );
    std::fs::write(t.join("two.csv"), &two).unwrap();
    let out = n.batch(t, "two.csv", &[]);
    ok(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("two.csv: 2 ground control point(s), fewer than 3")
            && err.contains("shift only"),
        "{err}"
    );
    // A mark in a photo that cannot see the point: left out with its line, predicted position
    // and distance. A corner of frame 0 that some frame does not see.
    let (a, far) = [(20.0, 20.0), (620.0, 20.0), (20.0, 1130.0), (620.0, 1130.0)]
        .iter()
        .find_map(|&uv| {
            let a = n.rows("A", 0, uv, false);
            let far = n.truth.keys().find(|k| !a.contains(&format!("{k}.tif")))?;
            Some((a, far.clone()))
        })
        .unwrap();
    let g = a
        .lines()
        .next()
        .unwrap()
        .split(',')
        .skip(4)
        .collect::<Vec<_>>()
        .join(",");
    let wrong = format!(
        "{HEADER}{a}A,{far}.tif,320,576,{g}\n{}{}",
        n.rows("B", 2, (400.0, 800.0), false),
        n.rows("C", 1, (300.0, 500.0), false)
    );
    let line = wrong
        .lines()
        .position(|l| l.contains(&format!("{far}.tif,320,576")))
        .unwrap()
        + 1;
    std::fs::write(t.join("wrong.csv"), &wrong).unwrap();
    std::fs::remove_dir_all(t.join("out")).unwrap();
    let out = n.batch(t, "wrong.csv", &[]);
    ok(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!(
            "wrong.csv line {line}: 'A' is marked in {far}.tif at (320.0, 576.0) px"
        )) && err.contains("outside the photo: the mark is left out"),
        "{err}"
    );
    // A check point that is a control point under another name checks nothing.
    let same = format!(
        "{HEADER}{}{}",
        n.rows("A", 0, (200.0, 300.0), false),
        n.rows("A2", 0, (200.0, 300.0), true)
    );
    std::fs::write(t.join("same.csv"), &same).unwrap();
    fails(
        &n.batch(t, "same.csv", &["--gcp-sigma-px", "0.5"]),
        &["same.csv", "check point 'A2'", "'A'"],
    );
    // One name at two places.
    let twice = format!("{HEADER}A,x.tif,1,2,500,600,10,false\nA,y.tif,1,2,500,700,10,false\n");
    std::fs::write(t.join("twice.csv"), &twice).unwrap();
    fails(
        &n.batch(t, "twice.csv", &[]),
        &["twice.csv", "line 2", "line 3", "'A'"],
    );
    // An ODM file whose CRS line does not parse.
    std::fs::write(t.join("gcp_list.txt"), "WGS84 UTM 99Q\n1 2 3 4 5 a.tif A\n").unwrap();
    fails(
        &n.batch(t, "gcp_list.txt", &[]),
        &["gcp_list.txt", "line 1", "WGS84 UTM 99Q"],
    );
    // A negative mark deviation.
    fails(
        &n.batch(t, "two.csv", &["--gcp-sigma-px=-1"]),
        &["mark standard deviation", "-1"],
    );
}

#[test]
fn gcp_predict_puts_points_where_the_published_poses_see_them() {
    let tmp = tempfile::tempdir().unwrap();
    let Some(n) = ngi(tmp.path()) else {
        return;
    };
    let t = tmp.path();
    let rows = format!(
        "{HEADER}{}{}",
        n.rows("A", 0, (200.0, 300.0), false),
        n.rows("B", 3, (400.0, 800.0), false)
    );
    std::fs::write(t.join("g.csv"), &rows).unwrap();
    let mut args = vec!["gcp-predict", "g.csv", "--photos"];
    args.extend(n.frames.iter().map(String::as_str));
    args.extend([
        "--poses",
        "poses.csv",
        "--camera",
        "cam.toml",
        "--dem",
        &n.dem,
    ]);
    args.extend(["--out-dir", "chips", "--chip-px", "65"]);
    let stdout = ok(&aerorect(&args, t));
    // Every mark (projected through the published poses) is predicted within 0.01 px, and
    // nothing else is predicted.
    let predicted: Vec<&str> = stdout
        .lines()
        .skip(1)
        .filter(|l| l.contains(".tif,"))
        .collect();
    let marks: Vec<&str> = rows.lines().skip(1).collect();
    assert_eq!(predicted.len(), marks.len(), "{stdout}");
    for m in marks {
        let f: Vec<&str> = m.split(',').collect();
        let (u, v): (f64, f64) = (f[2].parse().unwrap(), f[3].parse().unwrap());
        let p = predicted
            .iter()
            .map(|l| l.split(',').collect::<Vec<_>>())
            .find(|p| p[0] == f[0] && p[1] == f[1])
            .unwrap_or_else(|| panic!("{m} not predicted: {stdout}"));
        let (pu, pv): (f64, f64) = (p[2].parse().unwrap(), p[3].parse().unwrap());
        assert!((pu - u).hypot(pv - v) < 0.01, "{m}: {pu} {pv}");
        assert_eq!(p[4], "true", "marked in the file");
        let stem = f[1].trim_end_matches(".tif");
        let chip = aerorect::io::read_image(&t.join(format!("chips/{}_{stem}.png", f[0]))).unwrap();
        assert_eq!((chip.size().width, chip.size().height), (65, 65));
    }
    // The predictions as ODM's gcp_list.txt: the poses' CRS, then one line per mark.
    let listed = std::fs::read_to_string(t.join("chips/gcp_predicted.txt")).unwrap();
    assert!(
        listed.lines().next().unwrap().contains("+proj=tmerc"),
        "{listed}"
    );
    assert_eq!(listed.lines().count(), predicted.len() + 1);
}
