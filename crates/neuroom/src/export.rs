//! `neuroom export`: a solved room as a glTF 2.0 binary (meshes from the SDFs, vertex colours under the
//! solved lighting, placed by the solved poses, the camera) and as an offline HTML report (the input
//! panorama and the solved scene's render under a slider, views of the solved scene, the same glTF in an
//! interactive 3D view, a top-down map against the ground truth, the metrics) and, with the `rerun`
//! feature, as a Rerun recording (`export/rrd.rs`).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use glam::DVec3;
use neuroom_core::formats::{Arrangement, atomic_write, read_arrangement, read_rgb, read_room};

use neuroom_core::metrics::{ArrangementScore, Symmetry, psnr, ssim};
use neuroom_core::obb::OrientedBox;
pub use neuroom_export::mesh::MeshDetail;
use neuroom_export::mesh::{Geometry, SceneMeshes, scene_meshes};
use neuroom_export::report::{Figure, Report, Section, Table};
use neuroom_export::room_gltf::{ExportCamera, room_glb};
use neuroom_export::topdown::{MapBox, TopDown};

use crate::tour::{Generated, Lens, generate, room_box};
use crate::view::{SolvedScene, ViewCamera, render_view, solved_scene};

#[cfg(feature = "rerun")]
mod rrd;

/// What to export and how.
#[derive(Clone, Debug)]
pub struct ExportOptions {
    /// Write the glTF binary here.
    pub gltf: Option<PathBuf>,
    /// Write the HTML report here.
    pub report: Option<PathBuf>,
    /// Write the Rerun recording (.rrd) here; needs the `rerun` feature.
    pub rrd: Option<PathBuf>,
    /// Ground-truth arrangement to compare with (report).
    pub truth: Option<PathBuf>,
    /// The room folder (object sizes for boxes and metrics); found beside the ground truth otherwise.
    pub room: Option<PathBuf>,
    /// The input panorama; found beside the arrangement or the ground truth otherwise.
    pub panorama: Option<PathBuf>,
    /// Mesh resolution (glTF and Rerun).
    pub detail: MeshDetail,
    /// Mesh resolution of the report's 3D view: coarser than the glTF's, as the page carries the
    /// meshes inline and a browser must load them whole.
    pub report_detail: MeshDetail,
    /// Width of the report's panorama render.
    pub render_width: u32,
    /// Number of pinhole views of the solved scene in the report.
    pub views: usize,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            gltf: None,
            report: None,
            rrd: None,
            truth: None,
            room: None,
            panorama: None,
            detail: MeshDetail::default(),
            report_detail: MeshDetail::preview(),
            render_width: 512,
            views: 2,
        }
    }
}

/// What an export wrote and measured.
#[derive(Clone, Debug, Default)]
pub struct ExportSummary {
    /// The glTF file with its vertex and triangle counts.
    pub gltf: Option<(PathBuf, usize, usize)>,
    /// The report.
    pub report: Option<PathBuf>,
    /// The Rerun recording.
    pub rrd: Option<PathBuf>,
    /// The scores against the ground truth, when given.
    pub score: Option<ArrangementScore>,
    /// PSNR (dB) and SSIM of the solved panorama render against the input, when both are known.
    pub image_agreement: Option<(f64, f64)>,
}

/// Exports the models in `models` placed by `arrangement` as `options` asks; `progress(stage)` names
/// each stage as it starts.
pub fn export(
    models: &Path,
    arrangement: &Path,
    options: &ExportOptions,
    progress: &mut dyn FnMut(&str),
) -> anyhow::Result<ExportSummary> {
    anyhow::ensure!(
        options.rrd.is_none() || cfg!(feature = "rerun"),
        "this neuroom was built without Rerun support: rebuild it with `--features rerun` to write .rrd files"
    );
    progress("placing the models");
    let scene = solved_scene(models, arrangement)?;
    let mut summary = ExportSummary::default();
    let names = object_names(&scene);
    let meshes = (options.gltf.is_some() || options.rrd.is_some()).then(|| {
        progress("extracting coloured meshes");
        scene_meshes(&scene.lit.scene, &names, &options.detail)
    });
    let camera = ExportCamera::from_panorama(scene.arrangement.camera_to_world);
    if let (Some(path), Some(meshes)) = (&options.gltf, &meshes) {
        summary.gltf = Some(write_gltf(meshes, &room_glb(meshes, &camera), path)?);
    }
    #[cfg(feature = "rerun")]
    if let (Some(path), Some(meshes)) = (&options.rrd, &meshes) {
        progress("recording for Rerun");
        rrd::write_rrd(&scene, meshes, arrangement, options, path)?;
        summary.rrd = Some(path.clone());
    }
    if let Some(path) = &options.report {
        progress("extracting coarse meshes for the report's 3D view");
        let coarse = scene_meshes(&scene.lit.scene, &names, &options.report_detail);
        let glb = room_glb(&coarse, &camera);
        let report = compose_report(
            &scene,
            models,
            arrangement,
            options,
            &glb,
            progress,
            &mut summary,
        )?;
        atomic_write(path, report.html().as_bytes())?;
        summary.report = Some(path.clone());
    }
    Ok(summary)
}

/// The arrangement's object names, in the scene's order: the names of the mesh layers.
fn object_names(scene: &SolvedScene) -> Vec<String> {
    scene
        .arrangement
        .objects
        .iter()
        .map(|o| o.name.clone())
        .collect()
}

/// Writes `glb`, the glTF binary of `meshes`; returns its path, vertex and triangle counts.
fn write_gltf(
    meshes: &SceneMeshes,
    glb: &[u8],
    path: &Path,
) -> anyhow::Result<(PathBuf, usize, usize)> {
    atomic_write(path, glb)?;
    let count = |f: &dyn Fn(&Geometry) -> usize| {
        meshes
            .layers
            .iter()
            .map(|l| f(&meshes.geometries[l.geometry]))
            .sum::<usize>()
    };
    Ok((
        path.to_path_buf(),
        count(&|g| g.positions.len()),
        count(&|g| g.triangles.len()),
    ))
}

/// The room folder: given, or the one holding the ground truth's `panoramas/`.
fn find_room(options: &ExportOptions) -> Option<PathBuf> {
    options.room.clone().or_else(|| {
        let dir = options.truth.as_ref()?.parent()?.parent()?;
        dir.join("room.json").exists().then(|| dir.to_path_buf())
    })
}

/// The input panorama: given, or the arrangement's `image` beside it or beside the ground truth.
fn find_panorama(
    options: &ExportOptions,
    arrangement: &Path,
    solved: &Arrangement,
    truth: Option<&Arrangement>,
) -> Option<PathBuf> {
    if let Some(p) = &options.panorama {
        return Some(p.clone());
    }
    let beside = |file: &Path, image: &str| {
        let p = file.parent()?.join(image);
        (!image.is_empty() && p.is_file()).then_some(p)
    };
    beside(arrangement, &solved.image).or_else(|| {
        let t = truth?;
        beside(options.truth.as_ref()?, &t.image)
    })
}

/// Full box sizes by object id: room.json's, or the extent of each model's surface.
fn object_sizes(scene: &SolvedScene, room: Option<&Path>) -> anyhow::Result<Vec<(u16, DVec3)>> {
    if let Some(room) = room {
        let room = read_room(room.join("room.json"))?;
        return Ok(room.objects.iter().map(|o| (o.id, o.size)).collect());
    }
    let s = &scene.lit.scene;
    Ok(s.objects
        .iter()
        .map(|o| {
            let g = Geometry::extract(
                &s.models[o.model].field,
                -o.half_extents,
                o.half_extents,
                24,
            );
            let size = g.bounds().map_or(2.0 * o.half_extents, |(lo, hi)| hi - lo);
            (o.instance_id, size.as_dvec3())
        })
        .collect())
}

/// Model name per object id: the solved scene's, then the manifest's id lists.
fn model_names(scene: &SolvedScene, models: &Path) -> Vec<(u16, String)> {
    let mut names: Vec<(u16, String)> = scene
        .lit
        .scene
        .objects
        .iter()
        .map(|o| (o.instance_id, scene.placed.names[o.model].clone()))
        .collect();
    if let Ok(m) = crate::edit::read_manifest(models) {
        for e in &m.models {
            names.extend(e.ids.iter().map(|id| (*id, e.name.clone())));
        }
    }
    names
}

fn lookup<T: Clone>(table: &[(u16, T)], id: u16) -> Option<T> {
    table.iter().find(|(i, _)| *i == id).map(|(_, v)| v.clone())
}

/// An image file as a figure, embedded as it is when PNG or JPEG.
fn file_figure(path: &Path, caption: String) -> anyhow::Result<Figure> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let mime = match bytes.get(..4) {
        Some([0x89, b'P', b'N', b'G']) => "image/png",
        Some([0xFF, 0xD8, 0xFF, _]) => "image/jpeg",
        _ => anyhow::bail!("{}: neither PNG nor JPEG", path.display()),
    };
    Ok(Figure {
        caption,
        mime,
        bytes,
    })
}

fn fmt(v: Option<f64>, unit: &str) -> String {
    v.map_or("–".into(), |x| format!("{x:.1}{unit}"))
}

/// The metrics table of `score`.
fn score_table(score: &ArrangementScore, names: &[(u16, String)]) -> Table {
    let mut rows: Vec<Vec<String>> = score
        .objects
        .iter()
        .map(|o| {
            vec![
                format!("{} ({})", lookup(names, o.id).unwrap_or_default(), o.id),
                o.predicted_id.map_or("missed".into(), |p| p.to_string()),
                format!("{:.1} %", o.iou_percent),
                fmt(o.rotation_error_deg, "°"),
                fmt(o.yaw_error_deg, "°"),
                fmt(o.position_error_cm, " cm"),
            ]
        })
        .collect();
    rows.push(vec![
        "mean".into(),
        format!(
            "P {:.0} % / R {:.0} %",
            100.0 * score.precision,
            100.0 * score.recall
        ),
        fmt(score.mean_iou_percent, " %"),
        fmt(score.mean_rotation_error_deg, "°"),
        fmt(score.mean_yaw_error_deg, "°"),
        fmt(score.mean_position_error_cm, " cm"),
    ]);
    Table {
        header: ["object (id)", "matched", "IoU", "ARE", "yaw error", "APE"]
            .map(String::from)
            .to_vec(),
        rows,
    }
}

/// The solved objects: position and heading.
fn object_table(arrangement: &Arrangement, names: &[(u16, String)]) -> Table {
    Table {
        header: ["object (id)", "model", "x", "y", "z", "yaw"]
            .map(String::from)
            .to_vec(),
        rows: arrangement
            .objects
            .iter()
            .map(|o| {
                let t = o.object_to_world.translation;
                vec![
                    format!("{} ({})", o.name, o.id),
                    lookup(names, o.id).unwrap_or_default(),
                    format!("{:.3} m", t.x),
                    format!("{:.3} m", t.y),
                    format!("{:.3} m", t.z),
                    format!("{:.1}°", o.object_to_world.yaw().to_degrees()),
                ]
            })
            .collect(),
    }
}

/// Boxes of an arrangement's objects whose size is known.
fn map_boxes(arrangement: &Arrangement, sizes: &[(u16, DVec3)]) -> Vec<MapBox> {
    arrangement
        .objects
        .iter()
        .filter_map(|o| {
            Some(MapBox {
                label: o.name.clone(),
                id: o.id,
                obb: OrientedBox::new(o.object_to_world, lookup(sizes, o.id)?),
            })
        })
        .collect()
}

/// Renders and measures the report's sections; `glb` is the solved room's glTF binary for the 3D view.
fn compose_report(
    scene: &SolvedScene,
    models: &Path,
    arrangement_path: &Path,
    options: &ExportOptions,
    glb: &[u8],
    progress: &mut dyn FnMut(&str),
    summary: &mut ExportSummary,
) -> anyhow::Result<Report> {
    let solved = &scene.arrangement;
    let truth = options.truth.as_deref().map(read_arrangement).transpose()?;
    let room = find_room(options);
    let sizes = object_sizes(scene, room.as_deref())?;
    let names = model_names(scene, models);
    let mut sections = vec![(
        "Summary".to_string(),
        Section::Text(format!(
            "Models {}; arrangement {} ({} objects){}.",
            models.display(),
            arrangement_path.display(),
            solved.objects.len(),
            options
                .truth
                .as_ref()
                .map_or(String::new(), |t| format!("; ground truth {}", t.display()))
        )),
    )];
    progress("rendering the solved panorama");
    let input = find_panorama(options, arrangement_path, solved, truth.as_ref());
    sections.extend(panorama_sections(
        scene,
        input.as_deref(),
        options,
        summary,
    )?);
    if options.views > 0 {
        progress("rendering views of the solved scene");
        sections.push((
            "Views of the solved scene".into(),
            views_section(scene, options.views)?,
        ));
    }
    sections.push((
        "The solved room in 3D".into(),
        Section::Model3d {
            glb: glb.to_vec(),
            caption: "the glTF export: meshes from the SDFs coloured under the solved lighting; drag to \
                      orbit, scroll to zoom; the room's walls are seen from inside only, so those nearest \
                      to you let you look in"
                .into(),
        },
    ));
    progress("drawing the map and the metrics");
    sections.push((
        "Top-down map".into(),
        map_section(scene, truth.as_ref(), &sizes),
    ));
    if let Some(t) = &truth {
        let score = score(solved, t, &sizes, &names);
        sections.push((
            "Arrangement against the ground truth".into(),
            Section::Table(score_table(&score, &names)),
        ));
        summary.score = Some(score);
    }
    sections.push((
        "Solved objects".into(),
        Section::Table(object_table(solved, &names)),
    ));
    Ok(Report {
        title: format!("neuroom: {}", arrangement_path.display()),
        sections,
    })
}

/// The solved panorama render, under a slider against the `input` panorama where there is one, and how
/// well the two agree (also kept in `summary`).
fn panorama_sections(
    scene: &SolvedScene,
    input: Option<&Path>,
    options: &ExportOptions,
    summary: &mut ExportSummary,
) -> anyhow::Result<Vec<(String, Section)>> {
    let render = render_view(
        scene,
        &ViewCamera::Panorama {
            width: options.render_width,
        },
    )?
    .rgb;
    let solved = Figure::png(
        "the solved scene rendered from the panorama camera",
        &render,
    )?;
    let Some(path) = input else {
        return Ok(vec![(
            "Solved panorama".into(),
            Section::Figures(vec![solved]),
        )]);
    };
    let small = read_rgb(path)?
        .image
        .box_downsample(render.width, render.height);
    summary.image_agreement = small.map(|small| (psnr(&small, &render), ssim(&small, &render)));
    let mut sections = vec![(
        "Input and solved panorama".into(),
        Section::Compare {
            before: file_figure(path, format!("input panorama {}", path.display()))?,
            after: solved,
            caption: format!(
                "left of the line: the input panorama {}; right of it: the solved scene rendered from \
                 the panorama camera; drag the slider to move the line",
                path.display()
            ),
        },
    )];
    if let Some((p, s)) = summary.image_agreement {
        sections.push((
            "Image agreement".into(),
            Section::Text(format!(
                "Solved render against the input at {}×{}: PSNR {p:.2} dB, SSIM {s:.3}.",
                render.width, render.height
            )),
        ));
    }
    Ok(sections)
}

/// `count` pinhole views of the solved scene from an orbit around the room.
fn views_section(scene: &SolvedScene, count: usize) -> anyhow::Result<Section> {
    let (lo, hi) = room_box(scene);
    let lens = Lens::Pinhole {
        width: 400,
        height: 300,
        fov_deg: 75.0,
    };
    let mut views = Vec::new();
    for (k, pose) in generate(Generated::Orbit(count), lo, hi)?
        .iter()
        .enumerate()
    {
        let (camera, camera_to_world) = lens.camera(pose)?;
        let rgb = crate::view::render_camera(scene, &camera, &camera_to_world, &|_| {}).rgb;
        views.push(Figure::png(format!("view {} of an orbit", k + 1), &rgb)?);
    }
    Ok(Section::Figures(views))
}

/// The top-down map of the solved boxes, with the ground truth's where given.
fn map_section(
    scene: &SolvedScene,
    truth: Option<&Arrangement>,
    sizes: &[(u16, DVec3)],
) -> Section {
    let (lo, hi) = room_box(scene);
    let camera = &scene.arrangement.camera_to_world;
    let map = TopDown {
        room: (lo.truncate(), hi.truncate()),
        solved: map_boxes(&scene.arrangement, sizes),
        truth: truth.map_or_else(Vec::new, |t| map_boxes(t, sizes)),
        camera: Some((camera.translation, camera.transform_vector(DVec3::X))),
    };
    let caption = if truth.is_some() {
        "top-down map: solved boxes filled, ground truth dashed, in the same colour per object"
    } else {
        "top-down map of the solved boxes"
    };
    Section::Svg {
        svg: map.svg(),
        caption: caption.into(),
    }
}

/// Scores the solved arrangement against the truth (boxes of the true sizes).
fn score(
    solved: &Arrangement,
    truth: &Arrangement,
    sizes: &[(u16, DVec3)],
    names: &[(u16, String)],
) -> ArrangementScore {
    crate::score::score_arrangement(truth, solved, |id| {
        let model = lookup(names, id).unwrap_or_else(|| format!("id {id}"));
        Some((model, lookup(sizes, id)?, Symmetry::None))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_core::formats::{write_arrangement, write_rgb};
    use neuroom_core::image::Image;
    use neuroom_testing::{tiny_arrangement, write_tiny_models};

    #[test]
    fn exports_a_glb_and_a_report_with_metrics_against_the_truth() {
        let dir = tempfile::tempdir().unwrap();
        let models = dir.path().join("models");
        write_tiny_models(&models).unwrap();
        let truth = tiny_arrangement();
        let mut solved = truth.clone();
        let t = &mut solved.objects[0].object_to_world.translation;
        *t += DVec3::new(0.05, 0.0, 0.0);
        let (truth_path, solved_path) =
            (dir.path().join("gt.json"), dir.path().join("solved.json"));
        write_arrangement(&truth_path, &truth).unwrap();
        write_arrangement(&solved_path, &solved).unwrap();
        write_rgb(
            dir.path().join("tiny.png"),
            &Image::filled(64, 32, [0.3f32; 3]),
        )
        .unwrap();
        let coarse = MeshDetail {
            object_cell_m: 0.05,
            room_cell_m: 0.2,
            ..MeshDetail::default()
        };
        let options = ExportOptions {
            gltf: Some(dir.path().join("room.glb")),
            report: Some(dir.path().join("report.html")),
            truth: Some(truth_path),
            detail: coarse,
            report_detail: coarse,
            render_width: 32,
            views: 1,
            ..ExportOptions::default()
        };
        let mut stages = Vec::new();
        let summary = export(&models, &solved_path, &options, &mut |s| {
            stages.push(s.to_string())
        })
        .unwrap();
        assert!(stages.len() >= 4, "{stages:?}");
        let (glb, vertices, triangles) = summary.gltf.unwrap();
        assert!(vertices > 0 && triangles > 0);
        assert!(gltf::Gltf::from_slice(&std::fs::read(glb).unwrap()).is_ok());
        let score = summary.score.unwrap();
        assert_eq!(score.recall, 1.0);
        let ape = score.mean_position_error_cm.unwrap();
        assert!(
            (ape - 5.0 / 3.0).abs() < 1e-6,
            "one object off by 5 cm of three: {ape}"
        );
        assert!(
            summary.image_agreement.is_some(),
            "the input was found beside the arrangement"
        );
        let html = std::fs::read_to_string(summary.report.unwrap()).unwrap();
        assert_eq!(
            html.matches("data:image/png;base64,").count(),
            3,
            "input, panorama, one view"
        );
        assert!(html.contains(r#"class="compare""#) && html.contains(r#"type="range""#));
        assert_eq!(html.matches("data:model/gltf-binary;base64,").count(), 1);
        assert!(html.contains("<svg") && html.contains(r#"class="truth""#));
        assert!(html.contains("ball_1 (1)"));
    }
}
