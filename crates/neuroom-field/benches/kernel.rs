//! `cargo bench -p neuroom-field --bench kernel`: the networks' matrix product on one thread, `f32`
//! against bf16, on the shapes of a 256-point chunk of the default field: a 64-wide hidden layer
//! forward, the SDF network's first layer (35 inputs), its 16-wide output layer, and a weight gradient
//! (`Xᵀ · Δ`, `k` = the chunk). Prints a text line and a JSON line per shape and precision.

use neuroom_field::kernel::{Init, Precision, matmul, padded};
use serde::Serialize;
use std::time::Instant;

/// One measured product.
#[derive(Serialize)]
struct KernelReport {
    shape: &'static str,
    m: usize,
    n: usize,
    k: usize,
    /// `f32`, or `bf16` where asked for and the CPU has it.
    arithmetic: &'static str,
    microseconds: f64,
    gflops: f64,
}

/// A product's shape and `A`'s strides (row, column).
struct Shape {
    name: &'static str,
    m: usize,
    n: usize,
    k: usize,
    a_strides: (usize, usize),
}

fn main() {
    let shapes = [
        Shape {
            name: "hidden 64 → 64",
            m: 256,
            n: 64,
            k: 64,
            a_strides: (64, 1),
        },
        Shape {
            name: "input 35 → 64",
            m: 256,
            n: 64,
            k: 35,
            a_strides: (48, 1),
        },
        Shape {
            name: "output 64 → 16",
            m: 256,
            n: 16,
            k: 64,
            a_strides: (64, 1),
        },
        Shape {
            name: "weight gradient 64 × 64",
            m: 64,
            n: 64,
            k: 256,
            a_strides: (1, 64),
        },
    ];
    let reps = 20_000;
    for s in &shapes {
        let a = vec![0.3f32; s.m.max(s.k) * 64 + 64];
        let b = vec![0.2f32; s.k * padded(s.n)];
        let mut c = vec![0.0f32; s.m * padded(s.n)];
        for precision in [Precision::F32, Precision::Bf16] {
            let (rs, cs) = s.a_strides;
            let start = Instant::now();
            for _ in 0..reps {
                let ldb = padded(s.n);
                matmul(
                    precision,
                    s.m,
                    s.n,
                    s.k,
                    &a,
                    rs,
                    cs,
                    &b,
                    ldb,
                    &mut c,
                    ldb,
                    Init::Zero,
                );
            }
            let seconds = start.elapsed().as_secs_f64() / reps as f64;
            let report = KernelReport {
                shape: s.name,
                m: s.m,
                n: s.n,
                k: s.k,
                arithmetic: precision.arithmetic(),
                microseconds: seconds * 1e6,
                gflops: 2.0 * (s.m * s.n * s.k) as f64 / seconds * 1e-9,
            };
            println!(
                "{:26} {:4}: {:7.2} µs, {:6.1} GFLOP/s",
                report.shape, report.arithmetic, report.microseconds, report.gflops
            );
            println!(
                "{}",
                serde_json::to_string(&report).expect("report serialises")
            );
        }
    }
}
