//! `drive [SCENE]` (run by `cargo xtask drive [SCENE]`): the keyboard view of manual
//! mode in the terminal, in real time. SCENE defaults to `scenes/paper-crane-manual-feedback.toml`; the
//! 3D crane is `scenes/crane3d/crane3d-manual-feedback.toml`; a scene without
//! `[operator]` is refused (its firmware has no manual mode).
//!
//! The terminal is put back as it was (raw mode off, the main screen, the cursor shown)
//! whichever way the view ends: quit, an error, or a panic.

use std::io::stdout;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use crossterm::cursor::Show;
use crossterm::event::{self, Event};
use crossterm::execute;
use drive_view::engine::{Engine, Snapshot};
use drive_view::switch::{Action, MasterSwitch};
use drive_view::tui;

/// The scene when none is named.
const DEFAULT_SCENE: &str = "scenes/paper-crane-manual-feedback.toml";

/// The picture is redrawn every this many controller cycles (every 50 ms at 100 Hz).
const DRAW_EVERY: u64 = 5;

fn main() -> ExitCode {
    let mut args = std::env::args_os().skip(1);
    let scene = PathBuf::from(args.next().unwrap_or_else(|| DEFAULT_SCENE.into()));
    if let Some(extra) = args.next() {
        eprintln!(
            "drive: one scene file only; also given {}",
            extra.to_string_lossy()
        );
        return ExitCode::FAILURE;
    }
    let engine = match Engine::for_scene(&scene) {
        Ok(e) => e,
        Err(e) => {
            eprintln!("drive: {e}");
            return ExitCode::FAILURE;
        }
    };
    // The cursor shown again if a panic ends the view (ratatui's hook, installed on top
    // of this one, leaves raw mode and the alternate screen first).
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let _ = execute!(stdout(), Show);
        hook(info);
    }));
    let mut terminal = match ratatui::try_init() {
        Ok(t) => t,
        Err(e) => {
            // Raw mode may be on already if the alternate screen was refused.
            ratatui::restore();
            eprintln!("drive: cannot set up the terminal: {e}");
            return ExitCode::FAILURE;
        }
    };
    let outcome = run(&mut terminal, engine);
    ratatui::restore();
    let _ = execute!(stdout(), Show);
    match outcome {
        Ok(last) => {
            let mode = last.status.map_or("-", |s| {
                tui::mode_name(s.get(3).copied().unwrap_or(u8::MAX))
            });
            println!(
                "drive: left after {:.1} s, mode {mode}, load at x {:.3} y {:.3} m, depth {:.3} m",
                last.t, last.plant.load[0], last.plant.load[1], last.plant.load[2]
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("drive: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The real-time loop: cycle k runs k periods after the start by the wall clock, the
/// keys pressed before it applied first; the picture every [`DRAW_EVERY`] cycles. A
/// cycle more than a period late (the machine stalled this process) moves the schedule
/// on from then instead of running the missed cycles back to back, so the controller's
/// time never runs ahead of the plant's wall clock by more than a period. Ends when the
/// operator quits; gives the last snapshot.
fn run(terminal: &mut ratatui::DefaultTerminal, mut engine: Engine) -> Result<Snapshot, String> {
    let mut switch = MasterSwitch::new(engine.has_y());
    let period = Duration::from_millis(u64::from(engine.period_ms()));
    let (mut anchor, mut anchor_k) = (Instant::now(), 0u64);
    let mut last = engine.cycle(&mut switch)?;
    for k in 1u64.. {
        let due = anchor + period * u32::try_from(k - anchor_k).unwrap_or(u32::MAX);
        loop {
            let now = Instant::now();
            if now >= due {
                break;
            }
            if !event::poll(due - now).map_err(|e| e.to_string())? {
                continue;
            }
            if let Event::Key(key) = event::read().map_err(|e| e.to_string())? {
                match tui::action(key) {
                    Some(Action::Quit) => return Ok(last),
                    Some(Action::Stop) => engine.request_stop(),
                    Some(a) => switch.apply(a),
                    None => {}
                }
            }
        }
        last = engine.cycle(&mut switch)?;
        let done = Instant::now();
        if done.saturating_duration_since(due) > period {
            (anchor, anchor_k) = (done, k);
        }
        if k % DRAW_EVERY == 0 {
            let info = engine.info();
            terminal
                .draw(|f| tui::draw(f, &last, &switch, info))
                .map_err(|e| e.to_string())?;
        }
    }
    Ok(last)
}
