//! The benchmarks behind the README's performance figures; the `neuroom bench` command prints them.

use neuroom_field::NeusConfig;
use neuroom_field::bench::{BenchReport, field_throughput};
use neuroom_field::kernel::Precision;

/// What `neuroom bench field` measures.
#[derive(Clone, Debug, Default)]
pub struct FieldBench {
    /// Custom table size (log2); with `finest`, replaces the default object/room pair by one configuration.
    pub log2_table: Option<u32>,
    /// Custom finest resolution.
    pub finest: Option<usize>,
    /// Point counts; empty = 65 536 and 262 144.
    pub n: Vec<usize>,
    /// Worker threads.
    pub threads: usize,
    /// Arithmetic of the networks' products.
    pub mlp_precision: Precision,
}

/// Measures field throughput for the default object and room configurations, or for a custom one.
pub fn field(spec: &FieldBench) -> anyhow::Result<Vec<BenchReport>> {
    anyhow::ensure!(spec.threads >= 1, "--threads must be at least 1");
    let ns = if spec.n.is_empty() {
        vec![65_536, 262_144]
    } else {
        spec.n.clone()
    };
    let mut configs = if spec.log2_table.is_some() || spec.finest.is_some() {
        let mut c = NeusConfig::object([0.5; 3]);
        c.hash.log2_table = spec.log2_table.unwrap_or(c.hash.log2_table);
        c.hash.finest_resolution = spec.finest.unwrap_or(c.hash.finest_resolution);
        vec![("custom", c)]
    } else {
        vec![
            ("object", NeusConfig::object([0.5; 3])),
            ("room", NeusConfig::room([-2.0, -2.0, 0.0], [2.0, 2.0, 2.6])),
        ]
    };
    let mut reports = Vec::new();
    for (label, config) in &mut configs {
        config.mlp_precision = spec.mlp_precision;
        for &n in &ns {
            anyhow::ensure!(n > 0, "--n must be positive");
            reports.push(field_throughput(label, config, n, spec.threads, 3));
        }
    }
    Ok(reports)
}

/// One line of text for a field measurement.
pub fn describe_field(r: &BenchReport) -> String {
    format!(
        "field {:6} n={:7} T=2^{} finest={} {}: fwd {:.3} M points/s, fwd+bwd {:.3} M points/s \
         ({:.3} M by CPU time), {:.0} FLOPs/point, {:.1} GFLOP/s = {:.1} % of {:.0} GFLOP/s peak",
        r.config,
        r.n,
        r.log2_table,
        r.finest,
        r.mlp_arithmetic,
        r.fwd_points_per_s * 1e-6,
        r.fwd_bwd_points_per_s * 1e-6,
        r.fwd_bwd_points_per_s_cpu * 1e-6,
        r.flops_per_point_fwd_bwd,
        r.gflops_fwd_bwd,
        100.0 * r.fraction_of_peak,
        r.peak_gflops
    )
}

/// Ray-traced samples per second of the synthetic-room renderer on one furnished `bedroom` panorama of
/// `width × width/2` pixels, with the full-room rendering quality.
pub fn synth(width: u32, seed: u64) -> anyhow::Result<neuroom_synth::SynthBenchReport> {
    anyhow::ensure!(
        width >= 16 && width.is_multiple_of(2),
        "--width must be an even number of at least 16"
    );
    let quality = neuroom_synth::Preset::named("bedroom")
        .expect("built-in preset")
        .panoramas
        .quality;
    Ok(neuroom_synth::bench_panorama(width, quality, seed)?)
}

/// One line of text for a synthetic-renderer measurement.
pub fn describe_synth(r: &neuroom_synth::SynthBenchReport) -> String {
    format!(
        "synth panorama {}×{} ({} triangles, {} spp, {} AO rays, {} threads): {:.0} samples/s, {:.0} rays/s, {:.2} s",
        r.width,
        r.width / 2,
        r.triangles,
        r.spp,
        r.ao_rays,
        r.threads,
        r.samples_per_second,
        r.rays_per_second,
        r.seconds
    )
}

/// The render benchmark (the paper's Table 3) with `iterations` timed iterations per row.
pub fn render(iterations: usize) -> anyhow::Result<neuroom_render::bench::RenderBenchReport> {
    anyhow::ensure!(iterations >= 1, "--iterations must be at least 1");
    let config = neuroom_render::bench::RenderBenchConfig {
        iterations,
        ..Default::default()
    };
    Ok(neuroom_render::bench::bench_render(&config))
}

/// The render benchmark as a text table.
pub fn describe_render(r: &neuroom_render::bench::RenderBenchReport) -> String {
    let mut out = format!(
        "render, {} threads: per iteration (plan + forward + backward)\n{:<12} {:>6} {:>8} {:>10} {:>10} {:>10}\n",
        r.threads, "sampling", "rays", "objects", "queries", "buffer MB", "ms"
    );
    for row in &r.rows {
        out += &format!(
            "{:<12} {:>6} {:>8} {:>10} {:>10.1} {:>10.0}\n",
            row.sampling,
            row.rays,
            row.objects,
            row.queries,
            row.buffer_bytes as f64 / 1e6,
            row.ms_per_iteration
        );
    }
    out
}

/// Trains one model of the room (`background` or an object name) from scratch within the budget
/// `options` give (by default the training default's steps) and evaluates it on held-out views.
pub fn train(
    room: &std::path::Path,
    model: &str,
    config: &neuroom_train::TrainConfig,
) -> anyhow::Result<neuroom_train::bench::ModelBenchReport> {
    let config = config.clone();
    let progress = neuroom_train::progress::Bar::default();
    Ok(if model == "background" {
        neuroom_train::bench::bench_background(room, &config, &progress)?
    } else {
        neuroom_train::bench::bench_object(room, model, &config, &progress)?
    })
}

/// One line of text for a training measurement.
pub fn describe_train(r: &neuroom_train::bench::ModelBenchReport) -> String {
    let chamfer = r.chamfer_m.map_or("no GT mesh".to_string(), |c| {
        format!("Chamfer {:.1} mm", c.mean * 1e3)
    });
    let ceiling = r.noise_ceiling_psnr_db.map_or(String::new(), |c| {
        format!(" (the images' noise allows {c:.1} dB)")
    });
    let clock = match r.budget_clock {
        neuroom_train::BudgetClock::Wall => String::new(),
        neuroom_train::BudgetClock::Cpu => {
            format!(" of CPU per thread ({:.0} s wall)", r.train_wall_seconds)
        }
    };
    let held_out = r
        .held_out
        .as_ref()
        .map_or("no held-out views".to_string(), |e| {
            let matched = e
                .psnr_exposure_matched_db
                .map_or(String::new(), |m| format!(" ({m:.2} dB exposure matched)"));
            format!(
                "held-out PSNR {:.2} dB{matched}{ceiling}, median depth error {:.1} mm (offset \
                 {:+.1} mm), light codes [{}]",
                e.psnr_db,
                e.median_depth_error_m * 1e3,
                e.median_depth_offset_m * 1e3,
                crate::train::light_code_gains(&e.light_codes)
            )
        });
    format!(
        "train {} / {}: {} steps in {:.0} s{clock}, {held_out}, {chamfer}",
        r.room, r.model, r.steps, r.train_seconds,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_train::bench::ModelBenchReport;
    use neuroom_train::trainer::StepProfile;
    use neuroom_train::{BudgetClock, ModelKind};

    /// A capture trained without held-out views (`holdout` 0) has no held-out figures to print.
    #[test]
    fn a_training_without_held_out_views_says_so() {
        let report = ModelBenchReport {
            room: "bedroom".into(),
            model: "bed".into(),
            kind: ModelKind::Object,
            threads: 2,
            rays: 1000,
            steps: 10,
            train_seconds: 1.0,
            budget_clock: BudgetClock::Wall,
            train_wall_seconds: 1.0,
            load_seconds: 0.1,
            eval_seconds: 0.1,
            held_out: None,
            noise_ceiling_psnr_db: None,
            chamfer_m: None,
            inv_s: 100.0,
            step_profile_ms: StepProfile::default(),
        };
        let line = describe_train(&report);
        assert!(line.contains("no held-out views"), "{line}");
        assert!(!line.contains("PSNR"), "{line}");
    }
}
