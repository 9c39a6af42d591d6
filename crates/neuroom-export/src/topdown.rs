//! A top-down map of an arrangement as SVG: the room's outline, each object's footprint (the outline of
//! its box seen from above), the ground truth dashed beside it when known, and the camera.

use std::fmt::Write as _;

use glam::{DVec2, DVec3};
use neuroom_core::obb::OrientedBox;

/// Width of the drawing in SVG units (pixels).
const WIDTH: f64 = 640.0;
/// Margin around the room (pixels).
const MARGIN: f64 = 24.0;

/// One box on the map.
#[derive(Clone, Debug)]
pub struct MapBox {
    /// Shown beside it.
    pub label: String,
    /// Instance id (picks its colour).
    pub id: u16,
    /// The box placed in the world.
    pub obb: OrientedBox,
}

/// What the map shows.
#[derive(Clone, Debug, Default)]
pub struct TopDown {
    /// Room floor rectangle `(min, max)` in world x, y (metres).
    pub room: (DVec2, DVec2),
    /// The solved boxes (filled).
    pub solved: Vec<MapBox>,
    /// The ground-truth boxes (dashed outlines).
    pub truth: Vec<MapBox>,
    /// The camera centre and its forward direction, when known.
    pub camera: Option<(DVec3, DVec3)>,
}

/// Convex hull (counter-clockwise) of `points`, by the monotone chain.
fn hull(mut points: Vec<DVec2>) -> Vec<DVec2> {
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    points.dedup_by(|a, b| (*a - *b).length() < 1e-12);
    if points.len() < 3 {
        return points;
    }
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut lower: Vec<DVec2> = Vec::new();
    for &p in &points {
        while lower.len() >= 2 && cross(lower[lower.len() - 2], lower[lower.len() - 1], p) <= 0.0 {
            lower.pop();
        }
        lower.push(p);
    }
    let mut upper: Vec<DVec2> = Vec::new();
    for &p in points.iter().rev() {
        while upper.len() >= 2 && cross(upper[upper.len() - 2], upper[upper.len() - 1], p) <= 0.0 {
            upper.pop();
        }
        upper.push(p);
    }
    lower.pop();
    upper.pop();
    lower.extend(upper);
    lower
}

/// The footprint of a box: the hull of its corners projected onto the floor.
pub fn footprint(obb: &OrientedBox) -> Vec<DVec2> {
    hull(obb.corners().iter().map(|c| c.truncate()).collect())
}

/// A colour per id, spread around the hue circle.
fn color(id: u16) -> String {
    format!("hsl({}, 70%, 45%)", (id as u32 * 137) % 360)
}

/// Escapes text for XML and HTML.
pub fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

impl TopDown {
    /// The SVG document (standalone, to be embedded inline in HTML).
    pub fn svg(&self) -> String {
        let (lo, hi) = self.room;
        let extent = (hi - lo).max(DVec2::splat(1e-3));
        let scale = (WIDTH - 2.0 * MARGIN) / extent.x;
        let height = extent.y * scale + 2.0 * MARGIN;
        let to_svg = |p: DVec2| {
            DVec2::new(
                MARGIN + (p.x - lo.x) * scale,
                height - MARGIN - (p.y - lo.y) * scale,
            )
        };
        let points = |ps: &[DVec2]| {
            ps.iter()
                .map(|p| {
                    let q = to_svg(*p);
                    format!("{:.1},{:.1}", q.x, q.y)
                })
                .collect::<Vec<_>>()
                .join(" ")
        };
        let mut s = String::new();
        let _ = write!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {WIDTH} {height:.1}" width="{WIDTH}" height="{height:.1}" font-family="sans-serif" font-size="12">"#
        );
        let corners = [lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)];
        let _ = write!(
            s,
            r##"<polygon points="{}" fill="#f4f1ea" stroke="#333" stroke-width="2"/>"##,
            points(&corners)
        );
        for b in &self.truth {
            let _ = write!(
                s,
                r#"<polygon class="truth" points="{}" fill="none" stroke="{}" stroke-width="1.5" stroke-dasharray="5 3"/>"#,
                points(&footprint(&b.obb)),
                color(b.id)
            );
        }
        for b in &self.solved {
            let c = color(b.id);
            let centre = to_svg(b.obb.center().truncate());
            let _ = write!(
                s,
                r#"<polygon class="solved" points="{}" fill="{c}" fill-opacity="0.35" stroke="{c}" stroke-width="2"/><text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
                points(&footprint(&b.obb)),
                centre.x,
                centre.y + 4.0,
                escape(&b.label)
            );
        }
        if let Some((eye, forward)) = self.camera {
            let c = to_svg(eye.truncate());
            let f = forward.truncate().try_normalize().unwrap_or(DVec2::X);
            let tip = to_svg(eye.truncate() + 0.4 * f);
            let _ = write!(
                s,
                r##"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="#000" stroke-width="2"/><circle cx="{:.1}" cy="{:.1}" r="6" fill="#000"/><text x="{:.1}" y="{:.1}">camera</text>"##,
                c.x,
                c.y,
                tip.x,
                tip.y,
                c.x,
                c.y,
                c.x + 8.0,
                c.y - 8.0
            );
        }
        s.push_str("</svg>");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_core::Pose;

    #[test]
    fn footprint_of_a_yawed_box_is_its_rotated_rectangle() {
        let pose = Pose::from_yaw_translation(0.5, DVec3::new(1.0, 2.0, 0.3));
        let obb = OrientedBox::new(pose, DVec3::new(2.0, 1.0, 0.6));
        let f = footprint(&obb);
        assert_eq!(f.len(), 4);
        let area = 0.5 * (0..4).map(|i| f[i].perp_dot(f[(i + 1) % 4])).sum::<f64>();
        assert!(
            (area - 2.0).abs() < 1e-9,
            "counter-clockwise, area 2: {area}"
        );
    }

    #[test]
    fn svg_holds_every_box_and_escapes_labels() {
        let obb = |x: f64| {
            OrientedBox::new(
                Pose::from_yaw_translation(0.0, DVec3::new(x, 1.0, 0.2)),
                DVec3::splat(0.4),
            )
        };
        let map = TopDown {
            room: (DVec2::ZERO, DVec2::new(4.0, 3.0)),
            solved: vec![MapBox {
                label: "a<b".into(),
                id: 1,
                obb: obb(1.0),
            }],
            truth: vec![
                MapBox {
                    label: "a".into(),
                    id: 1,
                    obb: obb(1.1),
                },
                MapBox {
                    label: "c".into(),
                    id: 2,
                    obb: obb(3.0),
                },
            ],
            camera: Some((DVec3::new(2.0, 1.5, 1.2), DVec3::X)),
        };
        let svg = map.svg();
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
        assert_eq!(svg.matches(r#"class="solved""#).count(), 1);
        assert_eq!(svg.matches(r#"class="truth""#).count(), 2);
        assert!(svg.contains("a&lt;b") && !svg.contains("a<b"));
        assert!(svg.contains("camera"));
    }
}
