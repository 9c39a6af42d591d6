//! Finite-difference checks of NeuS volume rendering, sampling properties, and rendering spheres.

use glam::Vec3;
use neuroom_field::rng::SplitMix;
use neuroom_field::{
    AnalyticColor, AnalyticField, CodeSet, Field, FieldOutput, NeusConfig, NeusField, Query,
};
use neuroom_render::sampling::{depth_guided, importance, merge_by_t, stratified, uniform};
use neuroom_render::volume::{RayOutput, RayTape, render_ray, render_ray_backward};

const EPS: f64 = 1e-6;

fn assert_close(what: &str, analytic: f64, numeric: f64) {
    let tol = 1e-7 + 1e-5 * numeric.abs().max(analytic.abs());
    assert!(
        (analytic - numeric).abs() <= tol,
        "{what}: analytic {analytic:e} vs finite difference {numeric:e}"
    );
}

/// A ray crossing a surface: SDF decreasing through zero, with a second dip, never exactly flat.
fn ray_case() -> (Vec<f64>, Vec<f64>, Vec<[f64; 3]>) {
    let n = 12;
    let t: Vec<f64> = (0..n)
        .map(|i| 1.0 + 0.1 * i as f64 + 0.01 * (i * i) as f64)
        .collect();
    let sdf = t
        .iter()
        .map(|x| 0.45 - 0.3 * x + 0.05 * (3.0 * x).sin())
        .collect();
    let rgb = (0..n)
        .map(|i| [0.2 + 0.05 * i as f64, 0.9 - 0.03 * i as f64, 0.5])
        .collect();
    (t, sdf, rgb)
}

fn loss(out: &RayOutput<f64>) -> f64 {
    0.3 * out.rgb[0] - 0.7 * out.rgb[1] + 0.2 * out.rgb[2] + 0.4 * out.depth - 0.9 * out.opacity
}

#[test]
fn volume_rendering_gradients_to_sdf_colour_and_sharpness() {
    let (t, mut sdf, mut rgb) = ray_case();
    let mut inv_s = 7.0;
    let mut tape = RayTape::default();
    let out = render_ray(&t, &sdf, &rgb, inv_s, &mut tape);
    assert!(out.opacity > 0.5 && out.opacity <= 1.0);
    let d_out = RayOutput {
        rgb: [0.3, -0.7, 0.2],
        depth: 0.4,
        opacity: -0.9,
    };
    let mut d_sdf = vec![0.0; t.len()];
    let mut d_rgb = vec![[0.0; 3]; t.len()];
    let d_s = render_ray_backward(&sdf, inv_s, &mut tape, &d_out, &mut d_sdf, &mut d_rgb);
    let eval = |sdf: &[f64], rgb: &[[f64; 3]], s: f64| {
        loss(&render_ray(&t, sdf, rgb, s, &mut RayTape::default()))
    };
    for i in 0..t.len() {
        let v = sdf[i];
        sdf[i] = v + EPS;
        let lp = eval(&sdf, &rgb, inv_s);
        sdf[i] = v - EPS;
        let lm = eval(&sdf, &rgb, inv_s);
        sdf[i] = v;
        assert_close(&format!("sdf[{i}]"), d_sdf[i], (lp - lm) / (2.0 * EPS));
        for c in 0..3 {
            let v = rgb[i][c];
            rgb[i][c] = v + EPS;
            let lp = eval(&sdf, &rgb, inv_s);
            rgb[i][c] = v - EPS;
            let lm = eval(&sdf, &rgb, inv_s);
            rgb[i][c] = v;
            assert_close(
                &format!("rgb[{i}][{c}]"),
                d_rgb[i][c],
                (lp - lm) / (2.0 * EPS),
            );
        }
    }
    let numeric = (eval(&sdf, &rgb, inv_s + EPS) - eval(&sdf, &rgb, inv_s - EPS)) / (2.0 * EPS);
    assert_close("inv_s", d_s, numeric);
    inv_s = 1e4;
    let sharp = render_ray(&t, &sdf, &rgb, inv_s, &mut tape);
    assert!(
        sharp.opacity.is_finite() && (sharp.opacity - 1.0).abs() < 1e-6,
        "a sharp surface is opaque"
    );
}

fn lcg(seed: u64) -> impl FnMut() -> f32 {
    let mut rng = SplitMix::new(seed);
    move || rng.next_f64() as f32
}

#[test]
fn samplers_are_sorted_and_in_range() {
    let mut rng = lcg(1);
    let mut out = Vec::new();
    uniform(0.5, 2.5, 5, &mut out);
    assert_eq!(out, vec![0.5, 1.0, 1.5, 2.0, 2.5]);
    stratified(1.0, 3.0, 16, &mut rng, &mut out);
    assert!(out.windows(2).all(|w| w[0] <= w[1]) && out[0] >= 1.0 && out[15] <= 3.0);
    depth_guided(0.1, 5.0, 2.0, 0.05, 32, 16, &mut rng, &mut out);
    assert_eq!(out.len(), 48);
    assert!(out.windows(2).all(|w| w[0] <= w[1]));
    assert!(out.iter().filter(|t| (**t - 2.0).abs() <= 0.05).count() >= 32);
    let t: Vec<f32> = (0..=10).map(|i| i as f32).collect();
    let mut w = vec![0.0; 10];
    w[6] = 1.0;
    importance(&t, &w, 64, &mut rng, &mut out);
    assert!(out.windows(2).all(|w| w[0] <= w[1]));
    assert!(out.iter().filter(|x| (6.0..=7.0).contains(*x)).count() >= 60);
    let mut merged = Vec::new();
    merge_by_t(&[&[0.0, 2.0], &[1.0, 3.0]], &mut merged);
    assert_eq!(
        merged,
        vec![(0.0, 0, 0), (1.0, 1, 0), (2.0, 0, 1), (3.0, 1, 1)]
    );
}

/// Renders rays along +x at height offsets through `field`, returning (depth / opacity, opacity) per ray.
fn render_rays<F: Field>(field: &F, offsets: &[f32], inv_s: f32) -> Vec<(f32, f32)> {
    let mut ts = Vec::new();
    uniform(0.5, 3.5, 256, &mut ts);
    offsets
        .iter()
        .map(|&o| {
            let origin = Vec3::new(-2.0, o, 0.5 * o);
            let points: Vec<Vec3> = ts.iter().map(|t| origin + Vec3::X * *t).collect();
            let dirs = vec![Vec3::X; points.len()];
            let mut out = FieldOutput::default();
            field.forward(
                &Query {
                    points: &points,
                    dirs: &dirs,
                    codes: CodeSet::default(),
                },
                &mut Default::default(),
                &mut out,
            );
            let rgb: Vec<[f32; 3]> = out.rgb.iter().map(|c| c.to_array()).collect();
            let r = render_ray(&ts, &out.sdf, &rgb, inv_s, &mut RayTape::default());
            (r.depth / r.opacity.max(1e-6), r.opacity)
        })
        .collect()
}

#[test]
fn rendered_depth_of_analytic_sphere_matches_intersection() {
    let r = 0.6;
    let sphere = AnalyticField::Sphere {
        centre: Vec3::ZERO,
        radius: r,
        color: AnalyticColor::Constant(Vec3::ONE),
    };
    let offsets = [0.0, 0.1, 0.2, 0.3];
    for (o, (depth, opacity)) in offsets.iter().zip(render_rays(&sphere, &offsets, 400.0)) {
        let d2 = o * o * 1.25;
        let expected = 2.0 - (r * r - d2).sqrt();
        assert!(opacity > 0.999, "opacity {opacity}");
        assert!(
            (depth - expected).abs() < 3e-3,
            "offset {o}: depth {depth} vs {expected}"
        );
    }
}

#[test]
fn rendered_depth_of_initial_neus_field_is_its_sphere() {
    let field = NeusField::<f32>::new(NeusConfig::object([0.5, 0.5, 0.5]));
    let r = field.config().init.radius;
    let offsets = [0.0, 0.1, 0.2];
    for (o, (depth, opacity)) in offsets.iter().zip(render_rays(&field, &offsets, 400.0)) {
        let expected = 2.0 - (r * r - o * o * 1.25).sqrt();
        assert!(opacity > 0.99, "opacity {opacity}");
        assert!(
            (depth - expected).abs() < 1e-2,
            "offset {o}: depth {depth} vs {expected}"
        );
    }
}
