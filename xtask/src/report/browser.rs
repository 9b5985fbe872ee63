//! The page in a real browser: Debian's chromium, headless, loads the report and dumps
//! its DOM; the page's own line of script has counted the figures the browser parsed
//! (`data-figures`), which must equal the figures written (`data-expected`), and the
//! browser's console must report no error.

use std::path::Path;
use std::process::Command;

use crate::setup;

/// Loads `page` in headless chromium (installed from Debian's packages if missing) with
/// a fresh profile; an error says what the browser saw.
pub fn check(page: &Path) -> Result<(), String> {
    setup::ensure_chromium()?;
    let profile = std::env::temp_dir().join(format!("report-chromium-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&profile);
    let url = format!(
        "file://{}",
        page.canonicalize()
            .map_err(|e| format!("{}: {e}", page.display()))?
            .display()
    );
    let out = Command::new("timeout")
        .arg("120")
        .arg(setup::CHROMIUM)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--no-first-run",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg("--dump-dom")
        .arg(&url)
        .output()
        .map_err(|e| format!("cannot start {}: {e}", setup::CHROMIUM))?;
    let _ = std::fs::remove_dir_all(&profile);
    let dom = String::from_utf8_lossy(&out.stdout);
    let log = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        return Err(format!("chromium failed on {url} ({}):\n{log}", out.status));
    }
    let attribute = |name: &str| {
        dom.split(&format!("{name}=\""))
            .nth(1)
            .and_then(|rest| rest.split('"').next())
            .map(str::to_string)
    };
    let (expected, parsed) = (attribute("data-expected"), attribute("data-figures"));
    let console: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("CONSOLE") || l.contains("Uncaught"))
        .collect();
    if expected.is_none() || expected != parsed || !console.is_empty() {
        return Err(format!(
            "{url} in chromium: figures written {expected:?}, parsed {parsed:?}; console: {console:?}"
        ));
    }
    eprintln!(
        "report: {url} loads in headless chromium: {} figures parsed, no console error",
        parsed.unwrap_or_default()
    );
    Ok(())
}
