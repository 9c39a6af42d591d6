//! The offline HTML report: one self-contained page that any browser opens from disk and that loads
//! nothing from the network. Images are inlined as base64 data and the map as inline SVG. Two images of
//! the same view (the input panorama and its re-render) can be overlaid under a slider: a range input
//! whose one-line `oninput` handler moves a CSS variable that clips the upper image. A glTF binary (the
//! solved room) is embedded as a data URI and shown in an interactive 3D view (drag to orbit, scroll or
//! pinch to zoom) by the `<model-viewer>` element of `@google/model-viewer` 4.4.0 (Apache-2.0; three.js
//! inside, MIT), vendored in `vendor/model-viewer/` and inlined as a module script once per page that
//! has a 3D view.

use std::fmt::Write as _;

use base64::Engine as _;
use neuroom_core::image::RgbImage;

use crate::animation::to_u8;
use crate::topdown::escape;

/// `dist/model-viewer.min.js` of `@google/model-viewer` 4.4.0, unchanged (`vendor/model-viewer/README.md`).
const MODEL_VIEWER_JS: &str = include_str!("../vendor/model-viewer/model-viewer.min.js");

/// The notice written before the inlined viewer script.
const MODEL_VIEWER_NOTICE: &str = "<!-- The 3D view: @google/model-viewer 4.4.0 (Apache-2.0), \
with three.js r183 (MIT) and Lit (BSD-3-Clause) inside; their licence headers are kept below. -->";

/// An image shown in the report.
#[derive(Clone, Debug)]
pub struct Figure {
    /// Caption under it.
    pub caption: String,
    /// MIME type of `bytes` (`image/png`, `image/jpeg`, `image/gif`).
    pub mime: &'static str,
    /// The encoded image.
    pub bytes: Vec<u8>,
}

impl Figure {
    /// A rendered image, encoded as an 8-bit PNG.
    pub fn png(caption: impl Into<String>, image: &RgbImage) -> anyhow::Result<Figure> {
        Ok(Figure {
            caption: caption.into(),
            mime: "image/png",
            bytes: encode_png(image)?,
        })
    }

    /// The image as a `data:` URI.
    fn data_uri(&self) -> String {
        data_uri(self.mime, &self.bytes)
    }
}

/// A table of text cells.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// Column titles.
    pub header: Vec<String>,
    /// Rows of cells, as many as columns.
    pub rows: Vec<Vec<String>>,
}

/// One section of the report.
#[derive(Clone, Debug)]
pub enum Section {
    /// A paragraph of text.
    Text(String),
    /// Images side by side, as wide as the page allows: one alone spans the page, two share it.
    Figures(Vec<Figure>),
    /// Two images of the same view overlaid at the page's width, with a slider: `before` shows left of
    /// the slider's line, `after` (stretched to `before`'s box) right of it.
    Compare {
        /// The image left of the line (e.g. the input panorama).
        before: Figure,
        /// The image right of the line (e.g. the solved scene rendered from the same camera).
        after: Figure,
        /// Caption under both.
        caption: String,
    },
    /// An interactive 3D view of a glTF binary embedded in the page: drag to orbit, scroll to zoom.
    Model3d {
        /// The `.glb` file's bytes.
        glb: Vec<u8>,
        /// Caption under the view.
        caption: String,
    },
    /// An inline SVG drawing with a caption.
    Svg {
        /// The `<svg>` element.
        svg: String,
        /// Caption under it.
        caption: String,
    },
    /// A table.
    Table(Table),
}

/// The whole report: a title and titled sections.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Page title.
    pub title: String,
    /// Sections in order, each with a heading.
    pub sections: Vec<(String, Section)>,
}

/// Encodes an sRGB image as an 8-bit RGB PNG.
pub fn encode_png(image: &RgbImage) -> anyhow::Result<Vec<u8>> {
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, image.width, image.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header()?;
        let bytes: Vec<u8> = image.data.iter().flatten().map(|&c| to_u8(c)).collect();
        writer.write_image_data(&bytes)?;
    }
    Ok(out)
}

/// `bytes` as a base64 `data:` URI of type `mime`.
fn data_uri(mime: &str, bytes: &[u8]) -> String {
    let data = base64::engine::general_purpose::STANDARD.encode(bytes);
    format!("data:{mime};base64,{data}")
}

const STYLE: &str = "body{font-family:sans-serif;margin:2em auto;padding:0 2em;max-width:1200px;color:#222}\
figure{margin:0 0 1em 0}\
figcaption{font-size:90%;color:#555}\
.figures{display:grid;grid-template-columns:repeat(auto-fit,minmax(min(100%,360px),1fr));gap:1em}\
.figures img,.compare img{display:block;width:100%;border:1px solid #ccc;box-sizing:border-box}\
.stack{position:relative}\
.stack .after{position:absolute;inset:0;height:100%;clip-path:inset(0 0 0 var(--cut))}\
.stack::after{content:'';position:absolute;top:0;bottom:0;left:var(--cut);border-left:2px solid #fff;box-shadow:0 0 3px #000}\
.compare input{width:100%;margin:.5em 0}\
model-viewer{display:block;width:100%;height:min(675px,56vw,85vh);background:#eef1f4;border:1px solid #ccc;box-sizing:border-box}\
table{border-collapse:collapse;margin-bottom:1em}\
td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}\
th{background:#eee}td:first-child,th:first-child{text-align:left}";

impl Report {
    /// The page as HTML text.
    pub fn html(&self) -> String {
        let mut s = String::new();
        let _ = write!(
            s,
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title><style>{STYLE}</style></head><body><h1>{}</h1>\n",
            escape(&self.title),
            escape(&self.title)
        );
        for (index, (heading, section)) in self.sections.iter().enumerate() {
            let _ = writeln!(s, "<h2>{}</h2>", escape(heading));
            section.write_html(index, &mut s);
        }
        if self.has_3d_view() {
            let _ = writeln!(
                s,
                "{MODEL_VIEWER_NOTICE}\n<script type=\"module\">{MODEL_VIEWER_JS}</script>"
            );
        }
        s.push_str("</body></html>\n");
        s
    }

    /// Whether some section needs the 3D viewer's script.
    fn has_3d_view(&self) -> bool {
        self.sections
            .iter()
            .any(|(_, section)| matches!(section, Section::Model3d { .. }))
    }
}

impl Section {
    /// Writes the section's HTML; `index` (its place in the report) keeps element ids unique.
    fn write_html(&self, index: usize, s: &mut String) {
        match self {
            Section::Text(t) => {
                let _ = writeln!(s, "<p>{}</p>", escape(t));
            }
            Section::Figures(figures) => write_figures(figures, s),
            Section::Compare {
                before,
                after,
                caption,
            } => write_compare(before, after, caption, s),
            Section::Model3d { glb, caption } => write_model_3d(index, glb, caption, s),
            Section::Svg { svg, caption } => {
                let _ = writeln!(
                    s,
                    "<figure>{svg}<figcaption>{}</figcaption></figure>",
                    escape(caption)
                );
            }
            Section::Table(t) => write_table(t, s),
        }
    }
}

/// Images side by side in a grid that gives each as much of the page's width as it can.
fn write_figures(figures: &[Figure], s: &mut String) {
    s.push_str("<div class=\"figures\">\n");
    for f in figures {
        let _ = writeln!(
            s,
            "<figure><img alt=\"{}\" src=\"{}\"><figcaption>{}</figcaption></figure>",
            escape(&f.caption),
            f.data_uri(),
            escape(&f.caption)
        );
    }
    s.push_str("</div>\n");
}

/// `after` stacked on `before`, clipped left of `--cut`, which the range input moves.
fn write_compare(before: &Figure, after: &Figure, caption: &str, s: &mut String) {
    let _ = writeln!(
        s,
        "<figure class=\"compare\" style=\"--cut:50%\"><div class=\"stack\">\
<img alt=\"{}\" src=\"{}\"><img class=\"after\" alt=\"{}\" src=\"{}\"></div>\
<input type=\"range\" min=\"0\" max=\"100\" value=\"50\" aria-label=\"where the line between the two images is\" \
oninput=\"this.parentNode.style.setProperty('--cut',this.value+'%')\">\
<figcaption>{}</figcaption></figure>",
        escape(&before.caption),
        before.data_uri(),
        escape(&after.caption),
        after.data_uri(),
        escape(caption)
    );
}

/// A `<model-viewer>` of the embedded `.glb`: orbit and zoom, colours as baked (no tone mapping), seen
/// from above at an angle; its id is `model-3d-{index}`.
fn write_model_3d(index: usize, glb: &[u8], caption: &str, s: &mut String) {
    let _ = writeln!(
        s,
        "<figure><model-viewer id=\"model-3d-{index}\" alt=\"{}\" src=\"{}\" camera-controls \
touch-action=\"pan-y\" loading=\"eager\" tone-mapping=\"none\" interaction-prompt=\"none\" \
camera-orbit=\"-30deg 55deg auto\"></model-viewer><figcaption>{}</figcaption></figure>",
        escape(caption),
        data_uri("model/gltf-binary", glb),
        escape(caption)
    );
}

/// A table with a header row.
fn write_table(t: &Table, s: &mut String) {
    s.push_str("<table><tr>");
    for h in &t.header {
        let _ = write!(s, "<th>{}</th>", escape(h));
    }
    s.push_str("</tr>\n");
    for row in &t.rows {
        s.push_str("<tr>");
        for c in row {
            let _ = write!(s, "<td>{}</td>", escape(c));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_core::image::Image;

    #[test]
    fn figures_are_inlined_as_decodable_png() {
        let img = Image::filled(5, 3, [0.2, 0.4, 0.6]);
        let report = Report {
            title: "Room <1>".into(),
            sections: vec![
                (
                    "Input".into(),
                    Section::Figures(vec![Figure::png("pano", &img).unwrap()]),
                ),
                (
                    "Metrics".into(),
                    Section::Table(Table {
                        header: vec!["object".into(), "IoU".into()],
                        rows: vec![vec!["chair".into(), "91.0 %".into()]],
                    }),
                ),
            ],
        };
        let html = report.html();
        assert!(html.contains("<title>Room &lt;1&gt;</title>"));
        assert!(
            !html.contains("http://") && !html.contains("https://"),
            "no network"
        );
        let start = html.find("base64,").unwrap() + 7;
        let end = start + html[start..].find('"').unwrap();
        let png = base64::engine::general_purpose::STANDARD
            .decode(&html[start..end])
            .unwrap();
        let decoder = png::Decoder::new(std::io::Cursor::new(png));
        let reader = decoder.read_info().unwrap();
        assert_eq!((reader.info().width, reader.info().height), (5, 3));
        assert!(html.contains("<td>91.0 %</td>"));
        assert!(!html.contains("<script"), "no 3D view, no script");
    }

    /// The base64 payload of the first `src="data:{mime};base64,…"` at or after `from`.
    fn payload(html: &str, mime: &str, from: usize) -> Vec<u8> {
        let marker = format!("src=\"data:{mime};base64,");
        let start = from + html[from..].find(&marker).unwrap() + marker.len();
        let end = start + html[start..].find('"').unwrap();
        base64::engine::general_purpose::STANDARD
            .decode(&html[start..end])
            .unwrap()
    }

    #[test]
    fn compare_stacks_the_two_images_under_a_slider() {
        let before = Figure::png("input", &Image::filled(8, 4, [0.1, 0.2, 0.3])).unwrap();
        let after = Figure::png("render", &Image::filled(4, 2, [0.7; 3])).unwrap();
        let report = Report {
            title: "compare".into(),
            sections: vec![(
                "Input and render".into(),
                Section::Compare {
                    before: before.clone(),
                    after: after.clone(),
                    caption: "drag <the> slider".into(),
                },
            )],
        };
        let html = report.html();
        let at = html.find("class=\"compare\"").unwrap();
        assert_eq!(payload(&html, "image/png", at), before.bytes);
        let upper = html.find("class=\"after\"").unwrap();
        assert_eq!(payload(&html, "image/png", upper), after.bytes);
        assert!(html.contains("<input type=\"range\""));
        assert!(html.contains("setProperty('--cut'"));
        assert!(html.contains("drag &lt;the&gt; slider"));
    }

    #[test]
    fn a_3d_view_embeds_the_glb_and_inlines_the_viewer_once() {
        let glb = b"glTF\x02\x00\x00\x00 a binary".to_vec();
        let view = |caption: &str| Section::Model3d {
            glb: glb.clone(),
            caption: caption.into(),
        };
        let report = Report {
            title: "3D".into(),
            sections: vec![("One".into(), view("one")), ("Two".into(), view("two"))],
        };
        let html = report.html();
        assert_eq!(payload(&html, "model/gltf-binary", 0), glb);
        assert!(html.contains("<model-viewer id=\"model-3d-0\""));
        assert!(html.contains("<model-viewer id=\"model-3d-1\""));
        assert_eq!(html.matches(MODEL_VIEWER_JS).count(), 1);
        let page = html.replace(MODEL_VIEWER_JS, "");
        assert!(
            !page.contains("http://") && !page.contains("https://"),
            "nothing from the network"
        );
        assert_eq!(page.matches("<script").count(), 1);
    }

    #[test]
    fn the_vendored_viewer_can_be_inlined() {
        let js = MODEL_VIEWER_JS.to_ascii_lowercase();
        assert!(
            !js.contains("<script") && !js.contains("</script"),
            "a script tag inside would end or nest the inline script"
        );
        assert!(MODEL_VIEWER_JS.contains("customElements.define(\"model-viewer\""));
        assert!(
            MODEL_VIEWER_JS.len() < 1_500_000,
            "{} bytes",
            MODEL_VIEWER_JS.len()
        );
    }
}
