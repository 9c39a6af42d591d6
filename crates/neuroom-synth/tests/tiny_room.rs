//! End-to-end checks of generated rooms on the `tiny` preset: every file reads back through
//! neuroom-core, depth is consistent across views, panorama ground truth agrees with itself, the
//! arrangements obey room logic, and the output is byte-identical for a seed.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};
use neuroom_core::camera::{CameraModel, Equirect};
use neuroom_core::formats::{
    read_arrangement, read_capture, read_depth, read_mask, read_rgb, read_rgba, read_room,
};
use neuroom_core::obb::OrientedBox;
use neuroom_synth::{Preset, generate};

fn make(dir: &Path, seed: u64) {
    let preset = Preset::named("tiny").unwrap();
    generate(&preset, dir, seed, None, &[], &mut |_| {}).unwrap();
}

fn files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                );
            }
        }
    }
    out
}

#[test]
fn same_seed_gives_identical_bytes_for_any_thread_count() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    make(a.path(), 7);
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| make(b.path(), 7));
    let (fa, fb) = (files(a.path()), files(b.path()));
    assert_eq!(fa.keys().collect::<Vec<_>>(), fb.keys().collect::<Vec<_>>());
    for (k, v) in &fa {
        assert!(v == &fb[k], "{} differs", k.display());
    }
    let c = tempfile::tempdir().unwrap();
    make(c.path(), 8);
    assert_ne!(
        files(c.path())[Path::new("panoramas/tiny_a0_l0.png")],
        fa[Path::new("panoramas/tiny_a0_l0.png")]
    );
}

/// One generated room shared by the read-only tests below.
fn room() -> &'static Path {
    static ROOM: std::sync::OnceLock<tempfile::TempDir> = std::sync::OnceLock::new();
    ROOM.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        make(d.path(), 3);
        d
    })
    .path()
}

#[test]
fn everything_reads_back_through_core() {
    let dir = room();
    let room = read_room(dir).unwrap();
    assert_eq!(room.objects.len(), 2);
    assert_eq!(room.objects[1].relations, vec!["on:cabinet".to_string()]);
    let bg = read_capture(dir.join(&room.background.capture)).unwrap();
    assert!(bg.extra.contains_key("lighting"));
    for f in &bg.frames {
        let mask = read_mask(bg.resolve(f.instance.as_ref().unwrap())).unwrap();
        assert!(
            mask.data.iter().all(|&m| m == 0),
            "background masks must be empty"
        );
        read_rgb(bg.resolve(&f.image)).unwrap();
    }
    for o in &room.objects {
        let cap = read_capture(dir.join(&o.capture)).unwrap();
        let f = &cap.frames[0];
        let rgba = read_rgba(cap.resolve(&f.image)).unwrap().image;
        let mask = read_mask(cap.resolve(f.instance.as_ref().unwrap())).unwrap();
        let depth = read_depth(
            cap.resolve(f.depth.as_ref().unwrap()),
            cap.depth_unit_scale_factor,
        )
        .unwrap();
        assert!(mask.data.contains(&o.id) && mask.data.iter().all(|&m| m == 0 || m == o.id));
        let mut alpha_mismatch = 0;
        for ((px, m), d) in rgba.data.iter().zip(&mask.data).zip(&depth.data) {
            assert_eq!(*m == 0, *d == 0.0, "mask and depth disagree");
            alpha_mismatch += usize::from((*m == 0) != (px[3] == 0.0));
        }
        // Alpha is anti-aliased coverage; it differs from the centre-sampled mask only on silhouettes.
        assert!(
            alpha_mismatch * 20 < mask.data.len(),
            "{alpha_mismatch} alpha/mask mismatches"
        );
        assert!(rgba.data.iter().any(|p| p[3] == 0.0) && rgba.data.iter().any(|p| p[3] == 1.0));
        assert!(dir.join("meshes").join(format!("{}.ply", o.name)).is_file());
    }
    for a in 0..2 {
        for l in 0..2 {
            let arr = read_arrangement(dir.join(format!("panoramas/tiny_a{a}_l{l}.json"))).unwrap();
            assert_eq!(arr.image, format!("tiny_a{a}_l{l}.png"));
            assert!(arr.lighting.get("lights").is_some());
        }
    }
}

#[test]
fn capture_depth_is_consistent_across_views() {
    let dir = room();
    let room = read_room(dir).unwrap();
    for capture in [
        room.background.capture.clone(),
        room.objects[0].capture.clone(),
    ] {
        let cap = read_capture(dir.join(&capture)).unwrap();
        let depths: Vec<_> = cap
            .frames
            .iter()
            .map(|f| {
                read_depth(
                    cap.resolve(f.depth.as_ref().unwrap()),
                    cap.depth_unit_scale_factor,
                )
                .unwrap()
            })
            .collect();
        let (mut agree, mut in_front, mut compared) = (0, 0, 0);
        for (i, fi) in cap.frames.iter().enumerate() {
            for (j, fj) in cap.frames.iter().enumerate().filter(|(j, _)| *j != i) {
                let to_j = fj.camera_to_world.inverse();
                for v in 0..fi.camera.height {
                    for u in 0..fi.camera.width {
                        let d = depths[i].get(u, v);
                        if *d == 0.0 {
                            continue;
                        }
                        let p_cam = fi
                            .camera
                            .unproject(DVec2::new(u as f64 + 0.5, v as f64 + 0.5), *d as f64);
                        let world = fi.camera_to_world.transform_point(p_cam);
                        let Some((px, zj)) = fj.camera.project(to_j.transform_point(world)) else {
                            continue;
                        };
                        if !fj.camera.in_image(px) {
                            continue;
                        }
                        // The 3×3 neighbourhood bounds what view j sees around the projection,
                        // which absorbs depth edges and grazing surfaces at this small size.
                        let Some((lo, hi)) = neighbourhood(&depths[j], px.x as u32, px.y as u32)
                        else {
                            continue;
                        };
                        compared += 1;
                        // Occluded points lie behind what view j sees; visible ones match.
                        let tol = 0.005 + 0.005 * zj;
                        if zj > lo - tol && zj < hi + tol {
                            agree += 1;
                        } else if zj < lo - tol {
                            in_front += 1;
                        }
                    }
                }
            }
        }
        assert!(compared > 1000, "{compared}");
        // Views all around an object see its other sides, so fewer points are shared than in the room.
        assert!(
            agree as f64 > 0.2 * compared as f64,
            "{}: {agree} of {compared} agree",
            capture.display()
        );
        assert!(
            (in_front as f64) < 0.01 * compared as f64,
            "{}: {in_front} of {compared} in front",
            capture.display()
        );
    }
}

/// Smallest and largest non-zero depth in the 3×3 block around (u, v).
fn neighbourhood(depth: &neuroom_core::image::DepthImage, u: u32, v: u32) -> Option<(f64, f64)> {
    let mut range: Option<(f64, f64)> = None;
    for y in v.saturating_sub(1)..(v + 2).min(depth.height) {
        for x in u.saturating_sub(1)..(u + 2).min(depth.width) {
            let d = *depth.get(x, y) as f64;
            if d > 0.0 {
                range = Some(range.map_or((d, d), |(a, b)| (a.min(d), b.max(d))));
            }
        }
    }
    range
}

#[test]
fn panorama_points_of_instance_k_lie_in_box_k() {
    let dir = room();
    let room = read_room(dir).unwrap();
    for a in 0..2 {
        let stem = format!("panoramas/tiny_a{a}_l0");
        let arr = read_arrangement(dir.join(format!("{stem}.json"))).unwrap();
        let depth = read_depth(dir.join(format!("{stem}.depth.png")), 0.001).unwrap();
        let mask = read_mask(dir.join(format!("{stem}.mask.png"))).unwrap();
        let cam = Equirect::new(depth.width, depth.height).unwrap();
        let boxes: Vec<(u16, OrientedBox)> = arr
            .objects
            .iter()
            .map(|o| {
                (
                    o.id,
                    OrientedBox::new(o.object_to_world, room.object_by_id(o.id).unwrap().size),
                )
            })
            .collect();
        let mut seen = 0;
        for v in 0..depth.height {
            for u in 0..depth.width {
                let (k, d) = (*mask.get(u, v), *depth.get(u, v) as f64);
                assert!(d > 0.0, "closed rooms have depth everywhere");
                if k == 0 {
                    continue;
                }
                let world = arr
                    .camera_to_world
                    .transform_point(cam.unproject(DVec2::new(u as f64 + 0.5, v as f64 + 0.5), d));
                let (_, b) = boxes
                    .iter()
                    .find(|(id, _)| *id == k)
                    .expect("mask ids are arranged objects");
                assert!(
                    b.contains(world, 0.01),
                    "pixel ({u}, {v}) of {k} lies outside its box"
                );
                seen += 1;
            }
        }
        assert!(
            seen > 0 || arr.objects.len() < 2,
            "no object visible in arrangement {a}"
        );
    }
}

#[test]
fn arrangements_follow_room_logic() {
    let dir = room();
    let room = read_room(dir).unwrap();
    let size = DVec3::from_array(
        serde_json::from_value::<[f64; 3]>(room.extra["room_box"]["max"].clone()).unwrap(),
    );
    let mut omitted = false;
    for a in 0..2 {
        let arr = read_arrangement(dir.join(format!("panoramas/tiny_a{a}_l0.json"))).unwrap();
        omitted |= arr.objects.len() < room.objects.len();
        let boxes: Vec<_> = arr
            .objects
            .iter()
            .map(|o| {
                (
                    o,
                    OrientedBox::new(o.object_to_world, room.object_by_id(o.id).unwrap().size),
                )
            })
            .collect();
        for (o, b) in &boxes {
            let r = room.object_by_name(&o.name).unwrap();
            assert!(
                b.corners()
                    .iter()
                    .all(|c| c.cmpge(DVec3::splat(-1e-9)).all() && c.cmple(size + 1e-9).all()),
                "{} leaves the room",
                o.name
            );
            let bottom = o.object_to_world.translation.z - r.size.z / 2.0;
            match r.relations.first().map(String::as_str) {
                Some("floor") => assert!(bottom.abs() < 1e-9, "{} floats", o.name),
                Some(rel) if rel.starts_with("on:") => {
                    let (s, sb) = boxes.iter().find(|(x, _)| x.name == rel[3..]).unwrap();
                    let top = s.object_to_world.translation.z
                        + room.object_by_name(&s.name).unwrap().size.z / 2.0;
                    assert!(
                        (bottom - top).abs() < 1e-9,
                        "{} does not rest on {}",
                        o.name,
                        s.name
                    );
                    let foot = o.object_to_world.translation - DVec3::Z * (r.size.z / 2.0 - 1e-3);
                    assert!(
                        sb.contains(foot - DVec3::Z * 2e-3, 1e-6),
                        "{} overhangs {}",
                        o.name,
                        s.name
                    );
                }
                _ => {}
            }
            let cam = arr.camera_to_world.translation;
            assert!(!b.contains(cam, 0.3), "camera inside or next to {}", o.name);
            assert!((1.2..=1.6).contains(&cam.z));
        }
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                assert!(
                    boxes[i].1.intersection_volume(&boxes[j].1) < 1e-9,
                    "{} and {} overlap",
                    boxes[i].0.name,
                    boxes[j].0.name
                );
            }
        }
    }
    assert!(omitted, "the last arrangement leaves an object out");
}

#[test]
fn bench_reports_throughput() {
    let r =
        neuroom_synth::bench_panorama(64, neuroom_synth::render::Quality { spp: 1, ao_rays: 1 }, 1)
            .unwrap();
    assert_eq!(r.samples, 64 * 32);
    assert!(r.rays >= r.samples * 2 && r.samples_per_second > 0.0 && r.triangles > 100);
}

#[test]
fn every_preset_arranges_for_many_seeds() {
    use neuroom_synth::sampler::{Item, RoomSpace, YawBox};
    use rand::SeedableRng;
    for name in neuroom_synth::PRESET_NAMES {
        let preset = Preset::named(name).unwrap();
        for seed in 0..12u64 {
            let shell =
                neuroom_synth::shell::build_shell(DVec3::from_array(preset.room_size), seed);
            let models: Vec<_> = preset
                .models
                .iter()
                .map(|m| m.kind.build(&m.name, seed))
                .collect();
            let items: Vec<Item> = preset
                .objects
                .iter()
                .map(|o| Item {
                    furniture: &models[preset
                        .models
                        .iter()
                        .position(|m| m.name == o.model)
                        .unwrap()],
                    support: o
                        .on
                        .as_ref()
                        .and_then(|s| preset.objects.iter().position(|x| &x.name == s)),
                })
                .collect();
            let space = RoomSpace {
                size: shell.size,
                keep_out: &shell.keep_out,
            };
            let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
            let placed = space
                .arrange(&items, &[], &mut rng)
                .unwrap_or_else(|e| panic!("{name} seed {seed}: {e}"));
            let boxes: Vec<YawBox> = placed
                .iter()
                .map(|p| YawBox::of(&p.pose, items[p.index].furniture.size))
                .collect();
            assert!(
                space.camera(&boxes, 0.35, &mut rng).is_some(),
                "{name} seed {seed}: no camera spot"
            );
        }
    }
}
