//! One module per subcommand: its arguments and how it calls the library.

pub mod bench;
mod bench_figures;
mod bench_level;
pub mod bench_masks;
mod bench_phone;
pub mod bench_suite;
pub mod degrade;
pub mod demo;
pub mod edit;
pub mod eval;
pub mod export;
pub mod fit;
mod frame_corrections_arg;
pub mod import;
pub mod info;
pub mod locate;
pub mod masks;
mod mlp_precision_arg;
mod pinhole;
mod record_args;
pub mod relight;
pub mod render;
mod search_args;
pub mod synth;
pub mod train;
