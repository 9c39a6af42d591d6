//! Generates one preset room and prints the summary as JSON:
//! `cargo run --release -p neuroom-synth --example synth -- <preset> <out> [seed] [furniture dir]`.

use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: synth <preset> <out> [seed] [furniture dir]";
    let preset = neuroom_synth::Preset::named(args.get(1).expect(usage)).expect("unknown preset");
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
