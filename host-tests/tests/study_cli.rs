//! The `study` commands run on small inputs, and their CSV columns are the ones
//! docs/RESULTS.md documents.

use std::path::{Path, PathBuf};
use std::process::Command;

use host_tests::sweep::CSV_HEADER;

fn study() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_study"));
    cmd.current_dir(root());
    cmd
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("study-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn csv(path: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines().map(split).collect()
}

/// Splits a CSV line (the failure column is quoted and contains no commas).
fn split(line: &str) -> Vec<String> {
    line.split(',')
        .map(|s| s.trim_matches('"').to_string())
        .collect()
}

#[test]
fn documented_csv_columns() {
    // docs/RESULTS.md documents exactly these columns; a change must change both.
    let docs = std::fs::read_to_string(root().join("docs/RESULTS.md")).unwrap();
    assert!(
        docs.contains(CSV_HEADER),
        "docs/RESULTS.md does not document the sweep columns `{CSV_HEADER}`"
    );
}

#[test]
fn sweep_writes_one_row_per_configuration() {
    let out = scratch("sweep").join("sweep.csv");
    let status = study()
        .args([
            "sweep",
            "scenes/paper-crane.toml",
            "--vary",
            "h=0.01|0.005,jacobian=exact|jt10",
            "--repeats",
            "1",
            "--out",
        ])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let rows = csv(&out);
    assert_eq!(rows[0].join(","), CSV_HEADER);
    assert_eq!(rows.len(), 5, "4 configurations");
    let col = |name: &str| rows[0].iter().position(|c| c == name).unwrap();
    for row in &rows[1..] {
        assert_eq!(row[col("outcome")], "ok", "{row:?}");
        let e: f64 = row[col("e_max")].parse().unwrap();
        assert!(e > 1e-6 && e < 1e-2, "{row:?}");
        let ns: f64 = row[col("ns_per_step")].parse().unwrap();
        assert!(ns > 0.0, "{row:?}");
    }
    let hs: Vec<&str> = rows[1..].iter().map(|r| r[col("h")].as_str()).collect();
    assert_eq!(hs, ["0.01", "0.01", "0.005", "0.005"]);
}

#[test]
fn run_writes_the_time_series() {
    let out = scratch("run").join("series.csv");
    let output = study()
        .args(["run", "scenes/paper-crane.toml", "--csv"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(output.status.success());
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(text.contains("e_max") && text.contains("Newton"), "{text}");
    let rows = csv(&out);
    assert_eq!(rows[0], ["t", "u1", "u1_ref", "u2", "u2_ref", "error"]);
    assert_eq!(rows.len(), 1 + 1001);
}

#[test]
fn a_broken_scene_is_refused_naming_the_field() {
    let dir = scratch("broken");
    let text = std::fs::read_to_string(root().join("scenes/paper-crane.toml"))
        .unwrap()
        .replace("h = 0.01", "h = -0.01");
    let path = dir.join("broken.toml");
    std::fs::write(&path, text).unwrap();
    let output = study().arg("run").arg(&path).output().unwrap();
    assert!(!output.status.success());
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(err.contains("solver.h"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn paper_and_extremes_run_quick() {
    let dir = scratch("quick");
    for what in ["paper", "extremes"] {
        let status = study()
            .args([what, "--quick", "--out-dir"])
            .arg(&dir)
            .status()
            .unwrap();
        assert!(status.success(), "{what}");
    }
    for file in [
        "paper.md",
        "fig4-scaling.svg",
        "fig13-input-errors.csv",
        "extremes.csv",
        "extremes.md",
        "extremes-paper-crane.svg",
    ] {
        assert!(dir.join(file).exists(), "{file}");
    }
    // The map: every run ends with an outcome, none panics, no NaN where a run succeeded.
    let rows = csv(&dir.join("extremes.csv"));
    assert_eq!(rows[0].join(","), CSV_HEADER);
    let col = |name: &str| rows[0].iter().position(|c| c == name).unwrap();
    for row in &rows[1..] {
        let outcome = row[col("outcome")].as_str();
        assert!(
            [
                "ok",
                "inaccurate",
                "newton-failure",
                "non-finite",
                "refused"
            ]
            .contains(&outcome),
            "{row:?}"
        );
        if outcome == "ok" || outcome == "inaccurate" {
            assert!(
                row[col("e_max")].parse::<f64>().unwrap().is_finite(),
                "{row:?}"
            );
        }
    }
    assert!(rows[1..].iter().any(|r| r[col("outcome")] == "ok"));
}
