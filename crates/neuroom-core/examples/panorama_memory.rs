//! Peak memory of reading one panorama with its ray depth and instance mask (the largest images a room
//! holds), printed as text and as one JSON line.
//!
//! ```text
//! cargo run --release -p neuroom-core --example panorama_memory -- make /tmp/pano 4096
//! cargo run --release -p neuroom-core --example panorama_memory -- read /tmp/pano
//! ```
//! `make` writes `pano.png`, `pano.depth.png` and `pano.mask.png` (W × W/2, smooth colour, depth and a few
//! instance regions); `read` decodes the three as `neuroom info` does, one after the other, and reports the
//! process's peak resident memory (VmHWM on Linux) after each.

use neuroom_core::formats::{read_depth, read_mask, read_rgb, write_depth, write_mask, write_rgb};
use neuroom_core::image::Image;
use std::path::Path;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>()
        .as_slice()
    {
        ["make", dir, width] => make(Path::new(dir), width.parse()?),
        ["read", dir] => read(Path::new(dir)),
        _ => Err("usage: panorama_memory make DIR WIDTH | read DIR".into()),
    }
}

/// Writes the three test images.
fn make(dir: &Path, width: u32) -> Result<(), Box<dyn std::error::Error>> {
    let height = width / 2;
    let pixel = |i: usize| ((i % width as usize) as f32, (i / width as usize) as f32);
    let n = width as usize * height as usize;
    let rgb = Image {
        width,
        height,
        data: (0..n)
            .map(|i| {
                let (u, v) = pixel(i);
                [
                    u / width as f32,
                    v / height as f32,
                    0.5 + 0.5 * (u * 0.01).sin(),
                ]
            })
            .collect(),
    };
    write_rgb(dir.join("pano.png"), &rgb)?;
    drop(rgb);
    let depth = Image {
        width,
        height,
        data: (0..n)
            .map(|i| 1.0 + pixel(i).1 / height as f32 * 4.0)
            .collect(),
    };
    write_depth(dir.join("pano.depth.png"), &depth, 0.001)?;
    drop(depth);
    let mask = Image {
        width,
        height,
        data: (0..n)
            .map(|i| {
                let (u, v) = pixel(i);
                ((u as u32 / 512) % 4 * (v as u32 * 4 / height).min(3)) as u16
            })
            .collect(),
    };
    write_mask(dir.join("pano.mask.png"), &mask)?;
    println!(
        "wrote {width}×{height} pano.png, pano.depth.png, pano.mask.png in {}",
        dir.display()
    );
    Ok(())
}

/// Decodes the three images and reports the peak memory after each.
fn read(dir: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let start = Instant::now();
    let base = peak_kib();
    let rgb = read_rgb(dir.join("pano.png"))?.image;
    let (w, h) = (rgb.width, rgb.height);
    drop(rgb);
    let after_rgb = peak_kib();
    let depth = read_depth(dir.join("pano.depth.png"), 0.001)?;
    drop(depth);
    let after_depth = peak_kib();
    let mask = read_mask(dir.join("pano.mask.png"))?;
    drop(mask);
    let after_mask = peak_kib();
    let seconds = start.elapsed().as_secs_f64();
    let mib = |k: u64| k as f64 / 1024.0;
    println!(
        "{w}×{h}: peak {:.0} MiB after the colour image, {:.0} MiB after depth, {:.0} MiB after the mask \
         (process baseline {:.0} MiB); {seconds:.2} s",
        mib(after_rgb),
        mib(after_depth),
        mib(after_mask),
        mib(base)
    );
    println!(
        "{{\"bench\":\"panorama_memory\",\"width\":{w},\"height\":{h},\"baseline_mib\":{:.1},\
         \"peak_rgb_mib\":{:.1},\"peak_depth_mib\":{:.1},\"peak_mask_mib\":{:.1},\"seconds\":{seconds:.3}}}",
        mib(base),
        mib(after_rgb),
        mib(after_depth),
        mib(after_mask)
    );
    Ok(())
}

/// Peak resident memory of this process in KiB (`VmHWM`), 0 where /proc is unavailable.
fn peak_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        })
        .unwrap_or(0)
}
