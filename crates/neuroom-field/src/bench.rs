//! Throughput of the default field, the figure `neuroom bench field` reports.
//!
//! One step = full forward (SDF, analytic normal, colour) of `n` points uniform in the field's box, then the
//! full backward (every parameter gradient, hash tables included, with position gradients off). The FLOP
//! count per point is the model's nominal count: the multiply–adds of the dense layers (×2) — forward, the
//! normal's input-only backward through the SDF network, and the backward's weight and input gradients —
//! plus the hash grid's trilinear interpolation, Jacobian and scatter. The implementation executes about a
//! fifth less (the appearance and light codes enter the colour network once per run of points sharing
//! them, and input gradients stop at the columns that need one), so `gflops_fwd_bwd` and
//! `fraction_of_peak` are effective figures: the rate at which the nominal work gets done.

use crate::batch::Tape;
use crate::clock::process_cpu_seconds;
use crate::neus::{CodeSet, NeusConfig, NeusField, Outputs};
use crate::params::Params;
use crate::rng::SplitMix;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Measured throughput of one configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchReport {
    /// `object` or `room` (or a caller's label).
    pub config: String,
    /// Points per step.
    pub n: usize,
    /// Worker threads.
    pub threads: usize,
    /// log2 of the hash table size.
    pub log2_table: u32,
    /// Finest grid resolution.
    pub finest: usize,
    /// The arithmetic the networks' products ran in on this CPU: `f32`, or `bf16` where it was asked
    /// for and the CPU has it.
    #[serde(default = "f32_name")]
    pub mlp_arithmetic: String,
    /// Forward points per second (best of the repetitions).
    pub fwd_points_per_s: f64,
    /// Forward + backward points per second (best of the repetitions).
    pub fwd_bwd_points_per_s: f64,
    /// FLOPs per point of a forward pass.
    pub flops_per_point_fwd: f64,
    /// FLOPs per point of forward + backward.
    pub flops_per_point_fwd_bwd: f64,
    /// Achieved GFLOP/s in forward + backward.
    pub gflops_fwd_bwd: f64,
    /// Peak GFLOP/s of the threads used (f32 FMA), from the CPU's clock and vector width.
    pub peak_gflops: f64,
    /// `gflops_fwd_bwd / peak_gflops`.
    pub fraction_of_peak: f64,
    /// Forward + backward points per second of process CPU time, times `threads`: what the wall-clock
    /// figure would be on an otherwise idle machine (the mean over the repetitions, so a little pessimistic).
    #[serde(default)]
    pub fwd_bwd_points_per_s_cpu: f64,
}

fn f32_name() -> String {
    "f32".to_owned()
}

/// FLOPs per point of (forward, forward + backward) of a field.
pub fn flops_per_point(field: &NeusField<f32>) -> (f64, f64) {
    let (ms, mc) = (
        field.sdf_mlp().macs() as f64,
        field.color_mlp().macs() as f64,
    );
    let h = field.config().hash.clone();
    let (l, f) = (h.levels as f64, h.features as f64);
    let corners = 8.0 * l;
    // Per corner: weight (2 mul) + F mul-adds; Jacobian: 3 derivative weights (6) + 3F mul-adds.
    let hash_fwd = corners * (2.0 + 2.0 * f + 6.0 + 6.0 * f);
    let hash_bwd = corners * (2.0 + 2.0 * f);
    let fwd = 2.0 * (ms + mc) + 2.0 * ms + hash_fwd;
    // Backward: weight gradients and input gradients of both networks.
    let bwd = 4.0 * (ms + mc) + hash_bwd;
    (fwd, fwd + bwd)
}

/// Peak f32 GFLOP/s of `threads` cores: clock × FLOPs per cycle (2 FMA pipes × vector lanes × 2; AMD runs
/// AVX-512 on 256-bit pipes, so 32 FLOPs/cycle there and with AVX2; 64 on Intel AVX-512).
pub fn peak_gflops(threads: usize) -> f64 {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let mhz = info
        .lines()
        .find(|l| l.starts_with("cpu MHz"))
        .and_then(|l| l.split(':').nth(1))
        .and_then(|v| v.trim().parse::<f64>().ok())
        .unwrap_or(2500.0);
    let amd = info.contains("AuthenticAMD");
    let flags = info.lines().find(|l| l.starts_with("flags")).unwrap_or("");
    let per_cycle = if flags.contains(" avx512f") && !amd {
        64.0
    } else if flags.contains(" avx2") && flags.contains(" fma") {
        32.0
    } else {
        8.0
    };
    threads as f64 * mhz * 1e-3 * per_cycle
}

/// Measures forward and forward + backward throughput of a freshly initialised field of `config` on `n`
/// points uniform in its box, with `threads` rayon threads, best of `reps` repetitions after one warm-up.
pub fn field_throughput(
    label: &str,
    config: &NeusConfig,
    n: usize,
    threads: usize,
    reps: usize,
) -> BenchReport {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    pool.install(|| {
        let field = NeusField::<f32>::new(config.clone());
        let mut rng = SplitMix::new(7);
        let (lo, hi) = (config.bounds_min, config.bounds_max);
        let points: Vec<[f32; 3]> = (0..n)
            .map(|_| std::array::from_fn(|a| lo[a] + (hi[a] - lo[a]) * rng.next_f64() as f32))
            .collect();
        let dirs: Vec<[f32; 3]> = (0..n)
            .map(|i| [(i as f32).cos(), (i as f32).sin(), 0.0])
            .collect();
        let d_sdf = vec![1e-3f32; n];
        let d_rgb = vec![1e-3f32; 3 * n];
        let codes = CodeSet::default();
        let mut tape = Tape::default();
        let mut grads = Params::zeros_like(&field.params);
        let (mut fwd, mut both) = (f64::INFINITY, f64::INFINITY);
        let mut cpu = 0.0;
        for rep in 0..reps + 1 {
            if rep == 1 {
                cpu = process_cpu_seconds();
            }
            let t0 = Instant::now();
            field.forward(&points, &dirs, &codes, Outputs::Full, &mut tape);
            let t1 = Instant::now();
            field.backward(&codes, &mut tape, &d_sdf, Some(&d_rgb), &mut grads, None);
            let t2 = Instant::now();
            fwd = fwd.min((t1 - t0).as_secs_f64());
            both = both.min((t2 - t0).as_secs_f64());
        }
        let cpu_per_step = (process_cpu_seconds() - cpu) / reps.max(1) as f64;
        let (ff, fb) = flops_per_point(&field);
        let fwd_bwd_points_per_s = n as f64 / both;
        let gflops = fb * fwd_bwd_points_per_s * 1e-9;
        let peak = peak_gflops(threads);
        BenchReport {
            config: label.to_owned(),
            n,
            threads,
            log2_table: config.hash.log2_table,
            finest: config.hash.finest_resolution,
            mlp_arithmetic: config.mlp_precision.arithmetic().to_owned(),
            fwd_points_per_s: n as f64 / fwd,
            fwd_bwd_points_per_s,
            flops_per_point_fwd: ff,
            flops_per_point_fwd_bwd: fb,
            gflops_fwd_bwd: gflops,
            peak_gflops: peak,
            fraction_of_peak: gflops / peak,
            fwd_bwd_points_per_s_cpu: n as f64 * threads as f64 / cpu_per_step,
        }
    })
}
