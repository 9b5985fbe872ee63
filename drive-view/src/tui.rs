//! The terminal side of the view: what each key means on the master switch, and the
//! picture of one [`Snapshot`] — the crane (planar: the side view; 3D: the top view and
//! the hoist beside it), the controller's mode from its status frame and why manual
//! mode is not running when it is asked for, the set points, the load and its swing,
//! the levers and the keys' legend. Simple and legible: every quantity is also written
//! as a number.

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::Color;
use ratatui::symbols::Marker;
use ratatui::text::Line as TextLine;
use ratatui::widgets::canvas::{Canvas, Line, Rectangle};
use ratatui::widgets::{Block, Paragraph};
use ratatui::Frame;

use crate::engine::{CraneInfo, CraneKind, Snapshot};
use crate::switch::{Action, Axis, MasterSwitch, NOTCHES};

/// The master switch's meaning of a key: ←/→ the x lever (planar: trolley; 3D: bridge),
/// ↑/↓ the y lever (3D: trolley), Page Down/Up the hoist (lower/raise), Space centres
/// every lever, `m` the manual request, `d` the dead-man, `s` a stop request, `q`, Esc
/// or Ctrl-C quits. Key releases (sent by some terminals) mean nothing.
#[must_use]
pub fn action(key: KeyEvent) -> Option<Action> {
    if key.kind == KeyEventKind::Release {
        return None;
    }
    Some(match key.code {
        KeyCode::Right => Action::Notch(Axis::X, 1),
        KeyCode::Left => Action::Notch(Axis::X, -1),
        KeyCode::Up => Action::Notch(Axis::Y, 1),
        KeyCode::Down => Action::Notch(Axis::Y, -1),
        KeyCode::PageDown => Action::Notch(Axis::Z, 1),
        KeyCode::PageUp => Action::Notch(Axis::Z, -1),
        KeyCode::Char(' ') => Action::Centre,
        KeyCode::Char('c') if key.modifiers.contains(KeyModifiers::CONTROL) => Action::Quit,
        KeyCode::Char('m') => Action::ToggleManual,
        KeyCode::Char('d') => Action::ToggleEnable,
        KeyCode::Char('s') => Action::Stop,
        KeyCode::Char('q') | KeyCode::Esc => Action::Quit,
        _ => return None,
    })
}

/// The status frame's mode byte by name (docs/COMMANDS.md, the status frame).
#[must_use]
pub fn mode_name(code: u8) -> &'static str {
    match code {
        0 => "Enabling",
        1 => "Ready",
        2 => "Stopping",
        3 => "Quick stop",
        4 => "Halted",
        5 => "Manual",
        _ => "unknown",
    }
}

/// Why manual mode does not run although the switch asks for it: the controller's own
/// reason when it refused (EMCY 0xFF21), else what the status frame and the switch tell;
/// `None` when it runs or is not asked for.
#[must_use]
pub fn why_not_manual(snapshot: &Snapshot, switch: &MasterSwitch) -> Option<String> {
    if !switch.manual || snapshot.manual() {
        return None;
    }
    let Some(status) = snapshot.status else {
        return Some("no status frame yet".into());
    };
    let [_, _, _, mode, fault, ..] = status;
    if let Some(reason) = snapshot.refused {
        return Some(match reason {
            1 => "refused: this scene follows plans only".into(),
            2 => format!("refused: not ready ({}, fault {fault})", mode_name(mode)),
            3 => "refused: the generator cannot take the load from here".into(),
            r => format!("refused (reason {r})"),
        });
    }
    Some(match mode {
        0 => "the drives are still being enabled".into(),
        2..=4 => format!(
            "the controller is not ready: {} (fault {fault})",
            mode_name(mode)
        ),
        _ if !switch.enable => "the dead-man is not held (d)".into(),
        _ => "waits for the automatic move's rest (a lever deflected takes it over)".into(),
    })
}

/// Draws `snapshot` with the switch and the crane's fixed facts.
pub fn draw(frame: &mut Frame, snapshot: &Snapshot, switch: &MasterSwitch, info: &CraneInfo) {
    let [title, crane, panels, keys] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(8),
        Constraint::Length(8),
        Constraint::Length(2),
    ])
    .areas(frame.area());
    let kind = match info.kind {
        CraneKind::Planar => "planar crane",
        CraneKind::Spatial => "3D crane",
    };
    let closed = if info.feedback {
        "state feedback"
    } else {
        "feedforward only"
    };
    frame.render_widget(
        Paragraph::new(format!(
            "cargo xtask drive: {} ({kind}, plant not the model, {closed})   t = {:.1} s",
            info.scene, snapshot.t
        )),
        title,
    );
    match info.kind {
        CraneKind::Planar => side_view(frame, crane, snapshot, info),
        CraneKind::Spatial => {
            let [top, hoist] =
                Layout::horizontal([Constraint::Min(20), Constraint::Length(16)]).areas(crane);
            top_view(frame, top, snapshot, info);
            hoist_bar(frame, hoist, snapshot, info);
        }
    }
    let [controller, load, levers] = Layout::horizontal([
        Constraint::Percentage(38),
        Constraint::Percentage(36),
        Constraint::Percentage(26),
    ])
    .areas(panels);
    frame.render_widget(controller_panel(snapshot, switch, info), controller);
    frame.render_widget(load_panel(snapshot, info), load);
    frame.render_widget(lever_panel(switch, info), levers);
    let y_keys = if info.kind == CraneKind::Spatial {
        "  ↑/↓ trolley"
    } else {
        ""
    };
    let x_name = axis_names(info)[0];
    frame.render_widget(
        Paragraph::new(vec![
            TextLine::from(format!(
                "keys: ←/→ {x_name}{y_keys}  PgDn/PgUp lower/raise  Space release (centre)  \
                 one press = one notch of {NOTCHES}"
            )),
            TextLine::from("      m manual request  d dead-man  s stop request (0x210)  q quit"),
        ]),
        keys,
    );
}

/// The directions' names: the drives each moves the load with.
fn axis_names(info: &CraneInfo) -> [&'static str; 3] {
    match info.kind {
        CraneKind::Planar => ["trolley", "-", "hoist"],
        CraneKind::Spatial => ["bridge", "trolley", "hoist"],
    }
}

fn controller_panel<'a>(
    snapshot: &Snapshot,
    switch: &MasterSwitch,
    info: &CraneInfo,
) -> Paragraph<'a> {
    let mode = match snapshot.status {
        Some(s) => format!("mode {} {}", s[3], mode_name(s[3])),
        None => "mode - (no status frame yet)".into(),
    };
    let fault = snapshot.status.map_or(0, |s| s[4]);
    let yes = |b: bool| if b { "yes" } else { "no" };
    let mut lines = vec![
        TextLine::from(format!("{mode}   fault {fault}")),
        TextLine::from(format!(
            "manual asked {}   dead-man held {}",
            yes(switch.manual),
            yes(switch.enable)
        )),
    ];
    lines.push(TextLine::from(match why_not_manual(snapshot, switch) {
        Some(why) => format!("not manual: {why}"),
        None => String::new(),
    }));
    let names = axis_names(info);
    let [x, y, z] = snapshot.setpoints;
    lines.push(TextLine::from("the drives' set points, m/s:"));
    match info.kind {
        CraneKind::Planar => {
            lines.push(TextLine::from(format!(
                "  {} {x:+.3}  {} {z:+.3}",
                names[0], names[2]
            )));
        }
        CraneKind::Spatial => {
            lines.push(TextLine::from(format!(
                "  {} {x:+.3}  {} {y:+.3}",
                names[0], names[1]
            )));
            lines.push(TextLine::from(format!("  {} {z:+.3}", names[2])));
        }
    }
    Paragraph::new(lines).block(Block::bordered().title("Controller"))
}

fn load_panel<'a>(snapshot: &Snapshot, info: &CraneInfo) -> Paragraph<'a> {
    let [x, y, z] = snapshot.plant.load;
    let [sx, sy] = snapshot.swing_deg();
    let (position, swing) = match info.kind {
        CraneKind::Planar => (format!("load x {x:.3} m"), format!("swing {sx:+.3} deg")),
        CraneKind::Spatial => (
            format!("load x {x:.3} y {y:.3} m"),
            format!("swing x-z {sx:+.3}  y-z {sy:+.3} deg"),
        ),
    };
    let lines = vec![
        TextLine::from(position),
        TextLine::from(format!("depth {z:.3} m")),
        TextLine::from(format!(
            "speed {:.3} m/s, vertical {:+.3}",
            snapshot.horizontal_speed(),
            snapshot.load_velocity[2]
        )),
        TextLine::from(swing),
    ];
    Paragraph::new(lines).block(Block::bordered().title("Load (the plant)"))
}

/// One lever as text: its notch and a bar with the centre marked.
fn lever_line(name: &str, notch: i8) -> TextLine<'static> {
    let n = usize::from(NOTCHES.unsigned_abs());
    let at = usize::try_from(i16::from(notch) + i16::from(NOTCHES)).unwrap_or(n);
    let bar: String = (0..=2 * n)
        .map(|i| {
            if i == at {
                '#'
            } else if i == n {
                '|'
            } else {
                '.'
            }
        })
        .collect();
    TextLine::from(format!("{name:<7} {notch:+}/{NOTCHES} {bar}"))
}

fn lever_panel<'a>(switch: &MasterSwitch, info: &CraneInfo) -> Paragraph<'a> {
    let names = axis_names(info);
    let [x, y, z] = switch.levers;
    let mut lines = vec![lever_line(names[0], x)];
    if info.kind == CraneKind::Spatial {
        lines.push(lever_line(names[1], y));
    }
    lines.push(lever_line(names[2], z));
    Paragraph::new(lines).block(Block::bordered().title("Levers"))
}

/// A range padded by `pad` on both sides, as canvas bounds.
fn padded((lo, hi): (f64, f64), pad: f64) -> [f64; 2] {
    [lo - pad, hi + pad]
}

/// What each picture of the crane is made of, in its own coordinates: the rail (or the
/// beam) the carriage runs on, the carriage, the rope, the load.
struct Picture {
    rail: Line,
    carriage: Rectangle,
    rope: Line,
    load: Rectangle,
}

/// Draws `picture` in `area` under `title`, with the canvas's bounds.
fn render(frame: &mut Frame, area: Rect, title: &str, bounds: [[f64; 2]; 2], p: Picture) {
    let [x, y] = bounds;
    let canvas = Canvas::default()
        .block(Block::bordered().title(title))
        .marker(Marker::Braille)
        .x_bounds(x)
        .y_bounds(y)
        .paint(move |ctx| {
            ctx.draw(&p.rail);
            ctx.draw(&p.carriage);
            ctx.draw(&p.rope);
            ctx.draw(&p.load);
        });
    frame.render_widget(canvas, area);
}

/// The planar crane from the side: the rail, the trolley, the rope to the load.
fn side_view(frame: &mut Frame, area: Rect, snapshot: &Snapshot, info: &CraneInfo) {
    let [xr, _, lr] = info.ranges;
    let [xd, _, _] = snapshot.plant.drives;
    let [xc, _, zc] = snapshot.plant.load;
    let picture = Picture {
        rail: Line::new(xr.0, 0.0, xr.1, 0.0, Color::Gray),
        carriage: Rectangle::new(xd - 0.6, 0.0, 1.2, 0.6, Color::Yellow),
        rope: Line::new(xd, 0.0, xc, -zc, Color::White),
        load: Rectangle::new(xc - 0.4, -zc - 0.6, 0.8, 0.6, Color::Cyan),
    };
    let bounds = [padded(xr, 1.0), [-(lr.1 + 1.5), 1.0]];
    render(
        frame,
        area,
        "Side view (x right, depth down)",
        bounds,
        picture,
    );
}

/// The 3D crane from above: the bridge across the hall, the trolley on it, the load.
fn top_view(frame: &mut Frame, area: Rect, snapshot: &Snapshot, info: &CraneInfo) {
    let [xr, yr, _] = info.ranges;
    let [xd, yd, _] = snapshot.plant.drives;
    let [xc, yc, _] = snapshot.plant.load;
    let picture = Picture {
        rail: Line::new(xd, yr.0, xd, yr.1, Color::Gray),
        carriage: Rectangle::new(xd - 0.4, yd - 0.4, 0.8, 0.8, Color::Yellow),
        rope: Line::new(xd, yd, xc, yc, Color::White),
        load: Rectangle::new(xc - 0.2, yc - 0.2, 0.4, 0.4, Color::Cyan),
    };
    let bounds = [padded(xr, 1.0), padded(yr, 1.0)];
    let title = "Top view (x bridge right, y trolley up)";
    render(frame, area, title, bounds, picture);
}

/// The 3D crane's hoist: the load's depth below the trolley.
fn hoist_bar(frame: &mut Frame, area: Rect, snapshot: &Snapshot, info: &CraneInfo) {
    let [_, _, lr] = info.ranges;
    let [_, _, zc] = snapshot.plant.load;
    let picture = Picture {
        rail: Line::new(0.1, 0.0, 0.9, 0.0, Color::Gray),
        carriage: Rectangle::new(0.4, 0.0, 0.2, 0.3, Color::Yellow),
        rope: Line::new(0.5, 0.0, 0.5, -zc, Color::White),
        load: Rectangle::new(0.3, -zc - 0.5, 0.4, 0.5, Color::Cyan),
    };
    render(
        frame,
        area,
        "Hoist",
        [[0.0, 1.0], [-(lr.1 + 1.0), 0.5]],
        picture,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crossterm::event::KeyEventState;

    fn key(code: KeyCode) -> KeyEvent {
        KeyEvent {
            code,
            modifiers: KeyModifiers::NONE,
            kind: KeyEventKind::Press,
            state: KeyEventState::NONE,
        }
    }

    #[test]
    fn the_keys_move_the_levers_and_quit() {
        assert_eq!(action(key(KeyCode::Right)), Some(Action::Notch(Axis::X, 1)));
        assert_eq!(
            action(key(KeyCode::PageDown)),
            Some(Action::Notch(Axis::Z, 1)),
            "page down lowers the load"
        );
        assert_eq!(action(key(KeyCode::Char(' '))), Some(Action::Centre));
        assert_eq!(action(key(KeyCode::Esc)), Some(Action::Quit));
        let ctrl_c = KeyEvent {
            modifiers: KeyModifiers::CONTROL,
            ..key(KeyCode::Char('c'))
        };
        assert_eq!(action(ctrl_c), Some(Action::Quit));
        let release = KeyEvent {
            kind: KeyEventKind::Release,
            ..key(KeyCode::Right)
        };
        assert_eq!(action(release), None);
        assert_eq!(action(key(KeyCode::Char('x'))), None);
    }

    #[test]
    fn a_lever_is_drawn_at_its_notch_with_the_centre_marked() {
        assert_eq!(
            lever_line("trolley", 0).to_string(),
            "trolley +0/4 ....#...."
        );
        assert_eq!(
            lever_line("hoist", -4).to_string(),
            "hoist   -4/4 #...|...."
        );
        assert_eq!(
            lever_line("bridge", 3).to_string(),
            "bridge  +3/4 ....|..#."
        );
    }

    #[test]
    fn why_manual_mode_does_not_run_is_read_from_the_emcy_the_status_frame_and_the_switch() {
        use controller::Mode;
        use sim::simulated::TrueState;
        let snap = |status: Option<[u8; 8]>| Snapshot {
            t: 0.0,
            mode: Mode::Ready,
            status,
            refused: None,
            setpoints: [0.0; 3],
            feedforward: [0.0; 3],
            plant: TrueState {
                drives: [0.0; 3],
                load: [0.0; 3],
                swing: [0.0; 2],
            },
            load_velocity: [0.0; 3],
        };
        let mut switch = MasterSwitch::new(false);
        let ready = Some([0, 0, 0, 1, 0, 0, 0, 0]);
        assert_eq!(why_not_manual(&snap(ready), &switch), None, "not asked");
        switch.apply(Action::ToggleManual);
        let manual = Some([0, 0, 0, 5, 0, 0, 0, 0]);
        assert_eq!(why_not_manual(&snap(manual), &switch), None, "runs");
        let why = |status, switch: &MasterSwitch| why_not_manual(&snap(status), switch).unwrap();
        assert_eq!(why(None, &switch), "no status frame yet");
        assert_eq!(
            why(Some([0; 8]), &switch),
            "the drives are still being enabled"
        );
        assert_eq!(
            why(Some([0, 0, 0, 4, 7, 0, 0, 0]), &switch),
            "the controller is not ready: Halted (fault 7)"
        );
        assert!(why(ready, &switch).starts_with("waits for the automatic move's rest"));
        let refused = Snapshot {
            refused: Some(1),
            ..snap(ready)
        };
        assert_eq!(
            why_not_manual(&refused, &switch).unwrap(),
            "refused: this scene follows plans only"
        );
        switch.apply(Action::ToggleEnable);
        assert_eq!(why(ready, &switch), "the dead-man is not held (d)");
    }
}
