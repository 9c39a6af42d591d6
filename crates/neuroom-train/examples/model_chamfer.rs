//! Scores a trained object model's geometry against a ground-truth mesh, as `neuroom train` and `neuroom
//! bench train` do, and optionally writes the extracted mesh:
//! `cargo run --release -p neuroom-train --example model_chamfer -- MODEL_DIR TRUTH.ply [OUT.ply]`.

use neuroom_core::mesh::{read_ply, write_ply};
use neuroom_core::surface::chamfer;
use neuroom_train::dataset::Aabb;
use neuroom_train::eval::extract_mesh;
use neuroom_train::room::{CHAMFER_SAMPLES, MESH_CELLS};
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [model, truth, rest @ ..] = args.as_slice() else {
        return Err("usage: model_chamfer MODEL_DIR TRUTH.ply [OUT.ply]".into());
    };
    let (field, _, _) = neuroom_field::checkpoint::load(Path::new(model))?;
    let config = field.config();
    let bounds = Aabb {
        min: config.bounds_min,
        max: config.bounds_max,
    };
    let learned = extract_mesh(&field, &bounds, MESH_CELLS);
    if let Some(out) = rest.first() {
        write_ply(Path::new(out), &learned)?;
    }
    let c = chamfer(&learned, &read_ply(Path::new(truth))?, CHAMFER_SAMPLES);
    println!("{}", serde_json::to_string(&c)?);
    Ok(())
}
