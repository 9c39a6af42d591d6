//! The offline HTML report: one self-contained page (images inlined as base64 data, the map as inline
//! SVG, no scripts, no network) that any browser opens from disk.

use std::fmt::Write as _;

use base64::Engine as _;
use neuroom_core::image::RgbImage;

use crate::animation::to_u8;
use crate::topdown::escape;

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
    /// Images side by side.
    Figures(Vec<Figure>),
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

const STYLE: &str = "body{font-family:sans-serif;margin:2em;max-width:1200px;color:#222}\
figure{display:inline-block;margin:0 1em 1em 0;vertical-align:top}\
figure img{max-width:560px;width:100%;border:1px solid #ccc;image-rendering:auto}\
figcaption{font-size:90%;color:#555}\
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
        for (heading, section) in &self.sections {
            let _ = writeln!(s, "<h2>{}</h2>", escape(heading));
            section.write_html(&mut s);
        }
        s.push_str("</body></html>\n");
        s
    }
}

impl Section {
    fn write_html(&self, s: &mut String) {
        match self {
            Section::Text(t) => {
                let _ = writeln!(s, "<p>{}</p>", escape(t));
            }
            Section::Figures(figures) => {
                for f in figures {
                    let data = base64::engine::general_purpose::STANDARD.encode(&f.bytes);
                    let _ = writeln!(
                        s,
                        "<figure><img alt=\"{}\" src=\"data:{};base64,{data}\"><figcaption>{}</figcaption></figure>",
                        escape(&f.caption),
                        f.mime,
                        escape(&f.caption)
                    );
                }
            }
            Section::Svg { svg, caption } => {
                let _ = writeln!(
                    s,
                    "<figure>{svg}<figcaption>{}</figcaption></figure>",
                    escape(caption)
                );
            }
            Section::Table(t) => {
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
        }
    }
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
    }
}
