//! `cargo bench -p neuroom-field --bench field`: throughput of the default object and room fields on
//! 65 536 and 262 144 points with 2 threads (override with `NEUROOM_BENCH_N=a,b` and
//! `NEUROOM_BENCH_THREADS`; `NEUROOM_BENCH_CONFIGS=object` measures one configuration, `NEUROOM_BENCH_REPS` sets the repetitions). Prints a text line
//! and a JSON line per measurement.

use neuroom_field::NeusConfig;
use neuroom_field::bench::field_throughput;

fn main() {
    let ns: Vec<usize> = std::env::var("NEUROOM_BENCH_N")
        .ok()
        .map(|v| v.split(',').filter_map(|s| s.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![65_536, 262_144]);
    let threads = std::env::var("NEUROOM_BENCH_THREADS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2);
    let configs = [
        ("object", NeusConfig::object([0.5, 0.5, 0.5])),
        ("room", NeusConfig::room([-2.0, -2.0, 0.0], [2.0, 2.0, 2.6])),
    ];
    let reps = std::env::var("NEUROOM_BENCH_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3);
    let only = std::env::var("NEUROOM_BENCH_CONFIGS").ok();
    let wanted = |label: &str| {
        only.as_deref()
            .is_none_or(|o| o.split(',').any(|c| c == label))
    };
    for (label, config) in configs.iter().filter(|(l, _)| wanted(l)) {
        for &n in &ns {
            let r = field_throughput(label, config, n, threads, reps);
            println!(
                "{label:6} n={n:7} T=2^{} finest={}: fwd {:.2} M points/s, fwd+bwd {:.2} M points/s, \
                 {:.0} FLOPs/point, {:.1} GFLOP/s = {:.1} % of {:.0} GFLOP/s peak \
                 (CPU-time estimate {:.2} M points/s)",
                r.log2_table,
                r.finest,
                r.fwd_points_per_s * 1e-6,
                r.fwd_bwd_points_per_s * 1e-6,
                r.flops_per_point_fwd_bwd,
                r.gflops_fwd_bwd,
                100.0 * r.fraction_of_peak,
                r.peak_gflops,
                r.fwd_bwd_points_per_s_cpu * 1e-6
            );
            println!("{}", serde_json::to_string(&r).expect("report serialises"));
        }
    }
}
