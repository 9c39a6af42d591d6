//! Timing run of the figure: 500 iterations of 1024 rays with 5 objects, on untrained NeuS
//! fields (the network cost of trained ones) in the analytic room's layout, from the benchmark's noise.
//! Untrained fields carry no photometric signal, so only the time means anything here.
//!
//! `RAYON_NUM_THREADS=2 cargo run --release -p neuroom-fit --example fit_timing [pose_its] [light_its]`

use neuroom_fit::FitConfig;
use neuroom_fit::bench::{PoseNoise, run_case, untrained_neus_room};

fn main() {
    let arg = |k: usize, default: usize| {
        std::env::args()
            .nth(k)
            .and_then(|a| a.parse().ok())
            .unwrap_or(default)
    };
    let config = FitConfig {
        rays: 1024,
        pose_iterations: arg(1, 500),
        appearance_iterations: arg(2, 0),
        preview_height: None,
        ..FitConfig::default()
    };
    let room = untrained_neus_room(5, 256, &config);
    let report = run_case(
        room.scene,
        &room.room,
        &room.panorama,
        &room.camera_to_world,
        &room.objects,
        &PoseNoise::default(),
        0,
        &config,
    )
    .expect("fit");
    println!(
        "{} + {} iterations of {} rays, {} objects, {} threads: {:.1} s",
        report.pose_iterations,
        config.appearance_iterations,
        report.rays,
        report.objects,
        rayon::current_num_threads(),
        report.seconds,
    );
}
