//! The `neuroom` command: a thin layer over the `neuroom` library that parses arguments, shows progress
//! and turns errors into messages and exit codes.

mod commands;
mod progress;

use clap::{Parser, Subcommand};

/// Understand a known room from one 360° photo, and render it from anywhere.
#[derive(Parser)]
#[command(name = "neuroom", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Demo(commands::demo::Args),
    Synth(commands::synth::Args),
    Info(commands::info::Args),
    Import(commands::import::Args),
    Degrade(commands::degrade::Args),
    Masks(commands::masks::Args),
    Train(commands::train::Args),
    Render(commands::render::Args),
    Relight(commands::relight::Args),
    Edit(commands::edit::Args),
    Export(commands::export::Args),
    Eval(commands::eval::Args),
    Fit(commands::fit::Args),
    Locate(commands::locate::Args),
    Bench(commands::bench::Args),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(args) => commands::demo::run(args),
        Command::Synth(args) => commands::synth::run(args),
        Command::Info(args) => commands::info::run(args),
        Command::Import(args) => commands::import::run(args),
        Command::Degrade(args) => commands::degrade::run(args),
        Command::Masks(args) => commands::masks::run(args),
        Command::Train(args) => commands::train::run(args),
        Command::Render(args) => commands::render::run(args),
        Command::Relight(args) => commands::relight::run(args),
        Command::Edit(args) => commands::edit::run(args),
        Command::Export(args) => commands::export::run(args),
        Command::Eval(args) => commands::eval::run(args),
        Command::Fit(args) => commands::fit::run(args),
        Command::Locate(args) => commands::locate::run(args),
        Command::Bench(args) => commands::bench::run(args),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        // Every failure reported here is about the input or the environment: exit code 2 (panics are bugs
        // and keep Rust's own code).
        std::process::exit(2);
    }
}
