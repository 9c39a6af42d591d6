//! Generates one preset room and prints the summary as JSON, or times the panorama renderer:
//! `cargo run --release -p neuroom-synth --example synth -- <preset> <out> [seed] [furniture dir]`
//! `cargo run --release -p neuroom-synth --example synth -- bench [width]`.

use std::path::Path;

use neuroom_synth::render::Quality;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: synth <preset> <out> [seed] [furniture dir] | synth bench [width]";
    let first = args.get(1).expect(usage);
    if first == "bench" {
        let width = args
            .get(2)
            .map_or(1024, |w| w.parse().expect("width is a number"));
        let report = neuroom_synth::bench_panorama(width, Quality { spp: 4, ao_rays: 2 }, 0)
            .expect("bench failed");
        println!(
            "{}",
            serde_json::to_string_pretty(&report).expect("report serialises")
        );
        return;
    }
    let preset = neuroom_synth::Preset::named(first).expect("unknown preset");
    let out = Path::new(args.get(2).expect(usage));
    let seed = args
        .get(3)
        .map_or(0, |s| s.parse().expect("seed is a number"));
    let furniture = args.get(4).map(Path::new);
    let summary = neuroom_synth::generate(&preset, out, seed, furniture, &[], &mut |p| {
        if p.done == p.total {
            eprintln!("{}: {} done", p.stage, p.total);
        }
    })
    .expect("generation failed");
    println!(
        "{}",
        serde_json::to_string_pretty(&summary).expect("summary serialises")
    );
}
