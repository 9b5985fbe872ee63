//! The keyboard view as a person uses it: the real `drive` binary in a pseudo-terminal,
//! keys typed in, the screen parsed back (vt100). `m` asks for manual mode, three `→`
//! push the trolley's lever three notches, Space releases it, `q` quits: the screen
//! shows manual mode, the load moved the pushed way, the lever back at its centre; the
//! process exits 0 and leaves the terminal as it found it (the main screen, the cursor
//! shown, line editing and echo on again).
//!
//! Robust on a loaded machine: every step waits for what the screen shows, never for a
//! fixed time, with generous deadlines; the run itself takes a few seconds.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::io::{Read, Write};
use std::num::NonZeroU16;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use nix::sys::termios::LocalFlags;
use portable_pty::{native_pty_system, Child, CommandBuilder, MasterPty, PtySize};

/// How long any one thing may take to show on a loaded 2-core machine.
const PATIENCE: Duration = Duration::from_secs(60);

/// The view in a pseudo-terminal: what it wrote, parsed, and the raw bytes.
struct Pty {
    master: Box<dyn MasterPty + Send>,
    writer: Box<dyn Write + Send>,
    child: Box<dyn Child + Send + Sync>,
    parser: Arc<Mutex<vt100::Parser>>,
    raw: Arc<Mutex<Vec<u8>>>,
}

impl Pty {
    /// Starts the view on `scene` (relative to the repository's root) in a 120×36
    /// terminal.
    fn start(scene: &str) -> Self {
        let (rows, cols) = (36, 120);
        let pair = native_pty_system()
            .openpty(PtySize {
                rows,
                cols,
                pixel_width: 0,
                pixel_height: 0,
            })
            .unwrap();
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
        let mut cmd = CommandBuilder::new(env!("CARGO_BIN_EXE_drive"));
        cmd.arg(root.join(scene));
        cmd.cwd(&root);
        cmd.env("TERM", "xterm-256color");
        let child = pair.slave.spawn_command(cmd).unwrap();
        drop(pair.slave);
        let parser = Arc::new(Mutex::new(vt100::Parser::new(
            NonZeroU16::new(rows).unwrap(),
            NonZeroU16::new(cols).unwrap(),
            0,
        )));
        let raw = Arc::new(Mutex::new(Vec::new()));
        let mut reader = pair.master.try_clone_reader().unwrap();
        {
            let (parser, raw) = (Arc::clone(&parser), Arc::clone(&raw));
            std::thread::spawn(move || {
                let mut buf = [0u8; 8192];
                while let Ok(n) = reader.read(&mut buf) {
                    if n == 0 {
                        break;
                    }
                    let bytes = &buf[..n];
                    parser.lock().unwrap().process(bytes);
                    raw.lock().unwrap().extend_from_slice(bytes);
                }
            });
        }
        let writer = pair.master.take_writer().unwrap();
        Self {
            master: pair.master,
            writer,
            child,
            parser,
            raw,
        }
    }

    fn screen(&self) -> String {
        self.parser.lock().unwrap().screen().contents()
    }

    fn keys(&mut self, bytes: &[u8]) {
        self.writer.write_all(bytes).unwrap();
        self.writer.flush().unwrap();
    }

    /// Waits until the screen satisfies `ok`, failing with `what` and the screen after
    /// [`PATIENCE`] (or if the view exits before).
    fn wait_for(&mut self, what: &str, ok: impl Fn(&str) -> bool) -> String {
        let start = Instant::now();
        loop {
            let screen = self.screen();
            if ok(&screen) {
                return screen;
            }
            if let Some(status) = self.child.try_wait().unwrap() {
                panic!("the view exited ({status:?}) waiting for {what}; screen:\n{screen}");
            }
            assert!(
                start.elapsed() < PATIENCE,
                "no {what} after {PATIENCE:?}; screen:\n{screen}"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// The number after `label` on the screen (`load x 12.345 m` → 12.345).
fn number_after(screen: &str, label: &str) -> Option<f64> {
    let rest = &screen[screen.find(label)? + label.len()..];
    rest.split_whitespace().next()?.parse().ok()
}

#[test]
fn the_keyboard_drives_the_planar_crane_in_manual_mode_and_quits_cleanly() {
    let started = Instant::now();
    let mut pty = Pty::start("scenes/paper-crane-manual-feedback.toml");
    pty.wait_for("mode 1 Ready", |s| s.contains("mode 1 Ready"));
    pty.keys(b"m");
    let screen = pty.wait_for("mode 5 Manual", |s| s.contains("mode 5 Manual"));
    let x0 = number_after(&screen, "load x").expect("the load's x on the screen");
    // Three notches right: the trolley lever at +3 of 4.
    pty.keys(b"\x1b[C\x1b[C\x1b[C");
    pty.wait_for("the lever at +3/4", |s| s.contains("trolley +3/4"));
    let pushed = Instant::now();
    // About 2 s of motion, and the load seen moving right.
    pty.wait_for("the load moving right for 2 s", |s| {
        pushed.elapsed() > Duration::from_secs(2)
            && number_after(s, "load x").is_some_and(|x| x > x0 + 0.05)
    });
    pty.keys(b" ");
    let released = pty.wait_for("the lever centred", |s| s.contains("trolley +0/4"));
    assert!(
        released.contains("mode 5 Manual"),
        "still in manual mode:\n{released}"
    );
    // The load goes on to the released stop's end: wait until it has travelled on.
    let x_release = number_after(&released, "load x").unwrap();
    let screen = pty.wait_for("the load stopping", |s| {
        number_after(s, "load x").is_some_and(|x| x > x_release + 0.05)
    });
    let x1 = number_after(&screen, "load x").unwrap();
    assert!(x1 > x0 + 0.1, "the load moved right: {x0} → {x1} m");
    assert!(screen.contains("trolley +0/4 ....#...."), "lever centred");
    pty.keys(b"q");
    let deadline = Instant::now() + PATIENCE;
    let status = loop {
        if let Some(status) = pty.child.try_wait().unwrap() {
            break status;
        }
        assert!(Instant::now() < deadline, "the view did not quit");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(status.success(), "exit status {status:?}");
    // The terminal restored: line editing and echo on again (raw mode left), the main
    // screen back, the cursor shown.
    let termios = pty.master.get_termios().expect("the pty's termios");
    assert!(
        termios
            .local_flags
            .contains(LocalFlags::ICANON | LocalFlags::ECHO),
        "raw mode left: {:?}",
        termios.local_flags
    );
    // The reader has the last bytes once the child's side is closed.
    let deadline = Instant::now() + PATIENCE;
    while !pty.screen().contains("drive: left after") {
        assert!(
            Instant::now() < deadline,
            "no farewell line:\n{}",
            pty.screen()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let parser = pty.parser.lock().unwrap();
    assert!(!parser.screen().alternate_screen(), "the main screen back");
    assert!(!parser.screen().hide_cursor(), "the cursor shown");
    let raw = pty.raw.lock().unwrap();
    let leave = b"\x1b[?1049l";
    assert!(
        raw.windows(leave.len()).any(|w| w == leave),
        "the alternate screen left"
    );
    println!(
        "load x {x0:.3} → {x1:.3} m; the whole run took {:.1} s",
        started.elapsed().as_secs_f64()
    );
}
