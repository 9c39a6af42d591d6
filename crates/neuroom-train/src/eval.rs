//! Evaluation of a learned model on held-out views and against a ground-truth mesh.
//!
//! Held-out views are rendered without their depth: surface-guided sampling finds the first zero crossing
//! of the SDF along the ray from a coarse SDF-only pass, then renders a thin shell around it with NeuS
//! volume rendering (rays without a crossing render nothing: opacity 0). Figures:
//! - PSNR (sRGB, over black) on the model's pixels: the object's pixels, or every valid background pixel;
//!   and the same with each view's exposure and white balance matched, for models of auto-exposed frames;
//! - median absolute error of the rendered distance (`depth / opacity`) where the depth is known;
//! - Chamfer distance between the extracted mesh ([`neuroom_core::surface`]) and the ground truth;
//! - the light-code check: held-out views re-lit by an augmentation map, rendered with that map's code and
//!   with code 0, PSNR of each against the re-lit images.

use crate::augment::Augmentation;
use crate::dataset::{Aabb, FrameView, PixelClass};
use glam::Vec3;
use neuroom_core::mesh::TriMesh;
use neuroom_core::stats::upper_median_by;
use neuroom_core::surface::{Grid, extract_surface};
use neuroom_field::{CodeSet, Codes, NeusField, Outputs, Tape};
use neuroom_render::sampling::{Crossing, uniform};
use neuroom_render::volume::{RayTape, render_ray};
use serde::{Deserialize, Serialize};

/// Sampling of the evaluation renderer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderOptions {
    /// SDF-only samples per ray to find the surface.
    pub coarse: usize,
    /// Samples in the shell around it.
    pub fine: usize,
    /// Smallest shell half-width (metres); it is `5 / (inv_s · slope)` otherwise, with the SDF's slope
    /// along the ray at the crossing (grazing rays get wider shells).
    pub min_shell: f32,
    /// Largest shell half-width (metres).
    pub max_shell: f32,
    /// Nearest distance from the camera considered.
    pub near: f32,
}

impl RenderOptions {
    /// Defaults for a box of diagonal `diag`: 96 coarse samples, 32 fine, shell 0.5 % to 10 % of it.
    pub fn for_diagonal(diag: f32) -> Self {
        Self {
            coarse: 96,
            fine: 32,
            min_shell: 0.005 * diag,
            max_shell: 0.1 * diag,
            near: 0.02,
        }
    }
}

/// A rendered view.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rendered {
    /// Colour over black.
    pub rgb: Vec<[f32; 3]>,
    /// Expected distance along the ray (`depth / opacity`; 0 where nothing was hit).
    pub distance: Vec<f32>,
    /// Opacity.
    pub opacity: Vec<f32>,
}

/// Rays rendered per batch.
const RAYS_PER_BATCH: usize = 4096;

/// Where the rays of a view's selected pixels first meet the model's surface, batch by batch. The
/// geometry does not depend on the light code, so one search serves renders under every code.
#[derive(Clone, Debug, Default)]
pub struct ViewSurfaces {
    batches: Vec<Vec<Hit>>,
}

/// The surfaces the pixels of `view` that `wanted` selects see, from `field` inside `bounds`.
pub fn view_surfaces(
    field: &NeusField<f32>,
    view: &FrameView,
    bounds: &Aabb,
    options: &RenderOptions,
    wanted: &dyn Fn(usize) -> bool,
) -> ViewSurfaces {
    let n = view.rgb.len();
    let mut tape = Tape::default();
    let batches = (0..n)
        .step_by(RAYS_PER_BATCH)
        .map(|start| {
            let end = (start + RAYS_PER_BATCH).min(n);
            let rays: Vec<(usize, Vec3, f32, f32)> = (start..end)
                .filter(|&i| wanted(i))
                .filter_map(|i| {
                    let d = view.direction(i);
                    let (near, far) = bounds.intersect(view.origin(), d)?;
                    let near = near.max(options.near);
                    (far > near).then_some((i, d, near, far))
                })
                .collect();
            find_surfaces(
                field,
                view.origin(),
                &rays,
                options,
                &mut tape,
                SEARCH_ROUND,
            )
        })
        .collect();
    ViewSurfaces { batches }
}

/// Renders `view` where `surfaces` found the model (other pixels black), once per light code of
/// `lights`: the geometry is computed once, the colour once per code.
pub fn shade_view(
    field: &NeusField<f32>,
    view: &FrameView,
    surfaces: &ViewSurfaces,
    lights: &[u32],
    options: &RenderOptions,
) -> Vec<Rendered> {
    let n = view.rgb.len();
    let blank = Rendered {
        rgb: vec![[0.0; 3]; n],
        distance: vec![0.0; n],
        opacity: vec![0.0; n],
    };
    let mut out = vec![blank; lights.len()];
    let mut tape = Tape::default();
    for hits in &surfaces.batches {
        shade(
            field,
            view.origin(),
            hits,
            lights,
            options,
            &mut tape,
            &mut out,
        );
    }
    out
}

/// Where a ray first crosses the zero level set.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Hit {
    pixel: usize,
    dir: Vec3,
    t: f32,
    /// `−∂SDF/∂t` at the crossing, from the coarse samples.
    slope: f32,
}

/// First zero crossing of the SDF along each ray, from `options.coarse` SDF samples.
///
/// The samples are taken front to back in rounds of `round` ([`SEARCH_ROUND`] outside tests); a ray
/// leaves the search at the round where it crosses. The SDF of a point does not depend on the batch
/// it is computed in, so the crossings are those of all samples taken at once, for a fraction of the
/// samples: most rays meet the model well before the far side of its box.
fn find_surfaces(
    field: &NeusField<f32>,
    o: Vec3,
    rays: &[(usize, Vec3, f32, f32)],
    options: &RenderOptions,
    tape: &mut Tape<f32>,
    round: usize,
) -> Vec<Hit> {
    let k = options.coarse.max(2);
    let mut searches: Vec<RaySearch> = rays.iter().map(|&ray| RaySearch::new(ray, k)).collect();
    let mut hits: Vec<Option<Hit>> = vec![None; rays.len()];
    let mut active: Vec<usize> = (0..rays.len()).collect();
    let mut points = Vec::new();
    let mut sdf = Vec::new();
    let mut first = 0;
    while first < k && !active.is_empty() {
        let last = (first + round.max(1)).min(k);
        points.clear();
        for &r in &active {
            let s = &searches[r];
            points.extend(
                s.ts[first..last]
                    .iter()
                    .map(|t| (o + *t * s.dir).to_array()),
            );
        }
        field.forward(&points, &[], &CodeSet::default(), Outputs::Sdf, tape);
        sdf.resize(points.len(), 0.0);
        tape.copy_sdf(&mut sdf);
        let width = last - first;
        let mut left = Vec::with_capacity(active.len());
        for (a, &r) in active.iter().enumerate() {
            match searches[r].extend(&sdf[a * width..(a + 1) * width]) {
                Some(hit) => hits[r] = Some(hit),
                None => left.push(r),
            }
        }
        active = left;
        first = last;
    }
    hits.into_iter().flatten().collect()
}

/// SDF samples of the surface search per ray and round.
const SEARCH_ROUND: usize = 24;

/// One ray's surface search: its sample distances and the SDF taken so far.
struct RaySearch {
    pixel: usize,
    dir: Vec3,
    near: f32,
    /// Distance between samples.
    step: f32,
    ts: Vec<f32>,
    sdf: Vec<f32>,
}

impl RaySearch {
    /// The search along `(pixel, direction, near, far)` with `k` samples.
    fn new((pixel, dir, near, far): (usize, Vec3, f32, f32), k: usize) -> Self {
        let mut ts = Vec::with_capacity(k);
        uniform(near, far, k, &mut ts);
        Self {
            pixel,
            dir,
            near,
            step: (far - near) / (k - 1) as f32,
            ts,
            sdf: Vec::with_capacity(k),
        }
    }

    /// Adds the SDF of the next samples; returns the hit when the first crossing from outside to
    /// inside is among them (or between the last one before them and the first).
    fn extend(&mut self, values: &[f32]) -> Option<Hit> {
        let from = self.sdf.len().saturating_sub(1);
        self.sdf.extend_from_slice(values);
        let s = &self.sdf;
        let crossing = Crossing::first(&s[from..])?;
        let j = from + crossing.before;
        Some(Hit {
            pixel: self.pixel,
            dir: self.dir,
            t: self.near + self.step * (j as f32 + crossing.fraction),
            slope: (s[j] - s[j + 1]) / self.step,
        })
    }
}

/// Volume-renders a shell around each found surface into `out[k]` under light code `lights[k]`.
fn shade(
    field: &NeusField<f32>,
    o: Vec3,
    hits: &[Hit],
    lights: &[u32],
    options: &RenderOptions,
    tape: &mut Tape<f32>,
    out: &mut [Rendered],
) {
    let k = options.fine.max(2);
    let inv_s = field.inv_s();
    let (mut points, mut dirs, mut all_t) = (Vec::new(), Vec::new(), Vec::new());
    let mut ts = Vec::new();
    for &Hit {
        dir: d, t, slope, ..
    } in hits
    {
        let w = (5.0 / (inv_s * slope.max(0.05))).clamp(options.min_shell, options.max_shell);
        uniform((t - w).max(options.near), t + w, k, &mut ts);
        all_t.extend_from_slice(&ts);
        points.extend(ts.iter().map(|t| (o + *t * d).to_array()));
        dirs.extend(std::iter::repeat_n(d.to_array(), k));
    }
    let codes = |light: u32| CodeSet {
        light: Codes::Fixed(light),
        ..CodeSet::default()
    };
    let mut sdf = vec![0.0; points.len()];
    let mut rgb = vec![0.0; 3 * points.len()];
    for (c, (&light, out)) in lights.iter().zip(out.iter_mut()).enumerate() {
        if c == 0 {
            field.forward(&points, &dirs, &codes(light), Outputs::Full, tape);
            tape.copy_sdf(&mut sdf);
        } else {
            field.recolor(&dirs, &codes(light), tape);
        }
        tape.copy_rgb(&mut rgb);
        let samples = ShellSamples {
            t: &all_t,
            sdf: &sdf,
            rgb: rgb.as_chunks::<3>().0,
            per_ray: k,
        };
        render_shells(hits, &samples, inv_s, out);
    }
}

/// The shell samples of a batch of rays, `per_ray` consecutive samples a ray.
struct ShellSamples<'a> {
    t: &'a [f32],
    sdf: &'a [f32],
    rgb: &'a [[f32; 3]],
    per_ray: usize,
}

/// NeuS volume rendering of each hit's shell into its pixel of `out`.
fn render_shells(hits: &[Hit], samples: &ShellSamples, inv_s: f32, out: &mut Rendered) {
    let k = samples.per_ray;
    let mut ray_tape = RayTape::default();
    for (r, &Hit { pixel: i, .. }) in hits.iter().enumerate() {
        let s = r * k..(r + 1) * k;
        let res = render_ray(
            &samples.t[s.clone()],
            &samples.sdf[s.clone()],
            &samples.rgb[s],
            inv_s,
            &mut ray_tape,
        );
        out.rgb[i] = res.rgb;
        out.opacity[i] = res.opacity;
        out.distance[i] = if res.opacity > 1e-3 {
            res.depth / res.opacity
        } else {
            0.0
        };
    }
}

/// Figures of one held-out view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ViewScore {
    /// Sum of squared colour errors over the model's pixels (per channel).
    pub squared_error: f64,
    /// Number of channel values in `squared_error`.
    pub count: usize,
}

impl ViewScore {
    /// Adds another view's errors.
    pub fn add(&mut self, other: ViewScore) {
        self.squared_error += other.squared_error;
        self.count += other.count;
    }

    /// PSNR (dB) of the summed errors.
    pub fn psnr(&self) -> f64 {
        psnr_of(self.squared_error / self.count.max(1) as f64)
    }
}

/// PSNR (dB) from a mean squared error.
pub fn psnr_of(mse: f64) -> f64 {
    -10.0 * mse.max(1e-12).log10()
}

/// Squared colour error of `rendered` against `target` over the view's surface pixels.
pub fn color_error(view: &FrameView, rendered: &[[f32; 3]], target: &[[f32; 3]]) -> ViewScore {
    let mut s = ViewScore::default();
    for i in (0..view.rgb.len()).filter(|&i| view.class[i] == PixelClass::Surface) {
        for c in 0..3 {
            let e = (rendered[i][c] - target[i][c]) as f64;
            s.squared_error += e * e;
            s.count += 1;
        }
    }
    s
}

/// Squared colour error of `rendered` against `target` over the view's surface pixels after matching
/// the view's exposure and white balance: one gain per channel, fitted by least squares on one half of
/// the view's pixels (the white squares of a checkerboard) and scored on the other, both ways round.
///
/// A model trained with per-frame colour gains ([`crate::frame_corrections`]) keeps the exposure its
/// training frames average to, which no capture fixes: a phone's exposures are its own, and the mean of a
/// few dozen random ones is a few percent off any other view's. A held-out view has its own exposure
/// too, so it is matched as the model's own frames are, with the model's own correction (a gain per
/// channel on sRGB values). Fitting on one half and scoring on the other keeps the fit from seeing
/// the pixels it is scored on, as NeRF-W's protocol for its per-image appearance does; the halves
/// interleave, so each sees what the other does (left and right halves of a view show different
/// surfaces, whose own errors would then pass for a gain).
pub fn exposure_matched_error(
    view: &FrameView,
    rendered: &[[f32; 3]],
    target: &[[f32; 3]],
) -> ViewScore {
    let width = view.camera.width as usize;
    let white = |i: usize| (i % width + i / width).is_multiple_of(2);
    let surface: Vec<usize> = (0..view.rgb.len())
        .filter(|&i| view.class[i] == PixelClass::Surface)
        .collect();
    // Per half (indexed by `white(i)`) and channel: Σ rendered · target and Σ rendered².
    let mut sums = [[[0.0f64; 2]; 3]; 2];
    for &i in &surface {
        for (c, sum) in sums[usize::from(white(i))].iter_mut().enumerate() {
            let (r, t) = (rendered[i][c] as f64, target[i][c] as f64);
            sum[0] += r * t;
            sum[1] += r * r;
        }
    }
    let gains = sums.map(|half| half.map(|[rt, rr]| if rr > 0.0 { rt / rr } else { 1.0 }));
    let mut s = ViewScore::default();
    for &i in &surface {
        // A pixel of one half takes the gains fitted on the other.
        let gain = gains[usize::from(!white(i))];
        for c in 0..3 {
            let matched = (rendered[i][c] as f64 * gain[c]).clamp(0.0, 1.0);
            let e = matched - target[i][c] as f64;
            s.squared_error += e * e;
            s.count += 1;
        }
    }
    s
}

/// Signed distance errors (metres, rendered − observed) where the view's depth is known and the render
/// hit something.
pub fn distance_errors(view: &FrameView, rendered: &Rendered) -> Vec<f32> {
    (0..view.rgb.len())
        .filter(|&i| {
            view.class[i] == PixelClass::Surface
                && view.distance[i] > 0.0
                && rendered.opacity[i] > 0.5
        })
        .map(|i| rendered.distance[i] - view.distance[i])
        .collect()
}

/// An estimate of the held-out PSNR an exact model would reach on `views`: their own pixel noise (a path
/// tracer's Monte-Carlo noise, a camera's sensor noise) is the error left when the model is perfect, so it
/// says how far a figure is from what the images allow. Each surface pixel whose four neighbours are
/// surface pixels too is compared with their mean; the noise's standard deviation is the median absolute
/// difference × 1.4826 (exact for Gaussian noise) / √(5/4) (the neighbours' mean carries a quarter of the
/// variance). Texture raises the estimate of the noise and heavy-tailed noise lowers it: a guide, not a
/// bound. `None` without such pixels.
pub fn noise_psnr_ceiling(views: &[FrameView]) -> Option<f64> {
    let mut differences = Vec::new();
    for view in views {
        let w = view.camera.width as usize;
        let h = view.rgb.len() / w.max(1);
        let surface = |i: usize| view.class[i] == PixelClass::Surface;
        for i in (w + 1..w * h.saturating_sub(1)).filter(|i| i % w != 0 && i % w != w - 1) {
            let around = [i - 1, i + 1, i - w, i + w];
            if !surface(i) || !around.iter().all(|&j| surface(j)) {
                continue;
            }
            for c in 0..3 {
                let mean = around.iter().map(|&j| view.rgb[j][c]).sum::<f32>() / 4.0;
                differences.push((view.rgb[i][c] - mean).abs());
            }
        }
    }
    if differences.is_empty() {
        return None;
    }
    let sigma = median(differences) as f64 * 1.4826 / 1.25f64.sqrt();
    Some(psnr_of(sigma * sigma))
}

/// Median of a list (0 when empty).
fn median(mut v: Vec<f32>) -> f32 {
    upper_median_by(&mut v, f32::total_cmp).unwrap_or(0.0)
}

/// The view's colours re-lit by augmentation map `k` (surface pixels; others unchanged).
pub fn relit_target(view: &FrameView, augmentation: &Augmentation, k: usize) -> Vec<[f32; 3]> {
    (0..view.rgb.len())
        .map(|i| {
            let n = Vec3::from(view.normal[i]);
            if view.class[i] == PixelClass::Surface && n != Vec3::ZERO {
                augmentation.relight_srgb(k, view.rgb[i], n)
            } else {
                view.rgb[i]
            }
        })
        .collect()
}

/// The zero level set of `field` inside `bounds`, on a grid of `cells` per side.
pub fn extract_mesh(field: &NeusField<f32>, bounds: &Aabb, cells: u32) -> TriMesh {
    let grid = Grid::over(Vec3::from(bounds.min), Vec3::from(bounds.max), cells);
    let sdf = |points: &[Vec3]| {
        let pts: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
        let mut tape = Tape::default();
        field.forward(&pts, &[], &CodeSet::default(), Outputs::Sdf, &mut tape);
        let mut s = vec![0.0; pts.len()];
        tape.copy_sdf(&mut s);
        s
    };
    extract_surface(&grid, &sdf)
}

/// Held-out figures of a model.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    /// Held-out views rendered.
    pub views: usize,
    /// PSNR (dB) over the model's pixels of every held-out view.
    pub psnr_db: f64,
    /// The same with each view's exposure and white balance matched ([`exposure_matched_error`]):
    /// what a model trained on auto-exposed frames is judged by. Reports written before it existed
    /// read `None`.
    #[serde(default)]
    pub psnr_exposure_matched_db: Option<f64>,
    /// Median absolute distance error (metres).
    pub median_depth_error_m: f32,
    /// Median signed distance error (metres): negative where the model's surfaces stand in front of
    /// the observed ones, as a model that grew towards its cameras does. Reports written before it
    /// existed read 0.
    #[serde(default)]
    pub median_depth_offset_m: f32,
    /// Fraction of the model's pixels the render hit (opacity > 0.5).
    pub coverage: f32,
    /// Light-code check per augmentation map: PSNR with its code and with code 0 against the re-lit view.
    pub light_codes: Vec<LightCodeCheck>,
}

/// The light-code check of one augmentation map (on up to [`LIGHT_CHECK_VIEWS`] held-out views).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LightCodeCheck {
    /// Map name.
    pub name: String,
    /// PSNR (dB) of the render with the map's light code.
    pub psnr_with_code_db: f64,
    /// PSNR (dB) of the render with code 0.
    pub psnr_with_code_0_db: f64,
}

/// Held-out views the light-code check uses (spread over the capture): one view alone may see the object
/// from an unusual side, all of them would multiply the evaluation time by the number of maps.
pub const LIGHT_CHECK_VIEWS: usize = 3;

/// The held-out views the light-code check uses: up to [`LIGHT_CHECK_VIEWS`] of `views`, spread
/// over the capture.
fn light_check_views(views: usize) -> Vec<usize> {
    match views {
        0 => Vec::new(),
        n if n <= LIGHT_CHECK_VIEWS => (0..n).collect(),
        n => (0..LIGHT_CHECK_VIEWS)
            .map(|k| k * (n - 1) / (LIGHT_CHECK_VIEWS - 1))
            .collect(),
    }
}

/// The light-code check's errors summed so far: per augmentation map, the renders with its code and
/// with code 0 against the view re-lit by the map.
struct LightCheckSums {
    coded: Vec<ViewScore>,
    plain: Vec<ViewScore>,
}

impl LightCheckSums {
    fn new(maps: usize) -> Self {
        Self {
            coded: vec![ViewScore::default(); maps],
            plain: vec![ViewScore::default(); maps],
        }
    }

    /// Adds one view: `code_0` rendered with code 0, `with_code[k]` with map `k`'s code.
    fn add(
        &mut self,
        view: &FrameView,
        augmentation: &Augmentation,
        code_0: &Rendered,
        with_code: &[Rendered],
    ) {
        for (k, rendered) in with_code.iter().enumerate() {
            let target = relit_target(view, augmentation, k);
            self.coded[k].add(color_error(view, &rendered.rgb, &target));
            self.plain[k].add(color_error(view, &code_0.rgb, &target));
        }
    }

    fn checks(&self, augmentation: &Augmentation) -> Vec<LightCodeCheck> {
        (0..augmentation.len())
            .map(|k| LightCodeCheck {
                name: augmentation.names[k].clone(),
                psnr_with_code_db: self.coded[k].psnr(),
                psnr_with_code_0_db: self.plain[k].psnr(),
            })
            .collect()
    }
}

/// Renders every held-out view with its own light code and scores it; the views of the light-code
/// check are rendered in the same pass with code 0 and each augmentation map's code (map `k` has light
/// code `first_augmented + k`).
pub fn evaluate(
    field: &NeusField<f32>,
    views: &[FrameView],
    bounds: &Aabb,
    augmentation: &Augmentation,
    first_augmented: usize,
) -> EvalReport {
    let diag = (Vec3::from(bounds.max) - Vec3::from(bounds.min)).length();
    let options = RenderOptions::for_diagonal(diag);
    let (mut total, mut matched, mut errors, mut hit, mut pixels) = (
        ViewScore::default(),
        ViewScore::default(),
        Vec::new(),
        0usize,
        0usize,
    );
    let checked = light_check_views(views.len());
    let mut light_check = LightCheckSums::new(augmentation.len());
    for (v, view) in views.iter().enumerate() {
        let mut lights = vec![view.light as u32];
        if checked.contains(&v) && !augmentation.is_empty() {
            lights.push(0);
            lights.extend((0..augmentation.len()).map(|k| (first_augmented + k) as u32));
        }
        let surface = |i: usize| view.class[i] == PixelClass::Surface;
        let found = view_surfaces(field, view, bounds, &options, &surface);
        let renders = shade_view(field, view, &found, &lights, &options);
        let r = &renders[0];
        total.add(color_error(view, &r.rgb, &view.rgb));
        matched.add(exposure_matched_error(view, &r.rgb, &view.rgb));
        errors.extend(distance_errors(view, r));
        let surface = (0..view.rgb.len()).filter(|&i| view.class[i] == PixelClass::Surface);
        for i in surface {
            pixels += 1;
            hit += usize::from(r.opacity[i] > 0.5);
        }
        if let [_, code_0, with_code @ ..] = renders.as_slice() {
            light_check.add(view, augmentation, code_0, with_code);
        }
    }
    EvalReport {
        views: views.len(),
        psnr_db: total.psnr(),
        psnr_exposure_matched_db: Some(matched.psnr()),
        median_depth_error_m: median(errors.iter().map(|e| e.abs()).collect()),
        median_depth_offset_m: median(errors),
        coverage: hit as f32 / pixels.max(1) as f32,
        light_codes: light_check.checks(augmentation),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use neuroom_core::Pose;
    use neuroom_core::camera::Pinhole;

    #[test]
    fn the_surface_search_in_rounds_finds_what_one_round_finds() {
        let field = NeusField::new(neuroom_field::NeusConfig::object([0.3, 0.2, 0.25]));
        let fc = field.config();
        let bounds = Aabb {
            min: fc.bounds_min,
            max: fc.bounds_max,
        };
        let options = RenderOptions::for_diagonal(1.0);
        let o = Vec3::new(0.1, -0.2, 0.9);
        let rays: Vec<(usize, Vec3, f32, f32)> = (0..400)
            .filter_map(|i| {
                let (x, y) = ((i % 20) as f32 / 19.0 - 0.5, (i / 20) as f32 / 19.0 - 0.5);
                let d = (Vec3::new(x * 0.8, y * 0.8, 0.0) - o).normalize();
                let (near, far) = bounds.intersect(o, d)?;
                Some((i, d, near.max(options.near), far))
            })
            .collect();
        let mut tape = Tape::default();
        let k = options.coarse;
        let once = find_surfaces(&field, o, &rays, &options, &mut tape, k);
        assert!(once.len() > 50 && once.len() < rays.len(), "{}", once.len());
        for round in [1, 5, SEARCH_ROUND] {
            let rounds = find_surfaces(&field, o, &rays, &options, &mut tape, round);
            assert_eq!(rounds, once, "rounds of {round}");
        }
    }

    /// A 64 × 48 view of one grey surface with Gaussian noise of standard deviation `sigma` per channel
    /// (Box–Muller), a black border of non-surface pixels around it.
    fn noisy_view(sigma: f32) -> FrameView {
        let (w, h) = (64usize, 48usize);
        let mut rng = Pcg32::new(7, 1);
        let inside = |i: usize| (4..w - 4).contains(&(i % w)) && (4..h - 4).contains(&(i / w));
        FrameView {
            index: 0,
            camera: Pinhole::new(w as u32, h as u32, 50.0, 50.0, 32.0, 24.0),
            camera_to_model: Pose::IDENTITY,
            light: 0,
            rgb: (0..w * h)
                .map(|i| {
                    if inside(i) {
                        std::array::from_fn(|_| 0.5 + sigma * rng.next_normal())
                    } else {
                        [0.0; 3]
                    }
                })
                .collect(),
            distance: vec![1.0; w * h],
            class: (0..w * h)
                .map(|i| {
                    if inside(i) {
                        PixelClass::Surface
                    } else {
                        PixelClass::Empty
                    }
                })
                .collect(),
            normal: vec![[0.0, 0.0, 1.0]; w * h],
        }
    }

    #[test]
    fn noise_ceiling_is_the_psnr_of_the_images_own_noise() {
        for sigma in [0.01f32, 0.03] {
            let got = noise_psnr_ceiling(&[noisy_view(sigma)]).unwrap();
            let want = psnr_of((sigma * sigma) as f64);
            assert!(
                (got - want).abs() < 0.5,
                "σ {sigma}: {got:.2} dB vs {want:.2} dB"
            );
        }
        let mut none = noisy_view(0.01);
        none.class.fill(PixelClass::Empty);
        assert_eq!(noise_psnr_ceiling(&[none]), None);
    }

    #[test]
    fn matching_the_exposure_forgives_a_gain_and_nothing_else() {
        let view = noisy_view(0.05);
        let gains = [0.9f32, 1.05, 1.1];
        let exposed: Vec<[f32; 3]> = view
            .rgb
            .iter()
            .map(|p| std::array::from_fn(|c| p[c] / gains[c]))
            .collect();
        let raw = color_error(&view, &exposed, &view.rgb).psnr();
        let matched = exposure_matched_error(&view, &exposed, &view.rgb).psnr();
        assert!(
            raw < 30.0 && matched > 80.0,
            "raw {raw:.1} dB, matched {matched:.1} dB"
        );
        // An error that is not a gain (every other pixel too bright, the rest too dark) is not
        // forgiven: each half's gain is fitted on the other half.
        let w = view.camera.width as usize;
        let split: Vec<[f32; 3]> = (0..view.rgb.len())
            .map(|i| {
                let k = if (i % w + i / w).is_multiple_of(2) {
                    1.1
                } else {
                    0.9
                };
                view.rgb[i].map(|v| v * k)
            })
            .collect();
        let raw = color_error(&view, &split, &view.rgb).psnr();
        let matched = exposure_matched_error(&view, &split, &view.rgb).psnr();
        assert!(matched < raw, "raw {raw:.1} dB, matched {matched:.1} dB");
    }
}
