//! The virtual ECU's command line as a user meets it (issue 32, case 7): `ecu --reference
//! … | head` ends quietly like other Unix tools (it panicked on the closed pipe, exit
//! status 101), and the lines it does print are the set points of the move.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Stdio};

fn ecu() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_ecu"));
    cmd.current_dir(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(".."));
    cmd
}

#[test]
fn the_reference_into_a_closed_pipe_ends_quietly() {
    for scene in [None, Some("scenes/crane3d/crane3d.toml")] {
        let spec = if scene.is_some() {
            "13,3.5,7,4"
        } else {
            "13,7.5,4"
        };
        let mut cmd = ecu();
        if let Some(scene) = scene {
            cmd.args(["--scene", scene]);
        }
        let mut child = cmd
            .args(["--reference", spec])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Like `| head -2`: two lines read, then the pipe closed.
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let mut lines = Vec::new();
        for _ in 0..2 {
            let mut line = String::new();
            out.read_line(&mut line).unwrap();
            lines.push(line);
        }
        drop(out);
        let output = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&output.stderr);
        assert!(!err.contains("panicked"), "{scene:?}: {err}");
        assert!(
            output.status.success(),
            "{scene:?}: {:?} {err}",
            output.status
        );
        // Each line: one integer set point per drive, µm/s.
        let drives = if scene.is_some() { 3 } else { 2 };
        for line in lines {
            let fields: Vec<i64> = line
                .split_whitespace()
                .map(|f| f.parse().unwrap())
                .collect();
            assert_eq!(fields.len(), drives, "{line:?}");
        }
    }
}
