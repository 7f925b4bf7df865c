//! The seed files: the repository's real images and tables, images written by our own writer
//! (PNG and TIFF at u8/u16/f32, GeoTIFFs of three kinds of CRS, BigTIFF, TIFFs carrying EXIF,
//! XMP and GDAL metadata), a DJI-style JPEG with EXIF (GPS) and XMP, camera and attitude TOML,
//! the CSV tables and CRS strings; NGI's JPEG-compressed YCbCr TIFF when ../shared/data has it.
//! Each binary seed carries the positions of its header integer fields.

use super::mutate::Field;
use aerorect_core::ImageSize;
use aerorect_geo::Crs;
use aerorect_io::{GeoReference, write_image_geo};
use aerorect_raster::{AnyRaster, Raster};
use std::path::{Path, PathBuf};
use tiff::encoder::{Rational, TiffEncoder, colortype};
use tiff::tags::Tag;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// PNG, JPEG or TIFF: every image and metadata reader.
    Image,
    Xmp,
    CameraToml,
    /// Other tools' camera files (OpenCV, COLMAP, OpenSfM, Metashape, DJI, Orthority).
    CameraFormat,
    /// Hostile camera files (YAML alias bombs, deep nesting, a text over the size cap): every
    /// camera reader must refuse them, within bounded memory and time.
    HostileCamera,
    AttitudeToml,
    AttitudeInline,
    Checkpoints,
    Gcps,
    ControlPoints,
    Poses,
    Crs,
}

impl Kind {
    pub fn is_text(self) -> bool {
        self != Kind::Image
    }
}

pub struct Seed {
    pub name: String,
    pub kind: Kind,
    pub bytes: Vec<u8>,
    pub fields: Vec<Field>,
}

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel)
}

fn seed(name: &str, kind: Kind, bytes: Vec<u8>) -> Seed {
    let fields = if kind == Kind::Image {
        fields_of(&bytes)
    } else {
        Vec::new()
    };
    Seed {
        name: name.to_string(),
        kind,
        bytes,
        fields,
    }
}

/// The integer header fields of a PNG (chunk lengths, IHDR), a JPEG (segment lengths, frame
/// size, the TIFF structure of an EXIF segment) or a TIFF/BigTIFF (every IFD entry's type,
/// count and value, IFD offsets, the EXIF and GPS sub-IFDs).
pub fn fields_of(b: &[u8]) -> Vec<Field> {
    let mut out = Vec::new();
    let be = |pos, width| Field {
        pos,
        width,
        big_endian: true,
    };
    if b.starts_with(b"\x89PNG") {
        let mut at = 8;
        while at + 12 <= b.len() {
            out.push(be(at, 4));
            if &b[at + 4..at + 8] == b"IHDR" {
                out.extend([
                    be(at + 8, 4),
                    be(at + 12, 4),
                    be(at + 16, 1),
                    be(at + 17, 1),
                ]);
                out.extend([be(at + 18, 1), be(at + 19, 1), be(at + 20, 1)]);
            }
            let n = u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]) as usize;
            at += 12 + n;
        }
    } else if b.starts_with(&[0xFF, 0xD8]) {
        let mut at = 2;
        while at + 4 <= b.len() && b[at] == 0xFF {
            let marker = b[at + 1];
            if marker == 0xDA {
                out.push(be(at + 2, 2));
                break;
            }
            out.push(be(at + 2, 2));
            if matches!(marker, 0xC0..=0xC3) {
                out.extend([be(at + 4, 1), be(at + 5, 2), be(at + 7, 2), be(at + 9, 1)]);
            }
            if marker == 0xE1 && b[at + 4..].starts_with(b"Exif\0\0") {
                tiff_fields(b, at + 10, &mut out);
            }
            at += 2 + usize::from(u16::from_be_bytes([b[at + 2], b[at + 3]]));
        }
    } else {
        tiff_fields(b, 0, &mut out);
    }
    out
}

/// The TIFF structure starting at `base` (offsets inside it are relative to `base`).
fn tiff_fields(b: &[u8], base: usize, out: &mut Vec<Field>) {
    let Some(h) = b.get(base..base + 16) else {
        return;
    };
    let big_endian = match &h[..2] {
        b"II" => false,
        b"MM" => true,
        _ => return,
    };
    let f = |pos, width| Field {
        pos: base + pos,
        width,
        big_endian,
    };
    let rd = |pos: usize, width: usize| -> Option<u64> {
        let s = b.get(base + pos..base + pos + width)?;
        let mut v = [0u8; 8];
        if big_endian {
            v[8 - width..].copy_from_slice(s);
            Some(u64::from_be_bytes(v))
        } else {
            v[..width].copy_from_slice(s);
            Some(u64::from_le_bytes(v))
        }
    };
    let big = rd(2, 2) == Some(43);
    let (count_w, entry, first) = if big { (8, 20, 8) } else { (4, 12, 4) };
    out.push(f(first, count_w));
    let mut queue = vec![rd(first, count_w).unwrap_or(0) as usize];
    let mut seen = 0;
    while let Some(ifd) = queue.pop() {
        seen += 1;
        if ifd == 0 || seen > 16 {
            continue;
        }
        let n_w = if big { 8 } else { 2 };
        let Some(n) = rd(ifd, n_w) else { continue };
        out.push(f(ifd, n_w));
        let n = (n as usize).min(500);
        for i in 0..n {
            let e = ifd + n_w + i * entry;
            let Some(tag) = rd(e, 2) else { break };
            out.extend([f(e + 2, 2), f(e + 4, count_w), f(e + 4 + count_w, count_w)]);
            out.push(f(e + 4 + count_w, 2));
            if tag == 34665 || tag == 34853 || tag == 330 {
                queue.push(rd(e + 4 + count_w, count_w).unwrap_or(0) as usize);
            }
        }
        let next = ifd + n_w + n * entry;
        out.push(f(next, count_w));
        queue.push(rd(next, count_w).unwrap_or(0) as usize);
    }
}

/// An IFD entry: tag, type, count, value bytes; type 0 is a pointer to the IFD whose index the
/// count holds.
type Entry = (u16, u16, u32, Vec<u8>);

/// A little-endian TIFF structure of the given IFDs.
fn tiff_block(ifds: &[Vec<Entry>]) -> Vec<u8> {
    let ifd_len = |n: usize| 2 + 12 * n + 4;
    let mut at = 8;
    let offsets: Vec<usize> = ifds
        .iter()
        .map(|d| {
            let o = at;
            at += ifd_len(d.len());
            o
        })
        .collect();
    let mut data_at = at;
    let mut head = b"II*\0".to_vec();
    head.extend_from_slice(&8u32.to_le_bytes());
    let mut data = Vec::new();
    for d in ifds {
        head.extend_from_slice(&(d.len() as u16).to_le_bytes());
        for (tag, typ, count, value) in d {
            head.extend_from_slice(&tag.to_le_bytes());
            if *typ == 0 {
                head.extend_from_slice(&4u16.to_le_bytes());
                head.extend_from_slice(&1u32.to_le_bytes());
                head.extend_from_slice(&(offsets[*count as usize] as u32).to_le_bytes());
                continue;
            }
            head.extend_from_slice(&typ.to_le_bytes());
            head.extend_from_slice(&count.to_le_bytes());
            if value.len() <= 4 {
                let mut v = value.clone();
                v.resize(4, 0);
                head.extend_from_slice(&v);
            } else {
                head.extend_from_slice(&(data_at as u32).to_le_bytes());
                data.extend_from_slice(value);
                data_at += value.len();
            }
        }
        head.extend_from_slice(&0u32.to_le_bytes());
    }
    head.extend_from_slice(&data);
    head
}

fn rationals(v: &[(u32, u32)]) -> Vec<u8> {
    v.iter()
        .flat_map(|(n, d)| n.to_le_bytes().into_iter().chain(d.to_le_bytes()))
        .collect()
}

/// An EXIF APP1 segment as a DJI camera writes one: make, model, focal lengths, the size the
/// photo was taken at, the time and a GPS fix (degrees, minutes, seconds as rationals).
fn exif_app1() -> Vec<u8> {
    let ascii = |s: &str| (s.len() as u32 + 1, [s.as_bytes(), b"\0"].concat());
    let (nm, make) = ascii("DJI");
    let (nmo, model) = ascii("FC6310");
    let (nt, time) = ascii("2024:05:01 12:00:00");
    let ifd0 = vec![
        (271, 2, nm, make),
        (272, 2, nmo, model),
        (274, 3, 1, 1u16.to_le_bytes().to_vec()),
        (34665, 0, 1, vec![]),
        (34853, 0, 2, vec![]),
    ];
    let exif = vec![
        (36867, 2, nt, time),
        (37386, 5, 1, rationals(&[(88, 10)])),
        (40962, 4, 1, 64u32.to_le_bytes().to_vec()),
        (40963, 4, 1, 48u32.to_le_bytes().to_vec()),
        (41989, 3, 1, 24u16.to_le_bytes().to_vec()),
    ];
    let gps = vec![
        (1, 2, 2, b"N\0".to_vec()),
        (2, 5, 3, rationals(&[(53, 1), (54, 1), (1234, 100)])),
        (3, 2, 2, b"E\0".to_vec()),
        (4, 5, 3, rationals(&[(27, 1), (33, 1), (0, 1)])),
        (5, 1, 1, vec![0]),
        (6, 5, 1, rationals(&[(2505, 10)])),
    ];
    let tiff = tiff_block(&[ifd0, exif, gps]);
    let mut seg = vec![0xFF, 0xE1];
    seg.extend_from_slice(&((tiff.len() + 8) as u16).to_be_bytes());
    seg.extend_from_slice(b"Exif\0\0");
    seg.extend_from_slice(&tiff);
    seg
}

pub const DJI_XMP: &str = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:AbsoluteAltitude="+312.50" drone-dji:RelativeAltitude="+80.00" drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="+30.00" drone-dji:GimbalPitchDegree="-70.00" drone-dji:FlightRollDegree="+1.00" drone-dji:FlightYawDegree="+12.00" drone-dji:FlightPitchDegree="-2.00" drone-dji:GpsLatitude="+53.900000" drone-dji:GpsLongtitude="+27.550000" drone-dji:CalibratedFocalLength="3666.67" drone-dji:CalibratedOpticalCenterX="2736.00" drone-dji:CalibratedOpticalCenterY="1824.00" drone-dji:DewarpData="2018-06-08;3678.87,3671.63,9.02,-16.13,-0.2677,0.1110,0.0009,-0.0001,-0.0294"/></rdf:RDF></x:xmpmeta>"#;

/// `jpeg` with APP1 segments inserted after SOI: EXIF and/or an XMP packet.
pub fn with_app1(jpeg: &[u8], exif: bool, xmp: Option<&[u8]>) -> Vec<u8> {
    let mut out = jpeg[..2].to_vec();
    if exif {
        out.extend(exif_app1());
    }
    if let Some(x) = xmp {
        let mut payload = b"http://ns.adobe.com/xap/1.0/\0".to_vec();
        payload.extend_from_slice(x);
        let n = (payload.len() + 2).min(usize::from(u16::MAX));
        out.extend_from_slice(&[0xff, 0xe1]);
        out.extend_from_slice(&(n as u16).to_be_bytes());
        out.extend_from_slice(&payload[..n - 2]);
    }
    out.extend_from_slice(&jpeg[2..]);
    out
}

/// The top-left `w` x `h` pixels of a raster.
fn crop<T: aerorect_raster::Sample>(r: &Raster<T>, w: usize, h: usize) -> Raster<T> {
    let planes = r
        .planes()
        .iter()
        .map(|p| {
            (0..h)
                .flat_map(|y| p[y * r.width()..y * r.width() + w].iter().copied())
                .collect()
        })
        .collect();
    Raster::from_planes(ImageSize::new(w, h), planes).expect("crop")
}

fn written(dir: &Path, name: &str, img: &AnyRaster, geo: Option<&GeoReference>) -> Vec<u8> {
    let p = dir.join(name);
    write_image_geo(&p, img, geo).expect("write seed");
    std::fs::read(&p).expect("read seed")
}

fn small_jpeg(rgb: &Raster<u8>) -> Vec<u8> {
    let mut out = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, 80)
        .encode(
            &rgb.to_interleaved(),
            rgb.width() as u32,
            rgb.height() as u32,
            image::ExtendedColorType::Rgb8,
        )
        .expect("encode jpeg");
    out
}

fn tiff_with_tags(dir: &Path, name: &str, tags: &[(u16, &str)], exif: bool) -> Vec<u8> {
    let p = dir.join(name);
    let mut enc = TiffEncoder::new(std::fs::File::create(&p).expect("create")).expect("tiff");
    let exif_at = exif.then(|| {
        let mut d = enc.extra_directory().expect("exif ifd");
        d.write_tag(Tag::Unknown(37386), Rational { n: 473, d: 100 })
            .expect("tag");
        d.write_tag(Tag::Unknown(40962), 4000u32).expect("tag");
        d.write_tag(Tag::Unknown(40963), 2250u32).expect("tag");
        d.finish_with_offsets().expect("exif ifd").offset
    });
    let mut img = enc.new_image::<colortype::Gray8>(4, 3).expect("image");
    let e = img.encoder();
    for (tag, value) in tags {
        e.write_tag(Tag::Unknown(*tag), *value).expect("tag");
    }
    if let Some(at) = exif_at {
        e.write_tag(Tag::Unknown(34665), at).expect("tag");
    }
    img.write_data(&[7u8; 12]).expect("data");
    drop(enc);
    std::fs::read(&p).expect("read seed")
}

/// The NGI DEM's CRS (a compound WKT with a user-defined transverse Mercator).
pub const LO25_WKT: &str = r#"COMPD_CS["Lo25 WGS84 + EGM2008 height",PROJCS["Lo25 WGS84 + EGM2008 height",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563,AUTHORITY["EPSG","7030"]],AUTHORITY["EPSG","6326"]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433,AUTHORITY["EPSG","9122"]],AUTHORITY["EPSG","4326"]],PROJECTION["Transverse_Mercator"],PARAMETER["latitude_of_origin",0],PARAMETER["central_meridian",25],PARAMETER["scale_factor",1],PARAMETER["false_easting",0],PARAMETER["false_northing",0],UNIT["metre",1,AUTHORITY["EPSG","9001"]],AXIS["Easting",EAST],AXIS["Northing",NORTH]],VERT_CS["EGM2008 height",VERT_DATUM["EGM2008 geoid",2005,AUTHORITY["EPSG","1027"]],UNIT["metre",1,AUTHORITY["EPSG","9001"]],AXIS["Up",UP]]]"#;

const TMERC: &str = "+proj=tmerc +lat_0=0 +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m";

fn geo(crs: Crs, nodata: Option<f64>) -> GeoReference {
    GeoReference {
        crs,
        pixel_size: [0.25, 0.25],
        top_left: [500_123.5, 5_975_432.25],
        rotation: [0.0, 0.0],
        nodata,
    }
}

/// Every seed; images are written into `dir`.
pub fn all(dir: &Path) -> Vec<Seed> {
    let aero = std::fs::read(repo("data/aero1.jpg")).expect("data/aero1.jpg");
    let AnyRaster::U8(full) = aerorect_io::read_image(&repo("data/aero1.jpg")).expect("aero1")
    else {
        panic!("aero1.jpg is 8-bit");
    };
    let rgb = crop(&full, 48, 32);
    let gray = Raster::from_planes(rgb.size(), vec![rgb.plane(0).to_vec()]).expect("gray");
    let gray16 = gray.map_samples(|v| u16::from(v) * 257);
    let grayf = gray.map_samples(|v| f32::from(v) - 100.5);
    let ga = Raster::from_planes(
        rgb.size(),
        vec![rgb.plane(0).to_vec(), rgb.plane(1).to_vec()],
    )
    .expect("gray alpha");
    let jpeg = small_jpeg(&rgb);
    let (u8i, u16i, f32i) = (
        AnyRaster::U8(rgb.clone()),
        AnyRaster::U16(gray16),
        AnyRaster::F32(grayf),
    );
    let img = |name: &str, bytes: Vec<u8>| seed(name, Kind::Image, bytes);
    let mut s = vec![
        img("aero1.jpg", aero.clone()),
        img(
            "aero1-xmp.jpg",
            with_app1(&aero, false, Some(DJI_XMP.as_bytes())),
        ),
        img("small.jpg", jpeg.clone()),
        img("dji.jpg", with_app1(&jpeg, true, Some(DJI_XMP.as_bytes()))),
        img("rgb8.png", written(dir, "a.png", &u8i, None)),
        img("gray16.png", written(dir, "b.png", &u16i, None)),
        img(
            "gray-alpha8.png",
            written(dir, "c.png", &AnyRaster::U8(ga.clone()), None),
        ),
        img("rgb8.tif", written(dir, "a.tif", &u8i, None)),
        img("gray16.tif", written(dir, "b.tif", &u16i, None)),
        img("grayf32.tif", written(dir, "c.tif", &f32i, None)),
        img(
            "gray-alpha8.tif",
            written(dir, "d.tif", &AnyRaster::U8(ga), None),
        ),
        img(
            "geo-epsg.tif",
            written(
                dir,
                "e.tif",
                &u8i,
                Some(&geo(Crs::from_epsg(32635).unwrap(), Some(0.0))),
            ),
        ),
        img(
            "dem-wkt.tif",
            written(
                dir,
                "f.tif",
                &f32i,
                Some(&geo(Crs::from_wkt(LO25_WKT).unwrap(), Some(-9999.0))),
            ),
        ),
        img(
            "geo-proj.tif",
            written(
                dir,
                "g.tif",
                &u16i,
                Some(&geo(Crs::from_proj_string(TMERC).unwrap(), None)),
            ),
        ),
        img(
            "exif-xmp.tif",
            tiff_with_tags(
                dir,
                "h.tif",
                &[(271, "DJI"), (272, "FC220"), (700, DJI_XMP)],
                true,
            ),
        ),
    ];
    let gdal = format!(
        "<GDALMetadata>\n<Item name=\"EXIF_FocalLength\">(4.73)</Item>\n<Item name=\"EXIF_Make\">DJI</Item>\n<Item name=\"EXIF_GPSLatitude\">(53) (54) (1.2)</Item>\n<Item name=\"EXIF_GPSLatitudeRef\">S</Item>\n<Item name=\"XMP\" domain=\"xml:XMP\">{}</Item>\n</GDALMetadata>\n",
        DJI_XMP
            .replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
            .replace('"', "&quot;")
    );
    s.push(img(
        "gdal-metadata.tif",
        tiff_with_tags(dir, "i.tif", &[(42112, &gdal)], false),
    ));
    let big = dir.join("big.tif");
    let mut enc = TiffEncoder::new_big(std::fs::File::create(&big).expect("create")).expect("big");
    let data: Vec<u16> = (0..5 * 4 * 3).map(|i| i * 1000).collect();
    enc.write_image::<colortype::RGB16>(5, 4, &data)
        .expect("bigtiff");
    drop(enc);
    s.push(img("bigtiff-rgb16.tif", std::fs::read(&big).expect("read")));
    for f in [
        "strips_deflate_gray32f",
        "strips_lzw_gray8",
        "tiled_deflate_rgba8",
        "tiled_lzw_rgb16",
    ] {
        let p = repo(&format!("data/fixtures/{f}.tif"));
        s.push(img(&format!("{f}.tif"), std::fs::read(p).expect("fixture")));
    }
    let ngi = repo("../shared/data/ngi/3324c_2015_1004_05_0182_RGB.tif");
    if let Ok(b) = std::fs::read(&ngi) {
        s.push(img("ngi-jpeg-ycbcr.tif", b));
    }
    s.extend(text_seeds());
    s
}

fn text_seeds() -> Vec<Seed> {
    let t = |name: &str, kind, text: &str| seed(name, kind, text.as_bytes().to_vec());
    let corners: String = std::fs::read_to_string(repo("data/calib/left_corners.csv"))
        .expect("left_corners.csv")
        .lines()
        .take(25)
        .map(|l| format!("{l}\n"))
        .collect();
    let poses = std::fs::read_to_string(repo("../shared/data/ngi/ngi_xyz_opk.csv")).unwrap_or_else(|_| {
        "filename,x,y,z,omega,phi,kappa\n3324c_2015_1004_05_0182_RGB,-55094.504,-3727407.037,5258.308,-0.349,0.298,-179.087\n3324c_2015_1004_05_0184_RGB,-57710.435,-3727433.893,5256.765,0.27,-0.282,-179.028\n".into()
    });
    let opencv_yml = std::fs::read_to_string(repo("data/calib/left_intrinsics.yml"))
        .expect("left_intrinsics.yml");
    vec![
        t("dji.xmp", Kind::Xmp, DJI_XMP),
        t(
            "physical.toml",
            Kind::CameraToml,
            "focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nprincipal_point_px = [320.5, 239.5]\nimage_size_px = [640, 480]\n[distortion]\nmodel = \"improved\"\nk1 = -0.15\nk2 = 0.03\np1 = 0.001\np2 = -0.0005\n",
        ),
        t(
            "pixels.toml",
            Kind::CameraToml,
            "fx_px = 1000.0\nfy_px = 1001.5\ncx_px = 319.5\ncy_px = 239.5\nskew_px = 0.1\nimage_size_px = [640, 480]\n[distortion]\nmodel = \"opencv\"\nk1 = -0.2\nk2 = 0.05\np1 = 0.001\np2 = 0.0\nk3 = 0.01\n",
        ),
        t(
            "brown.toml",
            Kind::CameraToml,
            "focal_length_mm = 35.0\npixel_pitch_um = [6.0, 6.0]\n[distortion]\nmodel = \"brown\"\nk1 = 0.01\n",
        ),
        t(
            "attitude.toml",
            Kind::AttitudeToml,
            "azimuth = 20.0\nelevation = 20.0\nimage_rotation = 2.0\npitch = 3.0\nroll = -2.0\nyaw = 15.0\n",
        ),
        t(
            "attitude-inline",
            Kind::AttitudeInline,
            "azimuth=20,elevation=20,image_rotation=2,pitch=3,roll=-2,yaw=15",
        ),
        t(
            "checkpoints.csv",
            Kind::Checkpoints,
            "u_oblique,v_oblique,u_standard,v_standard\n10.5,20.25,11.0,19.0\n300,200,310.125,190.5\n-5,1e3,0,0\n",
        ),
        t(
            "gcps.csv",
            Kind::Gcps,
            "u_image,v_image,u_ref,v_ref\n1,2,3,4\n100,5,103,9\n5,100,7,104\n100,100,104,103\n50,50,52,53\n",
        ),
        t("left_corners.csv", Kind::ControlPoints, &corners),
        t("poses.csv", Kind::Poses, &poses),
        t("wkt", Kind::Crs, LO25_WKT),
        t("proj", Kind::Crs, TMERC),
        t(
            "utm",
            Kind::Crs,
            "+proj=utm +zone=34 +south +ellps=GRS80 +units=m",
        ),
        t("epsg", Kind::Crs, "EPSG:32635"),
        t("opencv.yml", Kind::CameraFormat, &opencv_yml),
        t(
            "opencv.xml",
            Kind::CameraFormat,
            "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>640</image_width>\n<image_height>480</image_height>\n<camera_matrix type_id=\"opencv-matrix\">\n  <rows>3</rows>\n  <cols>3</cols>\n  <dt>d</dt>\n  <data>\n    536.07 0. 342.37 0. 536.01 235.53 0. 0. 1.</data></camera_matrix>\n<distortion_coefficients type_id=\"opencv-matrix\">\n  <rows>8</rows>\n  <cols>1</cols>\n  <dt>d</dt>\n  <data>\n    -0.265 -0.0467 1.8e-3 -3.1e-4 0.252 0.01 -0.02 0.005</data></distortion_coefficients>\n</opencv_storage>\n",
        ),
        t(
            "cameras.txt",
            Kind::CameraFormat,
            "# Camera list with one line of data per camera:\n1 FULL_OPENCV 640 480 536.07 536.01 342.87 236.03 -0.265 -0.0467 1.8e-3 -3.1e-4 0.252 0.01 -0.02 0.005\n",
        ),
        t(
            "cameras.json",
            Kind::CameraFormat,
            "{\"v2 dji fc6310 5472 3648 brown 0.6666\": {\"projection_type\": \"brown\", \"width\": 5472, \"height\": 3648, \"focal_x\": 0.6672, \"focal_y\": 0.6669, \"c_x\": 0.0012, \"c_y\": -0.0021, \"k1\": -0.0031, \"k2\": 0.0102, \"k3\": -0.0098, \"p1\": 0.0003, \"p2\": -0.0002}}",
        ),
        t(
            "metashape.xml",
            Kind::CameraFormat,
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<calibration>\n  <projection>frame</projection>\n  <width>5472</width>\n  <height>3648</height>\n  <f>3684.12</f>\n  <cx>-11.25</cx>\n  <cy>25.5</cy>\n  <b1>-1.5</b1>\n  <b2>0.75</b2>\n  <k1>-0.0059</k1>\n  <p1>-0.0021</p1>\n</calibration>\n",
        ),
        t(
            "dewarp.txt",
            Kind::CameraFormat,
            "2018-09-04;3678.9,3671.5,10.5,-17.2,-0.26,0.11,0.001,-0.0003,-0.23",
        ),
        t("bomb.yaml", Kind::HostileCamera, &alias_bomb("")),
        t(
            "bomb.yml",
            Kind::HostileCamera,
            &alias_bomb("%YAML:1.0\n---\n"),
        ),
        t("deep.yaml", Kind::HostileCamera, &deep_yaml(200)),
        t("deep.json", Kind::HostileCamera, &"[".repeat(100_000)),
        t(
            "deep.xml",
            Kind::HostileCamera,
            &"<opencv_storage>".repeat(100_000),
        ),
        t("huge.toml", Kind::HostileCamera, &over_the_text_cap()),
        t(
            "orthority.yaml",
            Kind::CameraFormat,
            "cam:\n  type: opencv\n  im_size: [640, 1152]\n  focal_len: [120.0, 120.5]\n  sensor_size: [92.16, 165.888]\n  cx: 0.001\n  cy: -0.002\n  k1: -0.1\n  s1: 0.001\n",
        ),
    ]
}

/// A YAML "billion laughs": nine anchors, each a list of ten aliases of the one before (10^9
/// scalars expanded, 300 bytes written), after `prefix` (OpenCV's directive, or nothing).
fn alias_bomb(prefix: &str) -> String {
    let mut s = format!("{prefix}a0: &a0 [lol]\n");
    for i in 1..=9 {
        let refs = vec![format!("*a{}", i - 1); 10].join(",");
        s += &format!("a{i}: &a{i} [{refs}]\n");
    }
    s
}

/// Block mappings `depth` deep, under an Orthority-looking camera name.
fn deep_yaml(depth: usize) -> String {
    (0..depth)
        .map(|i| format!("{}cam{i}:\n", " ".repeat(i)))
        .collect::<String>()
        + &" ".repeat(depth)
        + "k1\n"
}

/// A valid camera TOML padded by a comment to one byte over the 16 MiB text cap.
fn over_the_text_cap() -> String {
    let head = "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n#";
    let cap = aerorect_io::MAX_TEXT_BYTES as usize;
    head.to_string() + &"x".repeat(cap + 1 - head.len())
}
