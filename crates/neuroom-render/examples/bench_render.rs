//! Prints the render benchmark (the paper's Table 3 on this machine) as a table, then as one JSON line.
//!
//! `cargo run --release -p neuroom-render --example bench_render [ITERATIONS]`
//!
//! The library's report counts the renderer's own buffers; the fields' tapes (activations kept for the
//! backward pass) grow with the full queries. This binary counts allocations to measure those bytes per
//! full query of a default NeuS field, and adds an estimate of the total per row.

use glam::Vec3;
use neuroom_field::{CodeSet, Field, FieldOutput, NeusConfig, NeusField, Params, Query, Tape};
use neuroom_render::bench::{RenderBenchConfig, bench_render};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The system allocator, counting live bytes.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);

// SAFETY: defers to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LIVE.fetch_add(layout.size(), Ordering::Relaxed);
        // SAFETY: same layout contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        // SAFETY: `ptr` came from `alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Bytes a default object field keeps per point in its tape after a full forward and backward.
fn tape_bytes_per_query() -> f64 {
    let n = 16_384;
    let field = NeusField::new(NeusConfig::object([0.4, 0.4, 0.5]));
    let mut grads = Params::zeros_like(&field.params);
    let points: Vec<Vec3> = (0..n)
        .map(|i| Vec3::new((i % 97) as f32, (i % 89) as f32, (i % 83) as f32) * 0.008 - 0.3)
        .collect();
    let dirs = vec![Vec3::X; n];
    let (d_sdf, d_rgb, mut d_points) = (
        vec![1e-3; n],
        vec![Vec3::splat(1e-3); n],
        vec![Vec3::ZERO; n],
    );
    let query = Query {
        points: &points,
        dirs: &dirs,
        codes: CodeSet::default(),
    };
    let before = LIVE.load(Ordering::Relaxed);
    let mut tape = Tape::default();
    let mut out = FieldOutput::default();
    Field::forward(&field, &query, &mut tape, &mut out);
    Field::backward(
        &field,
        &query,
        &mut tape,
        &d_sdf,
        &d_rgb,
        &mut grads,
        Some(&mut d_points),
    );
    let grown = LIVE.load(Ordering::Relaxed) - before;
    drop((tape, out));
    grown as f64 / n as f64
}

fn main() {
    let mut config = RenderBenchConfig::default();
    if let Some(n) = std::env::args().nth(1).and_then(|a| a.parse().ok()) {
        config.iterations = n;
    }
    let per_query = tape_bytes_per_query();
    let report = bench_render(&config);
    println!(
        "threads: {}; field tape ≈ {per_query:.0} bytes per full query",
        report.threads
    );
    println!(
        "{:<12} {:>6} {:>8} {:>10} {:>10} {:>10} {:>11} {:>10} {:>10} {:>9} {:>8} {:>8} {:>8}",
        "sampling",
        "rays",
        "objects",
        "trace q",
        "coarse q",
        "full q",
        "all q",
        "buffer MB",
        "+tape MB",
        "ms/iter",
        "plan",
        "forward",
        "backward"
    );
    for r in &report.rows {
        let mb = |b: f64| b / (1 << 20) as f64;
        println!(
            "{:<12} {:>6} {:>8} {:>10} {:>10} {:>10} {:>11} {:>10.2} {:>10.1} {:>9.1} {:>8.1} {:>8.1} {:>8.1}",
            r.sampling,
            r.rays,
            r.objects,
            r.trace_queries,
            r.coarse_queries,
            r.full_queries,
            r.queries,
            mb(r.buffer_bytes as f64),
            mb(r.buffer_bytes as f64 + per_query * r.full_queries as f64),
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
