//! The design report printed to PDF in headless Chromium (DevTools `Page.printToPDF`
//! through chromedriver): it lays out on several A4 pages with its tables.
//!
//! Skips like the page's browser test (`browser.rs`) when chromium is missing, unless
//! `RELIGHT_REQUIRE_BROWSER=1`; holds `common::alone()`.

use std::path::Path;

use serde_json::json;

use crate::browser::{base64_decode, find_driver, open_session, serve};
use crate::common;

/// The office alone, in its own folder (its bake cached beside the browser test's).
fn office() -> (std::path::PathBuf, std::path::PathBuf) {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-pdf");
    let dst = root.join("scenes").join("office");
    std::fs::create_dir_all(&dst).unwrap();
    for f in std::fs::read_dir(common::scenes_dir().join("office")).unwrap() {
        let f = f.unwrap();
        if f.file_type().unwrap().is_file() {
            std::fs::copy(f.path(), dst.join(f.file_name())).unwrap();
        }
    }
    (root.join("scenes"), root.join("cache"))
}

/// Count of `needle` in `hay`.
fn count(hay: &[u8], needle: &[u8]) -> usize {
    hay.windows(needle.len()).filter(|w| *w == needle).count()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_report_prints_to_a_pdf_of_several_pages() {
    let Some((driver_bin, browser_bin)) = find_driver() else {
        let msg = "chromium/chromedriver not found (apt-get install chromium chromium-driver)";
        if std::env::var("RELIGHT_REQUIRE_BROWSER").as_deref() == Ok("1") {
            panic!("{msg}");
        }
        eprintln!("SKIPPED the report PDF test: {msg}");
        return;
    };
    let _gate = common::alone();
    let (scenes, cache) = office();
    let (site, server) = serve(scenes, cache).await;
    let (s, _driver, _profile) = open_session(&driver_bin, &browser_bin).await;
    let url = format!("{site}/api/scenes/office/report?light.window_row=0.8&project=PDF%20test");
    s.post("/url", json!({ "url": url })).await;
    s.wait_for(
        "document.readyState === 'complete' && document.querySelectorAll('img.view').length === 2 \
         && [...document.images].every((i) => i.complete && i.naturalWidth > 0)",
        "the report and its images",
    )
    .await;
    // The page's own tables, as laid out.
    let tables = s
        .js("return document.querySelectorAll('table').length;")
        .await;
    assert!(tables.as_u64().unwrap() >= 5, "tables: {tables}");
    let pdf = s
        .post(
            "/goog/cdp/execute",
            json!({"cmd": "Page.printToPDF", "params": {
                "paperWidth": 8.27, "paperHeight": 11.69, "preferCSSPageSize": true,
                "printBackground": true, "generateTaggedPDF": true,
                "generateDocumentOutline": true}}),
        )
        .await;
    let bytes = base64_decode(pdf["data"].as_str().expect("PDF data"));
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-pdf/office-report.pdf");
    std::fs::write(&out, &bytes).unwrap();
    assert!(bytes.starts_with(b"%PDF-"), "not a PDF");
    // `/Type /Page` also starts `/Type /Pages`: count the pages alone.
    let pages = count(&bytes, b"/Type /Page") - count(&bytes, b"/Type /Pages");
    eprintln!(
        "office report PDF: {pages} pages, {} bytes ({})",
        bytes.len(),
        out.display()
    );
    // Title and schedule, one page per grid (2), assumptions, the views.
    assert!(pages >= 5, "{pages} pages");
    assert!(
        bytes.len() > 100_000,
        "{} bytes: the images are missing",
        bytes.len()
    );
    // The tagged PDF's structure holds the tables (/S /Table) and header cells.
    assert!(count(&bytes, b"/S /Table") >= 5, "tables in the structure");
    assert!(
        count(&bytes, b"/S /TH") >= 10,
        "header cells in the structure"
    );
    // The outline holds the headings as text (the page text itself is compressed).
    for heading in [
        "(Luminaire schedule)",
        "(Power)",
        "(Desk \\(task area\\))",
        "(Work plane at 0.75 m)",
        "(Reflectances of the main surfaces)",
        "(Relit views)",
    ] {
        assert!(
            count(&bytes, heading.as_bytes()) >= 1,
            "no heading {heading}"
        );
    }
    s.cmd(reqwest::Method::DELETE, "", serde_json::Value::Null)
        .await;
    server.abort();
}
