//! `cargo xtask drive [SCENE]`: manual mode (issue 28) felt from the keyboard. The real
//! controller runs on the virtual bus with a crane that is not the model, in real time;
//! the keyboard is the operator's master switch; a terminal view draws the crane, the
//! load's swing, the levers, the controller's mode and the drives' set points.
//!
//! * [`engine`] — the firmware's controller of a scene with `[operator]` (built as the
//!   host's run of the firmware builds it), the virtual bus and the plant stepped one
//!   cycle at a time, fed the switch, giving a snapshot to draw (no terminal:
//!   unit-tested);
//! * [`switch`] — the master switch with notched levers the keys move;
//! * [`tui`] — the keys' meaning and the drawing (ratatui).
//!
//! Its own crate rather than a module of `host-tests`: the terminal crates (ratatui,
//! crossterm, and the pseudo-terminal its test drives) are then built only for it, not
//! for every host test and for xtask, which depend on `host-tests`.

pub mod engine;
pub mod switch;
pub mod tui;
