//! Trains one model of a room with a time budget and prints the report as JSON:
//! `cargo run --release -p neuroom-train --example bench_train -- ROOM (background | OBJECT) [SECONDS] [STEPS]`.

use neuroom_train::TrainConfig;
use neuroom_train::bench::{bench_background, bench_object};
use neuroom_train::progress::Bar;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (room, model) = match args.as_slice() {
        [room, model, ..] => (PathBuf::from(room), model.clone()),
        _ => return Err("usage: bench_train ROOM (background | OBJECT) [SECONDS] [STEPS]".into()),
    };
    let mut config = TrainConfig::default();
    let budget = if model == "background" {
        &mut config.background
    } else {
        &mut config.object
    };
    if let Some(s) = args.get(2) {
        budget.time_budget_s = Some(s.parse()?);
    }
    if let Some(s) = args.get(3) {
        budget.steps = s.parse()?;
    }
    let report = if model == "background" {
        bench_background(&room, &config, &Bar::default())?
    } else {
        bench_object(&room, &model, &config, &Bar::default())?
    };
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
