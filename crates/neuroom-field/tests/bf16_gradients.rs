//! The bf16 products against finite differences of the `f64` reference: a network whose products round
//! their operands to bfloat16 (where the CPU has AVX-512 BF16; plain `f32` elsewhere) still computes the
//! gradient of the function the `f64` network computes, to within the rounding of those operands.

use neuroom_field::kernel::Precision;
use neuroom_field::mlp::{Activation, Mlp, MlpConfig, MlpWorkspace};
use neuroom_field::rng::SplitMix;

const EPS: f64 = 1e-6;
/// bf16 keeps 8 significant bits: each operand is off by up to 2⁻⁹ relative, and a gradient sums many
/// such products, so 2 % of the gradients' own scale bounds the difference (f32 stays below 1e-5).
const BF16_TOLERANCE: f64 = 0.02;

/// A network of the SDF network's shape (35 inputs, one hidden layer of 64, 16 outputs).
fn config(precision: Precision) -> MlpConfig {
    MlpConfig {
        input: 35,
        hidden: vec![64],
        output: 16,
        hidden_activation: Activation::Softplus { beta: 100.0 },
        output_activation: Activation::None,
        precision,
    }
}

/// `Σ c · output` of `mlp` on `n` rows of `input`.
fn loss<T: neuroom_field::Real>(
    mlp: &Mlp,
    params: &[T],
    input: &[T],
    c: &[T],
    n: usize,
    ws: &mut MlpWorkspace<T>,
) -> f64 {
    mlp.forward(&mlp.pack(params, 0..0), input, n, ws);
    let (out, stride) = ws.output();
    let width = mlp.config().output;
    (0..n * width)
        .map(|i| out[(i / width) * stride + i % width].to_f64() * c[i].to_f64())
        .sum()
}

/// `|got − expect| ≤ tolerance · scale` for every pair, `scale` the largest `|expect|`.
fn assert_within(what: &str, got: &[f64], expect: &[f64], tolerance: f64) {
    let scale = expect.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, (g, e)) in got.iter().zip(expect).enumerate() {
        assert!(
            (g - e).abs() <= tolerance * scale,
            "{what} {i}: {g:e} vs reference {e:e} (scale {scale:e})"
        );
    }
}

/// Central differences of `f` at `x`, one coordinate at a time.
fn finite_differences(x: &[f64], mut f: impl FnMut(&[f64]) -> f64) -> Vec<f64> {
    let mut x = x.to_vec();
    (0..x.len())
        .map(|i| {
            let base = x[i];
            x[i] = base + EPS;
            let plus = f(&x);
            x[i] = base - EPS;
            let minus = f(&x);
            x[i] = base;
            (plus - minus) / (2.0 * EPS)
        })
        .collect()
}

/// The `f64` reference network with initialised parameters and `n` rows of input in `[-1, 1]`.
struct Case {
    reference: Mlp,
    params: Vec<f64>,
    input: Vec<f64>,
    rng: SplitMix,
}

fn case(seed: u64, n: usize) -> Case {
    let reference = Mlp::new(config(Precision::F32));
    let mut rng = SplitMix::new(seed);
    let mut params = vec![0.0f64; reference.num_params()];
    reference.init(&mut params, &mut rng, 1.0);
    let input = (0..n * 35).map(|_| 2.0 * rng.next_f64() - 1.0).collect();
    Case {
        reference,
        params,
        input,
        rng,
    }
}

fn narrow(v: &[f64]) -> Vec<f32> {
    v.iter().map(|x| *x as f32).collect()
}

fn widen(v: &[f32]) -> Vec<f64> {
    v.iter().map(|x| *x as f64).collect()
}

#[test]
fn bf16_mlp_gradients_match_finite_differences_of_the_reference() {
    let n = 24;
    let Case {
        reference,
        params,
        input,
        mut rng,
    } = case(11, n);
    let c: Vec<f64> = (0..n * 16).map(|_| 2.0 * rng.next_f64() - 1.0).collect();

    // Finite differences of the f64 network, by parameter and by input.
    let mut ws = reference.workspace::<f64>(n);
    let d_params_fd = finite_differences(&params, |p| loss(&reference, p, &input, &c, n, &mut ws));
    let d_input_fd = finite_differences(&input, |x| loss(&reference, &params, x, &c, n, &mut ws));

    for (precision, tolerance) in [(Precision::F32, 1e-5), (Precision::Bf16, BF16_TOLERANCE)] {
        let mlp = Mlp::new(config(precision));
        let (p32, x32, c32) = (narrow(&params), narrow(&input), narrow(&c));
        let mut ws = mlp.workspace::<f32>(n);
        loss(&mlp, &p32, &x32, &c32, n, &mut ws);
        let mut grads = vec![0.0f32; p32.len()];
        let mut d_in = vec![0.0f32; n * 35];
        let pack = mlp.pack(&p32, 0..0);
        mlp.backward(
            &pack,
            &x32,
            n,
            &mut ws,
            &c32,
            Some(&mut grads),
            Some((&mut d_in, 35)),
        );
        let what = format!("{precision:?} parameter");
        assert_within(&what, &widen(&grads), &d_params_fd, tolerance);
        let what = format!("{precision:?} input");
        assert_within(&what, &widen(&d_in), &d_input_fd, tolerance);
    }
}

/// The input gradient of one output (what a field's normal is) in bf16 against the `f64` network's.
#[test]
fn bf16_output_input_gradient_matches_the_reference() {
    let n = 16;
    let Case {
        reference,
        params,
        input,
        ..
    } = case(12, n);
    let expect = normal(&reference, &params, &input, n);
    let bf16 = Mlp::new(config(Precision::Bf16));
    let got = widen(&normal(&bf16, &narrow(&params), &narrow(&input), n));
    assert_within("normal", &got, &expect, BF16_TOLERANCE);
}

/// The gradient of output 0 with respect to the first 3 input columns, `n × 3`.
fn normal<T: neuroom_field::Real>(mlp: &Mlp, params: &[T], input: &[T], n: usize) -> Vec<T> {
    let pack = mlp.pack(params, 0..0);
    let mut ws = mlp.workspace::<T>(n);
    mlp.forward(&pack, input, n, &mut ws);
    let mut d = vec![T::ZERO; n * 3];
    mlp.output_input_gradient(&pack, (input, 35), n, &mut ws, 0, (&mut d, 3));
    d
}
