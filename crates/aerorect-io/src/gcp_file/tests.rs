use super::*;

fn err(text: &str, name: &str) -> String {
    gcp_from_text(text, name).unwrap_err().to_string()
}

/// Asserts that a message names the file, the line and the value.
fn names_all(e: &str, file: &str, line: &str, value: &str) {
    assert!(
        e.contains(file) && e.contains(line) && e.contains(value),
        "'{e}' should name {file}, {line} and {value}"
    );
}

/// ODM's documented example, verbatim (docs.opendronemap.org/gcp, "GCP file format"):
/// `geo_x geo_y geo_z im_x im_y image_name [gcp_name] [extra1] [extra2]` under a PROJ line.
const ODM_DOC: &str = "+proj=utm +zone=10 +ellps=WGS84 +datum=WGS84 +units=m +no_defs
544256.7 5320919.9 5 3044 2622 IMG_0525.jpg
544157.7 5320899.2 5 4193 1552 IMG_0585.jpg
544033.4 5320876.0 5 1606 2763 IMG_0690.jpg
";

#[test]
fn odm_documented_example_gives_one_point_per_distinct_unnamed_position() {
    let g = gcp_from_text(ODM_DOC, "gcp_list.txt").unwrap();
    assert_eq!(g.format, GcpFormat::Odm);
    assert_eq!(
        g.crs,
        Some(
            Crs::from_proj_string("+proj=utm +zone=10 +ellps=WGS84 +datum=WGS84 +units=m +no_defs")
                .unwrap()
        )
    );
    // Columns 1-3 are the point, 4-5 the pixel, 6 the image; no names, three positions.
    assert_eq!(g.points.len(), 3);
    assert_eq!(g.marks.len(), 3);
    for (i, l) in ODM_DOC.lines().skip(1).enumerate() {
        let f: Vec<&str> = l.split_whitespace().collect();
        let col = |k: usize| f[k].parse::<f64>().unwrap();
        let p = &g.points[i];
        assert_eq!(p.xyz, [col(0), col(1), col(2)]);
        assert_eq!(p.line, i + 2);
        assert_eq!(p.sigma_m, None);
        assert!(!p.check, "ODM has no check-point column");
        let m = &g.marks[i];
        assert_eq!((m.image.as_str(), m.pixel), (f[5], [col(3), col(4)]));
        assert_eq!(m.point, p.name);
    }
    let names: Vec<&str> = g.points.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["gcp1", "gcp2", "gcp3"]);
}

/// A named EPSG:4326 gcp_list.txt in the form of the ODM docs' lon-lat examples (geo.txt's
/// `-91.99... 46.84...`): x is the longitude, y the latitude; the 7th column names the point.
#[test]
fn odm_epsg_4326_lines_of_one_name_are_one_point_longitude_first() {
    let t = "EPSG:4326\n\
             -116.7499838 43.06477015 2090.149 1559.41 1372.84 DJI_0177.JPG 100\n\
             -116.7499838\t43.06477015\t2090.149\t1491.01\t2471.85\tDJI_0355.JPG\t100\n\
             # a comment line\n\
             \n\
             -116.7504805 43.06475631 2088.227 1737.22 1763.28 DJI_0172.JPG 101 extra words\n\
             -116.7504805 43.06475631 2088.227 1660.24 2912.50 DJI_0350.JPG 101 # trailing\n";
    let g = gcp_from_text(t, "gcp_list.txt").unwrap();
    assert_eq!(g.crs, Some(Crs::from_epsg(4326).unwrap()));
    assert_eq!(g.points.len(), 2);
    assert_eq!(g.points[0].name, "100");
    assert_eq!(g.points[0].xyz, [-116.7499838, 43.06477015, 2090.149]);
    assert_eq!(g.points[1].line, 6);
    assert_eq!(g.marks.len(), 4);
    assert_eq!(
        g.marks.iter().filter(|m| m.point == "101").count(),
        2,
        "both 101 lines are marks of point 101"
    );
    // Latitude first is caught: geo_y beyond 90 cannot be a latitude.
    let e = err("EPSG:4326\n43.06 116.75 2090 1 1 a.jpg\n", "g.txt");
    names_all(&e, "g.txt", "line 2", "116.75");
    assert!(e.contains("latitude"), "{e}");
}

#[test]
fn odm_crs_line_variants() {
    let body = "\n500000 4500000 10 100 200 a.jpg p1\n";
    let crs = |first: &str| {
        gcp_from_text(&format!("{first}{body}"), "g.txt")
            .unwrap()
            .crs
    };
    assert_eq!(crs("WGS84 UTM 32N"), Some(Crs::from_epsg(32632).unwrap()));
    assert_eq!(crs("WGS84 UTM 32S"), Some(Crs::from_epsg(32732).unwrap()));
    assert_eq!(crs("WGS84 UTM 7N"), Some(Crs::from_epsg(32607).unwrap()));
    assert_eq!(crs("EPSG:32610"), Some(Crs::from_epsg(32610).unwrap()));
    let proj = "+proj=utm +zone=37 +south +ellps=WGS84 +datum=WGS84 +units=m +no_defs";
    assert_eq!(crs(proj), Some(Crs::from_proj_string(proj).unwrap()));
    assert_eq!(
        crs(&format!("'{proj}'")),
        Some(Crs::from_proj_string(proj).unwrap())
    );
    for bad in ["WGS84 UTM 61N", "WGS84 UTM 32X", "EPSG:abc", "NAD83 please"] {
        let e = err(&format!("{bad}{body}"), "gcp_list.txt");
        names_all(&e, "gcp_list.txt", "line 1", &format!("'{bad}'"));
    }
}

#[test]
fn odm_grouping_by_name_and_by_coordinates() {
    // Unnamed lines at one position are one point; a named line is its own point even at
    // the same position (two names at one place are allowed).
    let t = "EPSG:32632\n\
             10 20 30 1 1 a.jpg\n\
             11 20 30 1 1 a.jpg\n\
             10 20 30 2 2 b.jpg\n\
             10 20 30 3 3 c.jpg named\n\
             10 20 30 4 4 d.jpg other\n\
             10.0004 20 30 5 5 e.jpg named\n";
    let g = gcp_from_text(t, "g.txt").unwrap();
    let names: Vec<&str> = g.points.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["gcp1", "gcp2", "named", "other"]);
    let on = |p: &str| g.marks.iter().filter(|m| m.point == p).count();
    assert_eq!(
        (on("gcp1"), on("gcp2"), on("named"), on("other")),
        (2, 1, 2, 1)
    );
    assert_eq!(
        g.points[2].xyz,
        [10.0, 20.0, 30.0],
        "the first line defines it"
    );
}

#[test]
fn one_name_at_two_places_names_both_lines() {
    let t = "EPSG:32632\n10 20 30 1 1 a.jpg P\n10.01 20 30 1 1 b.jpg P\n";
    let e = err(t, "gcp_list.txt");
    names_all(&e, "gcp_list.txt", "line 2", "'P'");
    assert!(e.contains("line 3") && e.contains("10.01"), "{e}");
    let csv = "P,1,2,3\nQ,1,2,3\nP,1,2,3.5\n";
    let e = err(csv, "gcps.csv");
    names_all(&e, "gcps.csv", "line 1", "3.5");
    assert!(e.contains("line 3"), "{e}");
}

/// Pix4D's documented GCP lines (support.pix4d.com, "Tie points (GCPs, CPs) import format"):
/// `label, coordinate1, coordinate2, z[, Accuracy Horz, Accuracy Vert]`, no header.
#[test]
fn pix4d_coordinates_with_and_without_accuracy() {
    let t = "GCP0,2532795.105,1152094.639,395.883,0.02,0.03\n\
             GCP1,2532728.805,1152079.825,396.619\n";
    let g = gcp_from_text(t, "gcps.csv").unwrap();
    assert_eq!(g.format, GcpFormat::Pix4d);
    assert_eq!(g.crs, None, "Pix4D's file names no CRS");
    assert!(g.marks.is_empty());
    assert_eq!(g.points[0].name, "GCP0");
    assert_eq!(g.points[0].xyz, [2532795.105, 1152094.639, 395.883]);
    assert_eq!(g.points[0].sigma_m, Some([0.02, 0.03]));
    assert_eq!(g.points[1].sigma_m, None);
    let e = err("GCP0,1,2,3,0.02\n", "gcps.csv");
    names_all(&e, "gcps.csv", "line 1", "5 fields");
}

/// A coordinates file and a marks file (PIX4Dmapper's `imagename,gcplabel,x,y`) read as one.
#[test]
fn pix4d_coordinates_and_marks_read_together() {
    let dir = tempfile::tempdir().unwrap();
    let coords = dir.path().join("gcps.csv");
    let marks = dir.path().join("marks.csv");
    std::fs::write(
        &coords,
        "GCP0,46.23456,6.56114,299.931\n100,46.23234,6.56234,299.823\n",
    )
    .unwrap();
    std::fs::write(
        &marks,
        "IMG_0001.JPG,GCP0,1520.25,980.5\nIMG_0002.JPG,GCP0,300,400\nIMG_0002.JPG,100,10,20\n",
    )
    .unwrap();
    let g = read_gcp_files(&[coords.clone(), marks.clone()]).unwrap();
    assert_eq!(g.path, coords);
    assert_eq!(g.points.len(), 2);
    assert_eq!(g.marks.len(), 3);
    assert_eq!(g.marks[0].point, "GCP0");
    assert_eq!(g.marks[0].image, "IMG_0001.JPG");
    // Pix4D counts from the corner: the project's pixel centres are half a pixel less.
    assert_eq!(g.marks[0].pixel, [1519.75, 980.0]);
    assert_eq!(g.marks[2].point, "100", "a numeric label in a marks file");
    // The order of the paths does not matter.
    let h = read_gcp_files(&[marks.clone(), coords.clone()]).unwrap();
    assert_eq!((h.points, h.marks), (g.points, g.marks));
    // The marks file alone has no points.
    let e = read_gcp_file(&marks).unwrap_err().to_string();
    assert!(
        e.contains("marks.csv") && e.contains("coordinates file"),
        "{e}"
    );
    // A mark of a point no file defines.
    let stray = dir.path().join("stray.csv");
    std::fs::write(&stray, "IMG_0001.JPG,GCP0,1,2\nIMG_0003.JPG,GCP9,5,6\n").unwrap();
    let e = read_gcp_files(&[coords.clone(), stray])
        .unwrap_err()
        .to_string();
    names_all(&e, "stray.csv", "line 2", "'GCP9'");
    // A point marked twice in one image across files.
    let again = dir.path().join("again.csv");
    std::fs::write(&again, "IMG_0001.JPG,GCP0,1,2\n").unwrap();
    let e = read_gcp_files(&[coords, marks, again])
        .unwrap_err()
        .to_string();
    names_all(&e, "again.csv", "line 1", "'IMG_0001.JPG'");
    assert!(e.contains("marks.csv line 1"), "{e}");
}

/// PhotoScan/Metashape's marker reference export as published (gist dakotabenjamin/f9e5b8fc,
/// "#Label,X/East,Y/North,Z/Altitude,Accuracy_(m),Error_(m),...,X_est,Y_est,Z_est"), labels
/// quoted on some lines, the accuracy left empty.
#[test]
fn metashape_photoscan_export_reads_label_and_reference_columns() {
    let t = "#Label,X/East,Y/North,Z/Altitude,Accuracy_(m),Error_(m),X_error,Y_error,Z_error,X_est,Y_est,Z_est\n\
             GCP41,3078.071568,1480.959192,304.821336,,0.027775,-0.019520,-0.006123,0.018786,3078.052048,1480.953069,304.840122\n\
             \"GCP14\",3119.615808,1514.596920,304.800000,,0.008081,-0.004850,0.006462,-0.000148,3119.610958,1514.603382,304.799852\n";
    let g = gcp_from_text(t, "markers.csv").unwrap();
    assert_eq!(g.format, GcpFormat::Metashape);
    assert_eq!(g.points.len(), 2);
    assert_eq!(g.points[0].name, "GCP41");
    assert_eq!(g.points[0].xyz, [3078.071568, 1480.959192, 304.821336]);
    assert_eq!(g.points[0].sigma_m, None);
    assert_eq!(
        g.points[1].name, "GCP14",
        "quotes are not part of the label"
    );
    assert_eq!(g.points[1].xyz[2], 304.8);
    assert!(g.marks.is_empty(), "the CSV holds no projections");
}

#[test]
fn metashape_accuracies_and_enable_flag() {
    let t = "# Markers\n\
             #Label,Enable,X/Longitude,Y/Latitude,Z/Altitude,Accuracy_X/Y_(m),Accuracy_Z_(m),X_est\n\
             p1,1,6.56114,46.23456,299.9,0.02,0.05,6.5\n\
             p2,0,6.56234,46.23234,299.8,0.01,0.04,\n\
             p3,1,,,,,,\n";
    let g = gcp_from_text(t, "markers.csv").unwrap();
    assert_eq!(g.format, GcpFormat::Metashape);
    assert_eq!(
        g.points.len(),
        2,
        "a marker without reference coordinates is skipped"
    );
    assert_eq!(g.points[0].xyz, [6.56114, 46.23456, 299.9]);
    assert_eq!(g.points[0].sigma_m, Some([0.02, 0.05]));
    assert!(!g.points[0].check);
    assert!(g.points[1].check, "a marker not enabled is a check point");
    let per_axis = "#Label,X,Y,Z,X_accuracy,Y_accuracy,Z_accuracy\np,1,2,3,0.01,0.03,0.05\n";
    let g = gcp_from_text(per_axis, "m.csv").unwrap();
    assert_eq!(
        g.points[0].sigma_m,
        Some([0.03, 0.05]),
        "horizontal is the larger"
    );
    let one = "#Label,X/East,Y/North,Z/Altitude,Accuracy_(m)\np,1,2,3,0.005\n";
    assert_eq!(
        gcp_from_text(one, "m.csv").unwrap().points[0].sigma_m,
        Some([0.005, 0.005])
    );
    let e = err("#Label,X/East,Y/North,Accuracy_(m)\np,1,2,0.1\n", "m.csv");
    names_all(&e, "m.csv", "line 1", "no z column");
}

#[test]
fn aerorect_csv_rows_are_observations_and_points() {
    let t = "name,image,u,v,x,y,z,sigma_xy_m,sigma_z_m,check\n\
             A,IMG_1.JPG,99.5,10,500000,4500000,12.5,0.02,0.04,false\n\
             A,IMG_2.JPG,0,0,500000,4500000,12.5,0.02,0.04,no\n\
             B,,,,500100,4500100,13,,,yes\n";
    let g = gcp_from_text(t, "gcps.csv").unwrap();
    assert_eq!(g.format, GcpFormat::Aerorect);
    assert_eq!(g.crs, None);
    assert_eq!(g.points.len(), 2);
    assert_eq!(g.points[0].sigma_m, Some([0.02, 0.04]));
    assert!(!g.points[0].check && g.points[1].check);
    assert_eq!(g.points[1].sigma_m, None);
    assert_eq!(g.marks.len(), 2, "B has no mark");
    // u, v are the project's pixel coordinates, read as they are.
    assert_eq!(g.marks[1].pixel, [0.0, 0.0]);
    assert_eq!(g.marks[0].pixel, [99.5, 10.0]);
    // Only the required columns, in another order.
    let g = gcp_from_text("x,y,z,name,image,u,v\n1,2,3,P,a.jpg,4,5\n", "g.csv").unwrap();
    assert_eq!(
        (g.points[0].xyz, g.marks[0].pixel),
        ([1.0, 2.0, 3.0], [4.0, 5.0])
    );
    let e = err("name,image,u,v,x,y,z,colour\n", "g.csv");
    names_all(&e, "g.csv", "line 1", "'colour'");
    let e = err(
        "name,image,u,v,x,y,z,check\nP,a.jpg,1,2,3,4,5,maybe\n",
        "g.csv",
    );
    names_all(&e, "g.csv", "line 2", "'maybe'");
}

#[test]
fn bad_numbers_name_file_line_column_and_value() {
    let head = "EPSG:32632\n10 20 30 1 1 a.jpg\n";
    for (bad, value) in [
        ("10 20 abc 1 1 b.jpg", "geo_z 'abc' is not a number"),
        ("10 20 NaN 1 1 b.jpg", "geo_z 'NaN'"),
        ("10 20 30 inf 1 b.jpg", "im_x 'inf'"),
        ("2e9 20 30 1 1 b.jpg", "geo_x '2e9'"),
        ("10 20 30 1 -1e10 b.jpg", "im_y '-1e10'"),
    ] {
        let e = err(&format!("{head}{bad}\n"), "gcp_list.txt");
        names_all(&e, "gcp_list.txt", "line 3", value);
    }
    let e = err("GCP0,1,2,3,-0.02,0.02\n", "gcps.csv");
    names_all(
        &e,
        "gcps.csv",
        "line 1",
        "accuracy_horz '-0.02' is negative",
    );
    let e = err(
        "name,image,u,v,x,y,z,sigma_xy_m,sigma_z_m\nP,,,,1,2,3,0.1,-1\n",
        "g.csv",
    );
    names_all(&e, "g.csv", "line 2", "sigma_z_m '-1' is negative");
    let e = err("#Label,X,Y,Z,Accuracy_(m)\np,1,2,3,-5\n", "m.csv");
    names_all(&e, "m.csv", "line 2", "'-5' is negative");
    let e = err("IMG_1.JPG,P,x1,2\n", "marks.csv");
    names_all(&e, "marks.csv", "line 1", "'x1'");
}

#[test]
fn empty_files_and_files_without_points_are_refused() {
    for empty in ["", "\n  \n", "# only a comment\n"] {
        let e = err(empty, "gcp_list.txt");
        assert!(e.contains("gcp_list.txt") && e.contains("empty"), "{e}");
    }
    let e = err("EPSG:4326\n# nothing\n", "gcp_list.txt");
    assert!(e.contains("gcp_list.txt") && e.contains("no points"), "{e}");
    let e = err("name,image,u,v,x,y,z\n", "g.csv");
    assert!(e.contains("g.csv") && e.contains("no points"), "{e}");
    let e = err("EPSG:32632\n10 20 30 1 1\n", "gcp_list.txt");
    names_all(&e, "gcp_list.txt", "line 2", "'10 20 30 1 1'");
}

#[test]
fn a_point_marked_twice_in_one_image_names_both_lines() {
    let t = "WGS84 UTM 32N\n10 20 30 1 1 a.jpg P\n10 20 30 5 5 b.jpg P\n10 20 30 9 9 a.jpg P\n";
    let e = err(t, "gcp_list.txt");
    names_all(&e, "gcp_list.txt", "lines 2 and 4", "'a.jpg'");
    let csv = "name,image,u,v,x,y,z\nP,a.jpg,1,1,1,2,3\nP,a.jpg,2,2,1,2,3\n";
    let e = err(csv, "g.csv");
    names_all(&e, "g.csv", "lines 2 and 3", "'P'");
}

#[test]
fn formats_are_detected_from_content() {
    assert_eq!(detect_format(ODM_DOC), GcpFormat::Odm);
    assert_eq!(
        detect_format("WGS84 UTM 16N\n1 2 3 4 5 a.jpg\n"),
        GcpFormat::Odm
    );
    assert_eq!(detect_format("GCP0,1,2,3\n"), GcpFormat::Pix4d);
    assert_eq!(detect_format("a.jpg,GCP0,1,2\n"), GcpFormat::Pix4d);
    assert_eq!(
        detect_format("# x\n#Label,X,Y,Z\np,1,2,3\n"),
        GcpFormat::Metashape
    );
    assert_eq!(detect_format("name,image,u,v,x,y,z\n"), GcpFormat::Aerorect);
}

#[test]
fn read_gcp_file_reads_from_disk_with_the_path_in_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("gcp_list.txt");
    std::fs::write(&p, ODM_DOC).unwrap();
    let g = read_gcp_file(&p).unwrap();
    assert_eq!((g.path, g.points.len()), (p.clone(), 3));
    std::fs::write(&p, "EPSG:32610\n1 2 x 4 5 a.jpg\n").unwrap();
    let e = read_gcp_file(&p).unwrap_err().to_string();
    names_all(&e, &p.display().to_string(), "line 2", "geo_z 'x'");
}
