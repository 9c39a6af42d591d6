//! Finite-difference checks of every hand-written backward pass, in f64, on points away from kinks.

use neuroom_field::hash::{HashGrid, HashGridConfig, Strides};
use neuroom_field::kernel::Precision;
use neuroom_field::mlp::{Activation, Mlp, MlpConfig};
use neuroom_field::rng::SplitMix;
use neuroom_field::{CodeSet, Codes, Group, NeusConfig, NeusField, Outputs, Params, Tape};

const EPS: f64 = 1e-6;

fn assert_close(what: &str, analytic: f64, numeric: f64) {
    let tol = 1e-6 + 1e-5 * numeric.abs().max(analytic.abs());
    assert!(
        (analytic - numeric).abs() <= tol,
        "{what}: analytic {analytic:e} vs finite difference {numeric:e}"
    );
}

fn random(rng: &mut SplitMix, n: usize, scale: f64) -> Vec<f64> {
    (0..n)
        .map(|_| scale * (2.0 * rng.next_f64() - 1.0))
        .collect()
}

/// Points in `(0.05, 0.95)³` whose fractional cell position is at least 0.05 from a face at every level.
fn interior_points(grid: &HashGrid, rng: &mut SplitMix, n: usize) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    while out.len() < n {
        let x: [f64; 3] = std::array::from_fn(|_| 0.05 + 0.9 * rng.next_f64());
        let ok = grid.levels().iter().all(|l| {
            x.iter().all(|v| {
                let f = (v * l.resolution as f64).fract();
                f > 0.05 && f < 0.95
            })
        });
        if ok {
            out.push(x);
        }
    }
    out
}

#[test]
fn hash_encoding_gradients_to_table_and_position() {
    let grid = HashGrid::new(HashGridConfig {
        levels: 3,
        features: 2,
        log2_table: 6,
        base_resolution: 2,
        finest_resolution: 9,
    });
    assert!(grid.levels()[0].dense && !grid.levels()[2].dense);
    let mut rng = SplitMix::new(1);
    let mut table = random(&mut rng, grid.num_params(), 1.0);
    let u = interior_points(&grid, &mut rng, 5);
    let w = grid.config().output_dim();
    let c = random(&mut rng, u.len() * w, 1.0);
    let loss = |table: &[f64], u: &[[f64; 3]]| {
        let mut out = vec![0.0; u.len() * w];
        grid.forward(table, u, 3, &mut out, Strides::rows(w), None);
        out.iter().zip(&c).map(|(a, b)| a * b).sum::<f64>()
    };
    let mut grad = vec![0.0; table.len()];
    grid.backward_table(&[(&u[..], &c[..])], Strides::rows(w), 3, &mut grad);
    for i in (0..table.len()).step_by(3) {
        let v = table[i];
        table[i] = v + EPS;
        let lp = loss(&table, &u);
        table[i] = v - EPS;
        let lm = loss(&table, &u);
        table[i] = v;
        assert_close(&format!("table[{i}]"), grad[i], (lp - lm) / (2.0 * EPS));
    }
    let mut out = vec![0.0; u.len() * w];
    let mut jac = vec![0.0; u.len() * w * 3];
    grid.forward(&table, &u, 3, &mut out, Strides::rows(w), Some(&mut jac));
    for p in 0..u.len() {
        for a in 0..3 {
            let analytic: f64 = (0..w)
                .map(|k| c[p * w + k] * jac[(k * 3 + a) * u.len() + p])
                .sum();
            let mut up = u.clone();
            up[p][a] += EPS;
            let mut um = u.clone();
            um[p][a] -= EPS;
            assert_close(
                &format!("u[{p}][{a}]"),
                analytic,
                (loss(&table, &up) - loss(&table, &um)) / (2.0 * EPS),
            );
        }
    }
}

#[test]
fn hash_encoding_masks_levels() {
    let grid = HashGrid::new(HashGridConfig {
        levels: 4,
        features: 2,
        log2_table: 8,
        base_resolution: 2,
        finest_resolution: 16,
    });
    let mut rng = SplitMix::new(2);
    let table = random(&mut rng, grid.num_params(), 1.0);
    let mut out = vec![1.0; 8];
    grid.forward(
        &table,
        &[[0.3, 0.4, 0.6]],
        2,
        &mut out,
        Strides::rows(8),
        None,
    );
    assert!(out[..4].iter().all(|v| *v != 0.0) && out[4..].iter().all(|v| *v == 0.0));
}

fn check_mlp(hidden_activation: Activation, output_activation: Activation) {
    let mlp = Mlp::new(MlpConfig {
        input: 5,
        hidden: vec![7, 6],
        output: 4,
        hidden_activation,
        output_activation,
        precision: Precision::F32,
    });
    let mut rng = SplitMix::new(3);
    let mut params = vec![0.0f64; mlp.num_params()];
    mlp.init(&mut params, &mut rng, 1.0);
    for (i, b) in params.iter_mut().enumerate() {
        *b += 0.1 * ((i * 7919 % 13) as f64 / 13.0 - 0.5);
    }
    let n = 3;
    let mut input = random(&mut rng, n * 5, 1.0);
    let c = random(&mut rng, n * 4, 1.0);
    let mut ws = mlp.workspace(n);
    let loss = |params: &[f64], input: &[f64], ws: &mut neuroom_field::mlp::MlpWorkspace<f64>| {
        mlp.forward(&mlp.pack(params, 0..0), input, n, ws);
        let (out, stride) = ws.output();
        (0..n * 4)
            .map(|i| out[(i / 4) * stride + i % 4] * c[i])
            .sum::<f64>()
    };
    loss(&params, &input, &mut ws);
    let mut grads = vec![0.0; params.len()];
    let mut d_in = vec![0.0; n * 5];
    mlp.backward(
        &mlp.pack(&params, 0..0),
        &input,
        n,
        &mut ws,
        &c,
        Some(&mut grads),
        Some((&mut d_in, 5)),
    );
    for i in 0..params.len() {
        let v = params[i];
        params[i] = v + EPS;
        let lp = loss(&params, &input, &mut ws);
        params[i] = v - EPS;
        let lm = loss(&params, &input, &mut ws);
        params[i] = v;
        assert_close(&format!("param {i}"), grads[i], (lp - lm) / (2.0 * EPS));
    }
    for i in 0..input.len() {
        let v = input[i];
        input[i] = v + EPS;
        let lp = loss(&params, &input, &mut ws);
        input[i] = v - EPS;
        let lm = loss(&params, &input, &mut ws);
        input[i] = v;
        assert_close(&format!("input {i}"), d_in[i], (lp - lm) / (2.0 * EPS));
    }
    // One output's input gradient (the field's normal): every output column against the same
    // differences of that column alone, asking for a prefix of the input columns.
    for column in 0..4 {
        let output = |input: &[f64], ws: &mut neuroom_field::mlp::MlpWorkspace<f64>| {
            mlp.forward(&mlp.pack(&params, 0..0), input, n, ws);
            let (out, stride) = ws.output();
            (0..n).map(|p| out[p * stride + column]).collect::<Vec<_>>()
        };
        output(&input, &mut ws);
        let mut d_cols = vec![0.0; n * 4];
        mlp.output_input_gradient(
            &mlp.pack(&params, 0..0),
            (&input, 5),
            n,
            &mut ws,
            column,
            (&mut d_cols, 4),
        );
        for p in 0..n {
            for col in 0..4 {
                let v = input[p * 5 + col];
                input[p * 5 + col] = v + EPS;
                let yp = output(&input, &mut ws)[p];
                input[p * 5 + col] = v - EPS;
                let ym = output(&input, &mut ws)[p];
                input[p * 5 + col] = v;
                let name = format!("output {column} row {p} input {col}");
                assert_close(&name, d_cols[p * 4 + col], (yp - ym) / (2.0 * EPS));
            }
        }
    }
}

/// A one-layer network's output input gradient is a weight column scaled by the output activation's
/// derivative.
#[test]
fn mlp_output_input_gradient_single_layer() {
    let mlp = Mlp::new(MlpConfig {
        input: 3,
        hidden: vec![],
        output: 2,
        hidden_activation: Activation::Relu,
        output_activation: Activation::Sigmoid,
        precision: Precision::F32,
    });
    let mut rng = SplitMix::new(5);
    let params = random(&mut rng, mlp.num_params(), 0.8);
    let n = 2;
    let mut input = random(&mut rng, n * 3, 1.0);
    let mut ws = mlp.workspace(n);
    let pack = mlp.pack(&params, 0..0);
    let out1 = |input: &[f64], ws: &mut neuroom_field::mlp::MlpWorkspace<f64>| {
        mlp.forward(&pack, input, n, ws);
        let (out, stride) = ws.output();
        (0..n).map(|p| out[p * stride + 1]).collect::<Vec<_>>()
    };
    out1(&input, &mut ws);
    let mut d = vec![0.0; n * 3];
    mlp.output_input_gradient(&pack, (&input, 3), n, &mut ws, 1, (&mut d, 3));
    for i in 0..n * 3 {
        let v = input[i];
        input[i] = v + EPS;
        let yp = out1(&input, &mut ws)[i / 3];
        input[i] = v - EPS;
        let ym = out1(&input, &mut ws)[i / 3];
        input[i] = v;
        assert_close(&format!("input {i}"), d[i], (yp - ym) / (2.0 * EPS));
    }
}

#[test]
fn mlp_gradients_softplus_sigmoid() {
    check_mlp(Activation::Softplus { beta: 3.0 }, Activation::Sigmoid);
}

#[test]
fn mlp_gradients_relu_linear() {
    check_mlp(Activation::Relu, Activation::None);
}

/// A small f64 field with every code kind, a smooth SDF network and non-trivial tables.
fn small_field(object_codes: usize) -> NeusField<f64> {
    let mut config = NeusConfig::object([0.5, 0.5, 0.5]);
    config.hash = HashGridConfig {
        levels: 3,
        features: 2,
        log2_table: 7,
        base_resolution: 2,
        finest_resolution: 7,
    };
    config.sdf_hidden = vec![8];
    config.sdf_activation = Activation::Softplus { beta: 4.0 };
    config.geometry_features = 4;
    config.color_hidden = vec![8, 8];
    config.code_dim = 3;
    config.appearance_codes = 2;
    config.light_codes = 2;
    config.object_codes = object_codes;
    let mut field = NeusField::<f64>::new(config);
    let mut rng = SplitMix::new(4);
    for v in field.params.get_mut(Group::Hash) {
        *v = 0.5 * (2.0 * rng.next_f64() - 1.0);
    }
    let sdf_out = field.sdf_mlp().num_params();
    for v in &mut field.params.get_mut(Group::SdfMlp)[sdf_out - 40..] {
        *v += 0.3 * (2.0 * rng.next_f64() - 1.0);
    }
    for g in [Group::Appearance, Group::Light, Group::Object] {
        for v in field.params.get_mut(g) {
            *v = 0.5 * (2.0 * rng.next_f64() - 1.0);
        }
    }
    field
}

/// Points in the field's box (metres) that map to interior cell positions.
fn field_points(field: &NeusField<f64>, n: usize, seed: u64) -> Vec<[f64; 3]> {
    let lo = field.config().bounds_min;
    let hi = field.config().bounds_max;
    interior_points(field.grid(), &mut SplitMix::new(seed), n)
        .into_iter()
        .map(|u| std::array::from_fn(|a| lo[a] as f64 + u[a] * (hi[a] - lo[a]) as f64))
        .collect()
}

struct Case {
    points: Vec<[f64; 3]>,
    dirs: Vec<[f64; 3]>,
    app: Vec<u32>,
    light: Vec<u32>,
    obj: Vec<u32>,
    a: Vec<f64>,
    b: Vec<f64>,
}

impl Case {
    fn new(field: &NeusField<f64>, n: usize) -> Self {
        let mut rng = SplitMix::new(5);
        let dirs = (0..n)
            .map(|_| {
                let d: [f64; 3] = std::array::from_fn(|_| 2.0 * rng.next_f64() - 1.0);
                let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                d.map(|v| v / l)
            })
            .collect();
        Self {
            points: field_points(field, n, 6),
            dirs,
            app: (0..n as u32).map(|i| i % 2).collect(),
            light: (0..n as u32).map(|i| (i / 2) % 2).collect(),
            obj: (0..n as u32).map(|i| (i / 3) % 2).collect(),
            a: random(&mut rng, n, 1.0),
            b: random(&mut rng, 3 * n, 1.0),
        }
    }

    fn codes(&self) -> CodeSet<'_> {
        CodeSet {
            appearance: Codes::PerPoint(&self.app),
            light: Codes::PerPoint(&self.light),
            object: Codes::PerPoint(&self.obj),
        }
    }

    /// `Σ a·sdf (+ Σ b·rgb)` at `points`.
    fn loss(&self, field: &NeusField<f64>, points: &[[f64; 3]], color: bool) -> f64 {
        let mut tape = Tape::default();
        let n = points.len();
        let outputs = if color { Outputs::Full } else { Outputs::Sdf };
        field.forward(points, &self.dirs, &self.codes(), outputs, &mut tape);
        let mut sdf = vec![0.0; n];
        tape.copy_sdf(&mut sdf);
        let mut l: f64 = sdf.iter().zip(&self.a).map(|(x, y)| x * y).sum();
        if color {
            let mut rgb = vec![0.0; 3 * n];
            tape.copy_rgb(&mut rgb);
            l += rgb.iter().zip(&self.b).map(|(x, y)| x * y).sum::<f64>();
        }
        l
    }

    fn check(&self, field: &mut NeusField<f64>, color: bool, groups: &[Group]) {
        let n = self.points.len();
        let mut tape = Tape::default();
        let outputs = if color {
            Outputs::Full
        } else {
            Outputs::SdfGradient
        };
        field.forward(&self.points, &self.dirs, &self.codes(), outputs, &mut tape);
        let mut grads = Params::zeros_like(&field.params);
        let mut d_points = vec![[0.0; 3]; n];
        let d_rgb = color.then_some(&self.b[..]);
        field.backward(
            &self.codes(),
            &mut tape,
            &self.a,
            d_rgb,
            &mut grads,
            Some(&mut d_points),
        );
        for &g in groups {
            let len = field.params.get(g).len();
            for i in (0..len).step_by((len / 40).max(1)) {
                let v = field.params.get(g)[i];
                field.params.get_mut(g)[i] = v + EPS;
                let lp = self.loss(field, &self.points, color);
                field.params.get_mut(g)[i] = v - EPS;
                let lm = self.loss(field, &self.points, color);
                field.params.get_mut(g)[i] = v;
                assert_close(
                    &format!("{}[{i}]", g.name()),
                    grads.get(g)[i],
                    (lp - lm) / (2.0 * EPS),
                );
            }
        }
        for p in 0..n {
            for a in 0..3 {
                let mut pp = self.points.clone();
                pp[p][a] += EPS;
                let mut pm = self.points.clone();
                pm[p][a] -= EPS;
                let numeric =
                    (self.loss(field, &pp, color) - self.loss(field, &pm, color)) / (2.0 * EPS);
                assert_close(&format!("x[{p}][{a}]"), d_points[p][a], numeric);
            }
        }
    }
}

#[test]
fn sdf_network_gradients_params_codes_and_position() {
    let mut field = small_field(2);
    let case = Case::new(&field, 7);
    case.check(
        &mut field,
        false,
        &[Group::Hash, Group::SdfMlp, Group::Object],
    );
}

#[test]
fn colour_network_gradients_including_codes() {
    let mut field = small_field(2);
    // The normal enters the colour network without gradient by design; cut that input so the finite
    // differences see the same function.
    let cfg = field.config().clone();
    let normal_col = cfg.geometry_features + 2 * cfg.code_dim + 16;
    let width = cfg.color_hidden[0];
    for r in normal_col..normal_col + 3 {
        field.params.get_mut(Group::ColorMlp)[r * width..(r + 1) * width].fill(0.0);
    }
    let case = Case::new(&field, 7);
    case.check(
        &mut field,
        true,
        &[
            Group::Hash,
            Group::SdfMlp,
            Group::ColorMlp,
            Group::Appearance,
            Group::Light,
            Group::Object,
        ],
    );
}

#[test]
fn batched_passes_span_several_chunks() {
    let mut field = small_field(0);
    let case = Case::new(&field, 600);
    let mut tape = Tape::default();
    field.forward(
        &case.points,
        &case.dirs,
        &case.codes(),
        Outputs::Full,
        &mut tape,
    );
    assert_eq!(tape.chunks().len(), 3);
    let mut grads = Params::zeros_like(&field.params);
    field.backward(
        &case.codes(),
        &mut tape,
        &case.a,
        Some(&case.b),
        &mut grads,
        None,
    );
    let i = 5;
    let v = field.params.get(Group::SdfMlp)[i];
    field.params.get_mut(Group::SdfMlp)[i] = v + EPS;
    let lp = case.loss(&field, &case.points, true);
    field.params.get_mut(Group::SdfMlp)[i] = v - EPS;
    let lm = case.loss(&field, &case.points, true);
    field.params.get_mut(Group::SdfMlp)[i] = v;
    // Loose: the normal path is live here.
    let numeric = (lp - lm) / (2.0 * EPS);
    assert!((grads.get(Group::SdfMlp)[i] - numeric).abs() < 0.2 * numeric.abs().max(1.0));
}

#[test]
fn analytic_normal_matches_finite_differences() {
    let field = small_field(0);
    let case = Case::new(&field, 5);
    let mut tape = Tape::default();
    let codes = CodeSet::default();
    field.forward(&case.points, &[], &codes, Outputs::SdfGradient, &mut tape);
    let mut g = vec![[0.0; 3]; 5];
    tape.copy_gradient(&mut g);
    for (p, gp) in g.iter().enumerate() {
        for a in 0..3 {
            let sdf_at = |d: f64| {
                let mut x = case.points[p];
                x[a] += d;
                let mut t = Tape::default();
                field.forward(&[x], &[], &codes, Outputs::Sdf, &mut t);
                let mut s = [0.0];
                t.copy_sdf(&mut s);
                s[0]
            };
            assert_close(
                &format!("∇f[{p}][{a}]"),
                gp[a],
                (sdf_at(EPS) - sdf_at(-EPS)) / (2.0 * EPS),
            );
        }
    }
}

#[test]
fn box_base_normal_matches_finite_differences_inside_and_outside() {
    let mut config = small_field(0).config().clone();
    config.init.inside_out = true;
    config.init.box_half_extent = Some([0.4, 0.3, 0.45]);
    let field = NeusField::<f64>::new(config);
    // Inside the box near each wall, and outside beyond a face and beyond an edge.
    let points = [
        [0.35, 0.02, 0.05],
        [-0.03, -0.26, 0.1],
        [0.05, 0.1, 0.41],
        [0.46, 0.05, -0.02],
        [0.44, 0.36, 0.0],
    ];
    let codes = CodeSet::default();
    let mut tape = Tape::default();
    field.forward(&points, &[], &codes, Outputs::SdfGradient, &mut tape);
    let mut g = vec![[0.0; 3]; points.len()];
    tape.copy_gradient(&mut g);
    let sdf_at = |x: [f64; 3]| {
        let mut t = Tape::default();
        field.forward(&[x], &[], &codes, Outputs::Sdf, &mut t);
        let mut s = [0.0];
        t.copy_sdf(&mut s);
        s[0]
    };
    for (p, gp) in g.iter().enumerate() {
        for a in 0..3 {
            let (mut xp, mut xm) = (points[p], points[p]);
            xp[a] += EPS;
            xm[a] -= EPS;
            assert_close(
                &format!("∇f[{p}][{a}]"),
                gp[a],
                (sdf_at(xp) - sdf_at(xm)) / (2.0 * EPS),
            );
        }
    }
    // Positive inside the room box, negative outside.
    assert!(sdf_at(points[0]) > 0.0 && sdf_at(points[3]) < 0.0);
}

#[test]
fn eikonal_loss_gradients() {
    let mut field = small_field(2);
    let points = field_points(&field, 4, 8);
    let obj: Vec<u32> = vec![0, 1, 1, 0];
    let h = 0.01;
    let loss = |field: &NeusField<f64>| {
        let mut g = Params::zeros_like(&field.params);
        field.eikonal(
            &points,
            Codes::PerPoint(&obj),
            h,
            0.7,
            &mut Tape::default(),
            &mut g,
        )
    };
    let mut grads = Params::zeros_like(&field.params);
    let l0 = field.eikonal(
        &points,
        Codes::PerPoint(&obj),
        h,
        0.7,
        &mut Tape::default(),
        &mut grads,
    );
    assert!(l0 > 0.0);
    for g in [Group::Hash, Group::SdfMlp, Group::Object] {
        let len = field.params.get(g).len();
        for i in (0..len).step_by((len / 30).max(1)) {
            let v = field.params.get(g)[i];
            field.params.get_mut(g)[i] = v + EPS;
            let lp = loss(&field);
            field.params.get_mut(g)[i] = v - EPS;
            let lm = loss(&field);
            field.params.get_mut(g)[i] = v;
            assert_close(
                &format!("eikonal {}[{i}]", g.name()),
                grads.get(g)[i],
                (lp - lm) / (2.0 * EPS),
            );
        }
    }
}

/// `Mlp::forward_split` / `backward_split`: input columns 2..4 are supplied through the first layer's
/// pre-activation by the caller; the weight gradient of the other rows, the input gradient of columns 0..2
/// and (through `first_layer_delta`) the shared rows' gradient must match finite differences.
#[test]
fn mlp_split_gradients() {
    let mlp = Mlp::new(MlpConfig {
        input: 6,
        hidden: vec![5],
        output: 3,
        hidden_activation: Activation::Softplus { beta: 2.0 },
        output_activation: Activation::Sigmoid,
        precision: Precision::F32,
    });
    let (n, h, shared) = (4, 5, 2..4);
    let mut rng = SplitMix::new(9);
    let mut params = random(&mut rng, mlp.num_params(), 0.5);
    let mut input = random(&mut rng, n * 6, 1.0);
    let c = random(&mut rng, n * 3, 1.0);
    let mut ws = mlp.workspace(n);
    let run = |params: &[f64], input: &[f64], ws: &mut neuroom_field::mlp::MlpWorkspace<f64>| {
        let (pre, ps) = ws.first_layer_mut();
        for p in 0..n {
            for j in 0..h {
                let shared_sum: f64 = shared
                    .clone()
                    .map(|r| input[p * 6 + r] * params[r * h + j])
                    .sum();
                pre[p * ps + j] = params[6 * h + j] + shared_sum;
            }
        }
        let rest: Vec<f64> = (0..n)
            .flat_map(|p| [0, 1, 4, 5].map(|r| input[p * 6 + r]))
            .collect();
        mlp.forward_split(&mlp.pack(params, shared.clone()), &rest, 4, n, ws);
        rest
    };
    let loss = |params: &[f64], input: &[f64], ws: &mut neuroom_field::mlp::MlpWorkspace<f64>| {
        run(params, input, ws);
        let (out, stride) = ws.output();
        (0..n * 3)
            .map(|i| out[(i / 3) * stride + i % 3] * c[i])
            .sum::<f64>()
    };
    let rest = run(&params, &input, &mut ws);
    let mut grads = vec![0.0; params.len()];
    let mut d_in = vec![0.0; n * 2];
    mlp.backward_split(
        &mlp.pack(&params, shared.clone()),
        (&rest, 4),
        n,
        &mut ws,
        (&c, 3),
        Some(&mut grads),
        Some((&mut d_in, 2)),
    );
    let (delta, ds) = ws.first_layer_delta();
    for r in shared.clone() {
        for j in 0..h {
            grads[r * h + j] = (0..n).map(|p| input[p * 6 + r] * delta[p * ds + j]).sum();
        }
    }
    for i in 0..params.len() {
        let v = params[i];
        params[i] = v + EPS;
        let lp = loss(&params, &input, &mut ws);
        params[i] = v - EPS;
        let lm = loss(&params, &input, &mut ws);
        params[i] = v;
        assert_close(&format!("param {i}"), grads[i], (lp - lm) / (2.0 * EPS));
    }
    for p in 0..n {
        for col in 0..2 {
            let v = input[p * 6 + col];
            input[p * 6 + col] = v + EPS;
            let lp = loss(&params, &input, &mut ws);
            input[p * 6 + col] = v - EPS;
            let lm = loss(&params, &input, &mut ws);
            input[p * 6 + col] = v;
            assert_close(
                &format!("input[{p}][{col}]"),
                d_in[p * 2 + col],
                (lp - lm) / (2.0 * EPS),
            );
        }
    }
}

/// Recolouring a full forward pass under other appearance and light codes gives the bits a full pass
/// with those codes gives, over several chunks and with per-point codes.
#[test]
fn recolor_matches_a_full_forward_with_the_other_codes() {
    let field = small_field(0);
    let n = 700;
    let points = field_points(&field, n, 11);
    let dirs: Vec<[f64; 3]> = (0..n)
        .map(|k| {
            let a = k as f64 * 0.37;
            [a.cos() * 0.6, a.sin() * 0.6, 0.8]
        })
        .collect();
    let per_point: Vec<u32> = (0..n as u32).map(|k| k % 2).collect();
    let first = CodeSet::default();
    let other = CodeSet {
        appearance: Codes::PerPoint(&per_point),
        light: Codes::Fixed(1),
        ..CodeSet::default()
    };
    let rgb_of = |tape: &Tape<f64>| {
        let mut rgb = vec![0.0; 3 * n];
        tape.copy_rgb(&mut rgb);
        rgb
    };
    let mut tape = Tape::default();
    field.forward(&points, &dirs, &first, Outputs::Full, &mut tape);
    let before = rgb_of(&tape);
    field.recolor(&dirs, &other, &mut tape);
    let mut full = Tape::default();
    field.forward(&points, &dirs, &other, Outputs::Full, &mut full);
    let want = rgb_of(&full);
    assert_eq!(rgb_of(&tape), want);
    assert_ne!(before, want, "the codes change the colour");
}
