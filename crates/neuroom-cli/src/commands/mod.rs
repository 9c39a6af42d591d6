//! One module per subcommand: its arguments and how it calls the library.

pub mod bench;
pub mod info;
pub mod synth;
