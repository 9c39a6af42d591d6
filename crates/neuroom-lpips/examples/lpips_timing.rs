//! Times one LPIPS distance between two 512×256 panoramas with the converted weights and prints JSON.
//!
//! `cargo run --release -p neuroom-lpips --example lpips_timing [-- WEIGHTS.safetensors]`
//! (default: where `python3 tools/setup_lpips.py` puts them).

use std::time::Instant;

use neuroom_core::image::RgbImage;
use neuroom_lpips::Lpips;

const WIDTH: u32 = 512;
const HEIGHT: u32 = 256;
const RUNS: u32 = 10;

/// A smooth colourful panorama-sized image; `phase` shifts its pattern.
fn pattern(phase: f32) -> RgbImage {
    let mut image = RgbImage::filled(WIDTH, HEIGHT, [0.0; 3]);
    for v in 0..HEIGHT {
        for u in 0..WIDTH {
            let (x, y) = (u as f32 / 40.0 + phase, v as f32 / 25.0);
            image.set(
                u,
                v,
                std::array::from_fn(|c| 0.5 + 0.4 * (x + c as f32).sin() * (y - c as f32).cos()),
            );
        }
    }
    image
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let lpips = match std::env::args().nth(1) {
        Some(path) => Lpips::load(path)?,
        None => Lpips::load_default()?,
    };
    let (a, b) = (pattern(0.0), pattern(0.3));
    let distance = lpips.distance(&a, &b)?; // warm-up: thread pool, page faults
    let start = Instant::now();
    for _ in 0..RUNS {
        lpips.distance(&a, &b)?;
    }
    let seconds = start.elapsed().as_secs_f64() / f64::from(RUNS);
    let threads = rayon::current_num_threads();
    println!(
        r#"{{"width":{WIDTH},"height":{HEIGHT},"threads":{threads},"seconds_per_pair":{seconds:.4},"distance":{distance:.6}}}"#
    );
    Ok(())
}
