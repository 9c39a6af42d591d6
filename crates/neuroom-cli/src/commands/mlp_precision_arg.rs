//! `--mlp-precision f32|bf16`: the arithmetic of the fields' network products (`train`, `bench field`,
//! `bench train`).

use neuroom::train::MlpPrecision as Precision;

/// The products' arithmetic, as the command line names it.
#[derive(Clone, Copy, Debug, Default, clap::ValueEnum)]
pub enum MlpPrecisionArg {
    /// `f32` throughout.
    #[default]
    F32,
    /// Operands in bfloat16, sums in `f32`, where the CPU has AVX-512 BF16 (`f32` elsewhere).
    Bf16,
}

impl From<MlpPrecisionArg> for Precision {
    fn from(a: MlpPrecisionArg) -> Self {
        match a {
            MlpPrecisionArg::F32 => Precision::F32,
            MlpPrecisionArg::Bf16 => Precision::Bf16,
        }
    }
}
