//! The HTML report in a real browser: headless Chromium opens the tiny room's report from disk, with
//! WebGL on the CPU (SwiftShader), and the 3D view must load and draw without a console error and
//! without fetching anything. Needs Debian's `chromium` (`apt-get install chromium`); run with
//! `cargo test -p neuroom -- --ignored chromium_`.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use neuroom::export::{ExportOptions, MeshDetail, export};
use neuroom_core::formats::{read_rgb, write_arrangement, write_rgb};
use neuroom_core::image::Image;
use neuroom_testing::{tiny_arrangement, write_tiny_models};

/// The browser window, in CSS pixels; the harness pins the 3D view over all of it.
const WINDOW: (u32, u32) = (800, 500);
/// The 3D view's background (`#eef1f4` in the report's style) in [0, 1] sRGB.
const BACKGROUND: [f32; 3] = [238.0 / 255.0, 241.0 / 255.0, 244.0 / 255.0];
/// The longest one Chromium run may take.
const DEADLINE: Duration = Duration::from_secs(180);

/// Put first into the report's `<head>`: records on `<html>`, as `data-*` attributes that `--dump-dom`
/// shows, every console error, uncaught error, unhandled rejection and failed load (`data-errors`); when
/// the 3D view has loaded (a `load` event reaches the document, not the window), `data-viewer`, what was fetched from anywhere but a `data:` URI
/// (`data-network`), and where the compare slider puts its line after being moved to 20 (`data-cut`).
/// Its style pins the 3D view over the whole window for the screenshot.
const HARNESS: &str = r#"<script>
(() => {
  const root = document.documentElement;
  const note = (text) => { root.dataset.errors = (root.dataset.errors || '') + text + ' | '; };
  const consoleError = console.error.bind(console);
  console.error = (...args) => { note('console.error: ' + args.join(' ')); consoleError(...args); };
  addEventListener('unhandledrejection', (e) => note('unhandled rejection: ' + e.reason));
  addEventListener('error', (e) => {
    const t = e.target;
    if (t && t.localName === 'model-viewer') note('model-viewer: ' + (e.detail && e.detail.sourceError));
    else if (t instanceof Element) note('failed to load a ' + t.localName);
    else note('uncaught: ' + e.message);
  }, true);
  document.addEventListener('load', (e) => {
    if (e.target.localName !== 'model-viewer') return;
    root.dataset.viewer = 'loaded';
    root.dataset.network = performance.getEntriesByType('resource')
      .map((r) => r.name).filter((n) => !n.startsWith('data:')).join(' ');
    const range = document.querySelector('.compare input[type=range]');
    range.value = '20';
    range.dispatchEvent(new Event('input'));
    root.dataset.cut = range.parentNode.style.getPropertyValue('--cut');
  }, true);
})();
</script><style>model-viewer{position:fixed!important;left:0;top:0;z-index:10;
width:800px!important;height:500px!important;border:0!important}</style>"#;

/// Exports the tiny room's report (with an input panorama beside the arrangement) into `dir`.
fn write_tiny_report(dir: &Path) -> PathBuf {
    let models = dir.join("models");
    write_tiny_models(&models).unwrap();
    let arrangement = dir.join("solved.json");
    write_arrangement(&arrangement, &tiny_arrangement()).unwrap();
    write_rgb(
        dir.join("tiny.png"),
        &Image::filled(64, 32, [0.3, 0.5, 0.7]),
    )
    .unwrap();
    let options = ExportOptions {
        report: Some(dir.join("report.html")),
        report_detail: MeshDetail {
            object_cell_m: 0.05,
            room_cell_m: 0.2,
            ..MeshDetail::default()
        },
        render_width: 64,
        views: 1,
        ..ExportOptions::default()
    };
    export(&models, &arrangement, &options, &mut |_| {})
        .unwrap()
        .report
        .unwrap()
}

/// What one headless Chromium run left: the DOM after the virtual time budget, and its log.
struct Run {
    dom: String,
    log: String,
}

/// Opens `page` in headless Chromium with WebGL on SwiftShader, dumps its DOM and screenshots the window
/// into `shot`. Panics, naming what is missing, where there is no `chromium`.
fn run_chromium(work: &Path, page: &Path, shot: &Path) -> Run {
    let (dom_path, log_path) = (work.join("dom.html"), work.join("chromium.log"));
    let mut child = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=30000",
            "--dump-dom",
        ])
        .arg(format!("--window-size={},{}", WINDOW.0, WINDOW.1))
        .arg(format!("--user-data-dir={}", work.join("profile").display()))
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", page.display()))
        .stdout(File::create(&dom_path).unwrap())
        .stderr(File::create(&log_path).unwrap())
        .spawn()
        .unwrap_or_else(|e| {
            panic!("cannot run `chromium` ({e}): this test needs Debian's chromium (apt-get install chromium)")
        });
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > DEADLINE {
            let _ = child.kill();
            panic!("chromium took over {DEADLINE:?} on {}", page.display());
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    Run {
        dom: std::fs::read_to_string(dom_path).unwrap(),
        log: std::fs::read_to_string(log_path).unwrap(),
    }
}

/// The attributes of the dumped DOM's `<html>` element (values with `&quot;` and `&amp;` undone).
fn root_attributes(dom: &str) -> Vec<(String, String)> {
    let start = dom.find("<html").expect("an <html> element") + "<html".len();
    let mut rest = &dom[start..];
    let mut out = Vec::new();
    loop {
        rest = rest.trim_start();
        if rest.starts_with('>') || rest.is_empty() {
            return out;
        }
        let name_end = rest.find(['=', ' ', '>']).unwrap();
        let name = rest[..name_end].to_string();
        rest = &rest[name_end..];
        let Some(quoted) = rest.strip_prefix("=\"") else {
            out.push((name, String::new()));
            continue;
        };
        let end = quoted.find('"').unwrap();
        let value = quoted[..end].replace("&quot;", "\"").replace("&amp;", "&");
        out.push((name, value));
        rest = &quoted[end + 1..];
    }
}

/// The share of the screenshot's pixels below its top 10 rows (the view's loading bar) that differ
/// from the 3D view's background.
fn drawn_share(shot: &Path) -> f64 {
    let image = read_rgb(shot).unwrap().image;
    assert_eq!((image.width, image.height), WINDOW, "the screenshot's size");
    let below_bar = &image.data[10 * image.width as usize..];
    let drawn = below_bar
        .iter()
        .filter(|p| (0..3).any(|c| (p[c] - BACKGROUND[c]).abs() > 0.08))
        .count();
    drawn as f64 / below_bar.len() as f64
}

#[test]
#[ignore = "needs Debian's chromium (apt-get install chromium); .ci/run runs it where chromium is installed"]
fn chromium_report_draws_the_3d_view_without_console_errors() {
    let dir = tempfile::tempdir().unwrap();
    let report = std::fs::read_to_string(write_tiny_report(dir.path())).unwrap();
    let head = report.find("<head>").unwrap() + "<head>".len();
    let page = dir.path().join("harnessed.html");
    std::fs::write(
        &page,
        format!("{}{HARNESS}{}", &report[..head], &report[head..]),
    )
    .unwrap();
    let shot = dir.path().join("shot.png");
    let run = run_chromium(dir.path(), &page, &shot);
    let console: Vec<&str> = run.log.lines().filter(|l| l.contains("CONSOLE")).collect();
    let attributes = root_attributes(&run.dom);
    let attribute = |name: &str| {
        attributes
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    };
    assert_eq!(
        attribute("data-errors"),
        None,
        "errors in the page; its console: {console:#?}"
    );
    assert_eq!(
        attribute("data-viewer"),
        Some("loaded"),
        "the 3D view did not load; the page's console: {console:#?}"
    );
    assert_eq!(
        attribute("data-network"),
        Some(""),
        "fetched from outside the page"
    );
    assert_eq!(
        attribute("data-cut"),
        Some("20%"),
        "the slider moves the line"
    );
    let drawn = drawn_share(&shot);
    assert!(
        drawn > 0.05,
        "only {:.1} % of the 3D view differs from its background",
        100.0 * drawn
    );
}
