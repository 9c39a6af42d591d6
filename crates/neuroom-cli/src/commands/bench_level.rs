//! `neuroom bench level DIR…`: the levelling's up direction against the truth, on test panoramas as
//! taken and tilted.

use std::path::PathBuf;

use neuroom::bench_level::{ErrorSpread, TILT_AXES_DEG, TILT_DEG, bench_level};

/// The arguments of `bench level`.
#[derive(clap::Args)]
pub struct LevelArgs {
    /// Room folders or folders of rooms (e.g. `suite ../shared/data/blender-lite`).
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Also print the report as one JSON object.
    #[arg(long)]
    json: bool,
}

/// Runs the benchmark.
pub fn run(a: &LevelArgs) -> anyhow::Result<()> {
    println!(
        "up-direction error (degrees) as taken | tilted {TILT_DEG}° about axes {TILT_AXES_DEG:?}°"
    );
    let report = bench_level(&a.dirs, &mut |p| {
        let tilted: Vec<String> = p.tilted_deg.iter().map(|e| format!("{e:5.2}")).collect();
        println!(
            "{:<48} {:5.2} | {}",
            p.panorama,
            p.as_taken_deg,
            tilted.join(" ")
        );
    })?;
    let line = |name: &str, s: &ErrorSpread| {
        println!(
            "{name}: {} panoramas, mean {:.2}°, median {:.2}°, max {:.2}°, {} over 2°",
            s.count, s.mean_deg, s.median_deg, s.max_deg, s.over_2_deg
        )
    };
    line("as taken", &report.as_taken);
    line("tilted", &report.tilted);
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    }
    Ok(())
}
