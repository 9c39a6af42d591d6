//! Photometric loss of the joint rendering against the panorama's pixels: the mean over rays of the
//! squared colour error, `L = (1/n) Σᵣ |cᵣ − ĉᵣ|²`. Its gradient per ray feeds [`neuroom_render::Renderer::backward`].

use neuroom_render::volume::RayOutput;

/// The loss of rendered `outputs` against `target` colours; writes `weight · ∂L/∂output` per ray into
/// `d_out` (resized; depth and opacity get no gradient).
pub fn photometric_loss(
    outputs: &[RayOutput<f32>],
    target: &[[f32; 3]],
    weight: f32,
    d_out: &mut Vec<RayOutput<f32>>,
) -> f32 {
    assert_eq!(outputs.len(), target.len(), "one target colour per ray");
    d_out.clear();
    if outputs.is_empty() {
        return 0.0;
    }
    let scale = 1.0 / outputs.len() as f32;
    let mut loss = 0.0;
    d_out.extend(outputs.iter().zip(target).map(|(o, t)| {
        let e: [f32; 3] = std::array::from_fn(|c| o.rgb[c] - t[c]);
        loss += e.iter().map(|x| x * x).sum::<f32>();
        RayOutput {
            rgb: e.map(|x| 2.0 * weight * scale * x),
            depth: 0.0,
            opacity: 0.0,
        }
    }));
    weight * scale * loss
}
