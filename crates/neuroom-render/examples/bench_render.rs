//! Prints the render benchmark (the paper's Table 3 on this machine) as a table, then as one JSON line.
//!
//! `cargo run --release -p neuroom-render --example bench_render [ITERATIONS]`

use neuroom_render::bench::{RenderBenchConfig, bench_render};

fn main() {
    let mut config = RenderBenchConfig::default();
    if let Some(n) = std::env::args().nth(1).and_then(|a| a.parse().ok()) {
        config.iterations = n;
    }
    let report = bench_render(&config);
    println!("threads: {}", report.threads);
    println!(
        "{:<12} {:>6} {:>8} {:>10} {:>10} {:>10} {:>11} {:>10} {:>9}",
        "sampling",
        "rays",
        "objects",
        "trace q",
        "coarse q",
        "full q",
        "all q",
        "buffer MB",
        "ms/iter"
    );
    for r in &report.rows {
        println!(
            "{:<12} {:>6} {:>8} {:>10} {:>10} {:>10} {:>11} {:>10.2} {:>9.1} {:>8.1} {:>8.1} {:>8.1}",
            r.sampling,
            r.rays,
            r.objects,
            r.trace_queries,
            r.coarse_queries,
            r.full_queries,
            r.queries,
            r.buffer_bytes as f64 / (1 << 20) as f64,
            r.ms_per_iteration,
            r.ms_plan,
            r.ms_forward,
            r.ms_backward
        );
    }
    println!(
        "{}",
        serde_json::to_string(&report).expect("report serialises")
    );
}
