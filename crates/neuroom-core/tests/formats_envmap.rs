//! Environment maps: the vendored DWAB-compressed HDRIs decode to sane values, `.exr.js` modules decode to
//! the same map as their EXR, Radiance `.hdr` reads in the documented orientation.

use glam::{DVec2, Vec3};
use neuroom_core::formats::{EnvMap, read_envmap};
use std::path::PathBuf;

fn hdri(name: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/hdri")).join(name)
}

#[test]
fn vendored_hdris_decode_to_sane_radiance() {
    for name in ["apartment.exr", "studio.exr", "lobby.exr"] {
        let map = read_envmap(hdri(name)).unwrap();
        assert_eq!((map.width, map.height), (512, 256), "{name}");
        assert!(
            map.data
                .iter()
                .flatten()
                .all(|c| c.is_finite() && *c >= 0.0)
        );
        let mean = map.pixel_mean();
        assert!(
            mean.iter().all(|&m| m > 0.05 && m < 50.0),
            "{name}: mean {mean:?}"
        );
        // Bilinear sampling at a pixel centre returns that pixel.
        let d = map.direction(DVec2::new(100.5, 60.5)).as_vec3();
        let s = map.sample(d);
        let p = map.data[60 * 512 + 100];
        assert!(
            (0..3).all(|k| (s[k] - p[k]).abs() <= 1e-4 * p[k].max(1.0)),
            "{s:?} vs {p:?}"
        );
    }
}

/// Standard base64 with padding (test-only helper to build an `.exr.js` module).
fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |a, (i, &b)| a | (b as u32) << (16 - 8 * i));
        for i in 0..4 {
            let c = if i <= chunk.len() {
                ABC[(n >> (18 - 6 * i)) as usize & 63] as char
            } else {
                '='
            };
            out.push(c);
        }
    }
    out
}

#[test]
fn exr_js_module_decodes_like_its_exr() {
    let exr = std::fs::read(hdri("apartment.exr")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let js = dir.path().join("apartment.exr.js");
    let module = format!(
        "export default 'data:application/exr;base64,{}'\n",
        base64(&exr)
    );
    std::fs::write(&js, module).unwrap();
    assert_eq!(
        read_envmap(&js).unwrap(),
        read_envmap(hdri("apartment.exr")).unwrap()
    );
}

#[test]
fn radiance_hdr_reads_row_zero_as_the_zenith() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ramp.hdr");
    let (w, h) = (16usize, 8usize);
    // Brightness grows down the rows; red marks the centre columns (+x).
    let pixels: Vec<image::Rgb<f32>> = (0..h)
        .flat_map(|v| {
            (0..w).map(move |u| {
                image::Rgb([
                    if u == 7 || u == 8 { 4.0 } else { 0.0 },
                    v as f32 + 1.0,
                    0.5,
                ])
            })
        })
        .collect();
    let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    image::codecs::hdr::HdrEncoder::new(file)
        .encode(&pixels, w, h)
        .unwrap();
    let map = read_envmap(&path).unwrap();
    assert_eq!((map.width, map.height), (16, 8));
    let up = map.sample(Vec3::Z);
    let down = map.sample(-Vec3::Z);
    assert!(
        (up[1] - 1.0).abs() < 0.02 && (down[1] - 8.0).abs() < 0.1,
        "{up:?} {down:?}"
    );
    assert!(map.sample(Vec3::X)[0] > 3.9 && map.sample(-Vec3::X)[0] == 0.0);
    assert!(EnvMap::new(16, 8, map.data.clone()).is_ok());
}
