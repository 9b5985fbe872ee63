//! The page: one self-contained HTML file (style and figures inline, nothing loaded
//! from elsewhere) and each figure again as an SVG file beside it. A line of script at
//! the end counts the figures the browser parsed into `data-figures` on `<body>`, next
//! to `data-expected`: the headless browser check compares the two.

use std::fmt::Write as _;
use std::path::Path;

use super::figures::{histogram, time_series, Figure, Panel};
use super::load::{POSITION_TARGET, SWING_TARGET_DEG};
use super::requests::Kind;
use super::timing::{BIN_MS, SPAN_MS};
use super::{Extras, Summary};

/// Text for HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Seconds as milliseconds, or "—" where the log gave no number.
fn ms(v: Option<f64>, digits: usize) -> String {
    v.map_or("—".into(), |v| format!("{:.digits$}", v * 1e3))
}

fn opt(v: Option<f64>, unit: &str, scale: f64, digits: usize) -> String {
    v.map_or("—".into(), |v| format!("{:.digits$} {unit}", v * scale))
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1000px;margin:2em auto;color:#222}\
table{border-collapse:collapse;margin:0.5em 0 1em}td,th{border:1px solid #ccc;padding:2px 6px;\
font-size:90%;text-align:left;vertical-align:top}th{background:#f0f0f0}.bad{color:#b00}\
.ok{color:#070}figure{margin:1em 0}figcaption{font-size:90%;color:#555}pre{font-size:85%}";

/// Writes `index.html` and the figures' SVG files into `out`.
pub fn write(out: &Path, s: &Summary, x: &Extras) -> Result<(), String> {
    let figures = figures(s, x)?;
    let mut h = String::new();
    let w = &mut h;
    let _ = write!(
        w,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>Crane report: {}</title>\
         <style>{STYLE}</style></head><body data-expected=\"{}\">",
        esc(&s.log),
        figures.len()
    );
    let _ = write!(
        w,
        "<h1>Crane report</h1><table><tr><th>log</th><td>{}</td></tr><tr><th>format</th><td>{}</td></tr>\
         <tr><th>crane</th><td>{} (scene {}, its commissioning file beside it)</td></tr>\
         <tr><th>frames</th><td>{} over {:.2} s</td></tr></table>",
        esc(&s.log),
        s.format,
        s.crane,
        esc(&s.scene),
        s.read.frames,
        s.duration
    );
    input_section(w, s);
    network_section(w, s, x);
    requests_section(w, s, x.crane.controller);
    let mut figs = figures.iter();
    let _ = write!(w, "<h2>Drives</h2>");
    drives_section(w, s, &mut figs);
    let _ = write!(w, "<h2>The load</h2>");
    load_section(w, s, &mut figs);
    faults_section(w, s);
    let _ = write!(w, "<h2>Timing</h2>");
    timing_section(w, s, &mut figs);
    let _ = writeln!(
        w,
        "<script>document.body.setAttribute('data-figures',String(document.querySelectorAll('figure svg').length));</script></body></html>"
    );
    let path = out.join("index.html");
    std::fs::write(&path, h).map_err(|e| format!("{}: {e}", path.display()))?;
    for f in &figures {
        let path = out.join(&f.file);
        std::fs::write(&path, &f.svg).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(())
}

/// "… and N more …" after a list the report kept to its first entries.
fn more(list: &mut Vec<String>, dropped: u64, what: &str) {
    if dropped > 0 {
        list.push(format!("… and {dropped} more {what}"));
    }
}

fn figure(w: &mut String, f: Option<&Figure>) {
    if let Some(f) = f {
        // The SVG's own XML declaration does not belong inside HTML.
        let svg = f.svg.find("<svg").map_or(f.svg.as_str(), |i| &f.svg[i..]);
        let _ = write!(
            w,
            "<figure>{svg}<figcaption>{} (<a href=\"{}\">{}</a>)</figcaption></figure>",
            esc(&f.title),
            f.file,
            f.file
        );
    }
}

fn figures(s: &Summary, x: &Extras) -> Result<Vec<Figure>, String> {
    let mut out = Vec::new();
    for d in &x.drives.drives {
        let v = d.velocity_limit;
        out.push(time_series(
            &format!("drive-{}.svg", d.name),
            &format!("The {} drive (node {}): set point and velocity actual, position actual, following error", d.name, d.node),
            &[
                Panel {
                    title: &format!("{}: velocity", d.name),
                    y_label: "m/s",
                    curves: vec![
                        ("set point (RPDO1 0x60FF)".into(), d.setpoint.points().to_vec()),
                        ("velocity actual (TPDO1 0x606C)".into(), d.velocity.points().to_vec()),
                    ],
                    limits: vec![(format!("+limit {v} m/s"), v), (format!("−limit {v} m/s"), -v)],
                },
                Panel {
                    title: &format!("{}: position actual (TPDO2 0x6064)", d.name),
                    y_label: "m",
                    curves: vec![("position".into(), d.position.points().to_vec())],
                    limits: vec![],
                },
                Panel {
                    title: &format!("{}: following error (set point applied − velocity actual)", d.name),
                    y_label: "m/s",
                    curves: vec![("error".into(), d.error.points().to_vec())],
                    limits: vec![],
                },
            ],
        )?);
    }
    let planes = x.load.planes();
    let names = if planes == 2 {
        [
            "α, x–z plane (slope long16)",
            "β, y–z plane (slope lateral16)",
        ]
    } else {
        ["φ (slope long16)", ""]
    };
    let swing: Vec<_> = (0..planes)
        .map(|p| (names[p].to_string(), x.load.swing[p].points().to_vec()))
        .collect();
    let horizontal: Vec<_> = if planes == 2 {
        vec![
            ("x_C".to_string(), x.load.position[0].points().to_vec()),
            ("y_C".to_string(), x.load.position[1].points().to_vec()),
        ]
    } else {
        vec![("x_C".to_string(), x.load.position[0].points().to_vec())]
    };
    let targets: Vec<(String, f64)> = s
        .moves
        .items
        .iter()
        .flat_map(|m| {
            let n = m.target.len();
            m.target[..n - 1]
                .iter()
                .enumerate()
                .map(move |(i, v)| (format!("target {} of move {}", ["x", "y"][i], m.id), *v))
        })
        .take(6)
        .collect();
    out.push(time_series(
        "load.svg",
        "The load: swing from the inclinometer, position from the drives and the swing",
        &[
            Panel {
                title: "swing",
                y_label: "°",
                curves: swing,
                limits: vec![
                    (format!("+{SWING_TARGET_DEG}°"), SWING_TARGET_DEG),
                    (format!("−{SWING_TARGET_DEG}°"), -SWING_TARGET_DEG),
                ],
            },
            Panel {
                title: "load position, horizontal",
                y_label: "m",
                curves: horizontal,
                limits: targets,
            },
            Panel {
                title: "load depth z_C below the rail",
                y_label: "m",
                curves: vec![("z_C".into(), x.load.position[2].points().to_vec())],
                limits: s
                    .moves
                    .items
                    .iter()
                    .filter_map(|m| {
                        m.target
                            .last()
                            .map(|z| (format!("target z of move {}", m.id), *z))
                    })
                    .take(3)
                    .collect(),
            },
        ],
    )?);
    let bins: Vec<(f64, f64, u64)> = s
        .timing
        .histogram
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let lo = -SPAN_MS + i as f64 * BIN_MS;
            (lo, lo + BIN_MS, *n)
        })
        .collect();
    out.push(histogram(
        "sync-jitter.svg",
        "SYNC jitter: each interval less the cycle (the outer bins take the rest)",
        "interval − cycle, ms",
        &bins,
    )?);
    out.push(time_series(
        "sync-intervals.svg",
        "SYNC intervals over the log",
        &[Panel {
            title: "SYNC interval",
            y_label: "ms",
            curves: vec![("interval".into(), s.timing.intervals.points().to_vec())],
            limits: vec![("cycle".into(), s.timing.period * 1e3)],
        }],
    )?);
    Ok(out)
}

fn input_section(w: &mut String, s: &Summary) {
    let _ = write!(w, "<h2>What the log holds</h2><table>");
    let d = &s.decoding;
    let rows = [
        ("lines read", s.read.lines, ""),
        ("frames decoded by the DBC", d.decoded, ""),
        (
            "unreadable lines (truncated, garbled, too long)",
            s.read.unreadable,
            "bad",
        ),
        (
            "frames with an id the DBC does not have",
            d.unknown_ids.values().sum::<u64>() + d.unknown_other,
            "bad",
        ),
        (
            "frames the DBC has but cannot decode",
            d.undecodable.values().map(|v| v.0).sum(),
            "bad",
        ),
        (
            "other lines (an ASC header, events, comments): skipped",
            s.read.other_lines,
            "",
        ),
        ("error frames", s.read.error_frames, "bad"),
        ("CAN FD frames (not analysed)", s.read.fd_frames, ""),
        ("remote frames", d.remote, ""),
        ("extended-id frames", d.extended, ""),
        (
            "frames whose time stamp runs backwards",
            s.read.backwards,
            "bad",
        ),
    ];
    for (what, n, class) in rows {
        let class = if n > 0 { class } else { "" };
        let _ = write!(w, "<tr><th>{what}</th><td class=\"{class}\">{n}</td></tr>");
    }
    let _ = write!(w, "</table>");
    if !s.read.quoted.is_empty() {
        let _ = write!(w, "<p>Unreadable lines (the first):</p><pre>");
        for (n, line) in &s.read.quoted {
            let _ = writeln!(w, "line {n}: {}", esc(line));
        }
        let _ = write!(w, "</pre>");
    }
    if !d.unknown_ids.is_empty() {
        let list: Vec<String> = d
            .unknown_ids
            .iter()
            .map(|(id, n)| format!("{id} ×{n}"))
            .collect();
        let _ = write!(
            w,
            "<p>Ids the DBC does not have: {}{}</p>",
            list.join(", "),
            if d.unknown_other > 0 {
                format!(", and {} frames of other ids", d.unknown_other)
            } else {
                String::new()
            }
        );
    }
    if !d.undecodable.is_empty() {
        let _ = write!(w, "<p>Frames the DBC cannot decode:</p><ul>");
        for (id, (n, why)) in &d.undecodable {
            let _ = write!(w, "<li>{id} ×{n}: {}</li>", esc(why));
        }
        let _ = write!(w, "</ul>");
    }
    if !s.controller_heard || !s.two_controllers.is_empty() {
        let _ = write!(
            w,
            "<p class=\"bad\"><b>{}</b></p>",
            if s.controller_heard {
                "Two controllers on one bus?"
            } else {
                "No controller traffic in this log."
            }
        );
    }
    if !s.two_controllers.is_empty() {
        let _ = write!(w, "<ul>");
        for t in &s.two_controllers {
            let _ = write!(w, "<li class=\"bad\">{}</li>", esc(t));
        }
        let _ = write!(w, "</ul>");
    }
    let _ = write!(w, "<h3>What this log cannot answer</h3><ul>");
    for c in &s.cannot_answer {
        let _ = write!(w, "<li>{}</li>", esc(c));
    }
    let _ = write!(w, "</ul>");
}

fn network_section(w: &mut String, s: &Summary, x: &Extras) {
    let _ = write!(
        w,
        "<h2>Network</h2><table><tr><th>node</th><th>frames sent</th><th>first – last, s</th><th>boot-ups, s</th>\
         <th>heartbeats</th><th>interval mean / max, ms</th><th>gaps over {:.0} ms</th><th>age at the end, ms</th><th>NMT states</th></tr>",
        x.crane.heartbeat_timeout * 1e3
    );
    for (node, n) in &s.nodes {
        let mut states: Vec<String> = n
            .states
            .items
            .iter()
            .map(|(t, st)| format!("{st} ({t:.2})"))
            .collect();
        more(&mut states, n.states.dropped, "changes");
        let mut boots: Vec<String> = n.boot_ups.items.iter().map(|t| format!("{t:.2}")).collect();
        more(&mut boots, n.boot_ups.dropped, "boot-ups");
        let mut gaps: Vec<String> = n
            .heartbeat_gaps
            .items
            .iter()
            .map(|(t, g)| format!("{:.0} ms before {t:.2} s", g * 1e3))
            .collect();
        more(&mut gaps, n.heartbeat_gaps.dropped, "gaps");
        let interval = if n.heartbeat_interval.count > 0 {
            format!(
                "{:.1} / {:.1}",
                n.heartbeat_interval.mean * 1e3,
                n.heartbeat_interval.max * 1e3
            )
        } else {
            "—".into()
        };
        let _ = write!(
            w,
            "<tr><td>{}</td><td>{}</td><td>{:.2} – {:.2}</td><td>{}</td><td>{}</td><td>{interval}</td><td class=\"{}\">{}</td><td>{}</td><td>{}</td></tr>",
            esc(&x.crane.node_name(*node)),
            n.frames,
            n.first,
            n.last,
            if boots.is_empty() { "—".into() } else { boots.join(", ") },
            n.heartbeats,
            if gaps.is_empty() { "" } else { "bad" },
            if gaps.is_empty() { "none".into() } else { gaps.join("; ") },
            n.last_heartbeat.map_or("—".into(), |t| format!("{:.0}", (s.duration - t) * 1e3)),
            esc(&states.join(" → "))
        );
    }
    let _ = write!(w, "</table>");
    let missing: Vec<String> = x
        .crane
        .drives
        .iter()
        .map(|d| d.node)
        .chain([x.crane.controller])
        .filter(|n| !s.nodes.contains_key(n))
        .map(|n| x.crane.node_name(n))
        .collect();
    if !missing.is_empty() {
        let _ = write!(
            w,
            "<p class=\"bad\">Not heard in this log: {}.</p>",
            esc(&missing.join(", "))
        );
    }
    let _ = write!(w, "<h3>NMT commands</h3>");
    if s.nmt.items.is_empty() {
        let _ = write!(w, "<p>None in this log.</p>");
    } else {
        let list: Vec<String> = s
            .nmt
            .items
            .iter()
            .map(|c| {
                format!(
                    "{:.2} s {} → {}",
                    c.t,
                    c.command,
                    if c.node == 0 {
                        "all nodes".into()
                    } else {
                        x.crane.node_name(c.node)
                    }
                )
            })
            .collect();
        let items: Vec<String> = list
            .iter()
            .map(|l| format!("<li>{}</li>", esc(l)))
            .collect();
        let _ = write!(w, "<ul>{}</ul>", items.concat());
    }
    let _ = write!(
        w,
        "<h3>SDO transcripts (commissioning), objects named from the EDS</h3>"
    );
    if x.network.sdo.is_empty() {
        let _ = write!(w, "<p>No SDO traffic in this log.</p>");
    }
    for (node, c) in &x.network.sdo {
        let eds = x
            .network
            .eds_of(*node)
            .map_or("no EDS: objects by number".into(), |e| {
                format!("EDS {}", e.file)
            });
        let _ = write!(
            w,
            "<details><summary>{} — {} exchanges, {} aborts ({})</summary><pre>",
            esc(&x.crane.node_name(*node)),
            c.exchanges,
            c.aborts,
            esc(&eds)
        );
        for l in &c.lines {
            let times = if l.repeated > 1 {
                format!(" (×{})", l.repeated)
            } else {
                String::new()
            };
            let line = format!("{:8.3} s  {}{times}", l.t, l.text);
            if l.abort {
                let _ = writeln!(w, "<span class=\"bad\">{}</span>", esc(&line));
            } else {
                let _ = writeln!(w, "{}", esc(&line));
            }
        }
        if c.dropped > 0 {
            let _ = writeln!(w, "… and {} more exchanges", c.dropped);
        }
        let _ = write!(w, "</pre></details>");
    }
}

fn requests_section(w: &mut String, s: &Summary, controller: u8) {
    let manual = 0x400 + u16::from(controller);
    let _ = write!(w, "<h2>Requests and answers</h2>");
    if s.requests.items.is_empty() {
        let _ = write!(w, "<p>No request in this log.</p>");
    } else {
        let _ = write!(
            w,
            "<table><tr><th>s</th><th>id</th><th>request</th><th>answers (s)</th></tr>"
        );
        for r in &s.requests.items {
            let what = match &r.kind {
                Kind::Move { target, duration } => format!(
                    "move to ({}) m {}",
                    target
                        .iter()
                        .map(|v| format!("{v:.3}"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    duration.map_or("as fast as the limits allow".into(), |d| format!(
                        "in {d} s"
                    ))
                ),
                Kind::Stop => "stop".into(),
                Kind::Reset => "reset".into(),
                Kind::BySdo(c) => format!("written into 0x2000, command {c}"),
                Kind::Malformed(m) => format!("malformed (ignored and counted): {m}"),
            };
            let answers: Vec<String> = r
                .answers
                .iter()
                .map(|(t, a, reason)| {
                    if reason == "None" {
                        format!("{a} ({t:.2})")
                    } else {
                        format!("{a}, reason {reason} ({t:.2})")
                    }
                })
                .collect();
            let class = if r.answers.iter().any(|a| a.1 == "Rejected") {
                "bad"
            } else {
                ""
            };
            let answers = if answers.is_empty() {
                if matches!(r.kind, Kind::Malformed(_)) {
                    "— (not answered: ignored)".into()
                } else {
                    "<span class=\"bad\">no answer in the log</span>".to_string()
                }
            } else {
                esc(&answers.join("; "))
            };
            let _ = write!(
                w,
                "<tr><td>{:.2}</td><td>{}</td><td>{}</td><td class=\"{class}\">{answers}</td></tr>",
                r.t,
                r.id,
                esc(&what)
            );
        }
        let _ = write!(w, "</table>");
        if s.requests.dropped > 0 {
            let _ = write!(w, "<p>… and {} more requests.</p>", s.requests.dropped);
        }
    }
    if !s.unasked.items.is_empty() {
        let list: Vec<String> = s
            .unasked
            .items
            .iter()
            .map(|(t, id, a, r)| format!("{t:.2} s id {id}: {a} {r}"))
            .collect();
        let _ = write!(
            w,
            "<p>Answers to requests not in the log: {}</p>",
            esc(&list.join("; "))
        );
    }
    let _ = write!(w, "<h3>Modes and faults (status byte 3 and 4)</h3>");
    let modes: Vec<String> = s
        .modes
        .items
        .iter()
        .map(|(t, m, f)| {
            format!(
                "{t:.2} s {m}{}",
                if f == "None" {
                    String::new()
                } else {
                    format!(" (fault {f})")
                }
            )
        })
        .collect();
    let _ = write!(
        w,
        "<p>{}</p>",
        if modes.is_empty() {
            "No status frame in this log.".into()
        } else {
            esc(&modes.join(" → "))
        }
    );
    let stops = s
        .requests
        .items
        .iter()
        .filter(|r| r.kind == Kind::Stop)
        .count();
    let _ = write!(w, "<p>Stops requested: {stops}.</p>");
    let _ = write!(
        w,
        "<h3>Manual mode</h3><p>{}</p>",
        if s.manual_frames == 0 {
            format!("No manual-mode frames (0x{manual:03X}) in this log.")
        } else {
            format!(
                "{} manual-mode frames (0x{manual:03X}): counted; their sessions are not analysed yet.",
                s.manual_frames
            )
        }
    );
    let _ = write!(w, "<h3>The controller's counters (status bytes 5–7)</h3>");
    match s.last_counters {
        Some([ignored, misses, tx]) => {
            let _ = write!(w, "<p>At the end: frames ignored {ignored}, deadline misses {misses}, transmit failures {tx}.</p>");
        }
        None => {
            let _ = write!(w, "<p>No status frame: not known.</p>");
        }
    }
    if !s.counters.items.is_empty() {
        let list: Vec<String> = s
            .counters
            .items
            .iter()
            .map(|(t, n, a, b)| format!("{t:.2} s {n} {a} → {b}"))
            .collect();
        let _ = write!(w, "<p>{}</p>", esc(&list.join("; ")));
    }
}

fn drives_section<'a>(w: &mut String, s: &Summary, figs: &mut impl Iterator<Item = &'a Figure>) {
    let _ = write!(w, "<table><tr><th>drive</th><th>set points</th><th>largest |set point|</th><th>over the velocity limit</th><th>largest step</th><th>over the acceleration limit</th><th>largest |velocity actual|</th><th>following error mean / max</th><th>position first → last</th></tr>");
    for d in &s.drives {
        let _ = write!(
            w,
            "<tr><td>{} (node {})</td><td>{}</td><td>{} (limit {})</td><td class=\"{}\">{}</td><td>{} (limit {})</td><td class=\"{}\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            d.name, d.node, d.setpoints, opt(d.max_setpoint, "m/s", 1.0, 4), d.velocity_limit,
            if d.over_velocity > 0 { "bad" } else { "" }, d.over_velocity,
            opt(d.max_acceleration, "m/s²", 1.0, 3), d.acceleration_limit,
            if d.over_acceleration > 0 { "bad" } else { "" }, d.over_acceleration,
            opt(d.max_velocity, "m/s", 1.0, 4),
            if d.following_error.count > 0 { format!("{:.4} / {:.4} m/s", d.following_error.mean, d.following_error.max) } else { "—".into() },
            d.positions.map_or("—".into(), |(a, b)| format!("{a:.4} → {b:.4} m")),
        );
    }
    let _ = write!(w, "</table>");
    for d in &s.drives {
        figure(w, figs.next());
        let states: Vec<String> = d
            .states
            .items
            .iter()
            .map(|(t, st, sw)| format!("{st} [0x{sw:04X}] ({t:.2})"))
            .collect();
        let cws: Vec<String> = d
            .controlwords
            .items
            .iter()
            .map(|(t, c)| format!("{c} ({t:.2})"))
            .collect();
        let modes: Vec<String> = d
            .modes
            .items
            .iter()
            .map(|(t, m)| format!("{m} ({t:.2})"))
            .collect();
        let _ = write!(
            w,
            "<p><b>{}</b> CiA 402 states: {}<br>controlwords sent: {}<br>mode display: {}</p>",
            d.name,
            esc(&if states.is_empty() {
                "no TPDO1".into()
            } else {
                states.join(" → ")
            }),
            esc(&if cws.is_empty() {
                "no RPDO1".into()
            } else {
                cws.join(" → ")
            }),
            esc(&if modes.is_empty() {
                "no TPDO2".into()
            } else {
                modes.join(" → ")
            }),
        );
    }
}

fn load_section<'a>(w: &mut String, s: &Summary, figs: &mut impl Iterator<Item = &'a Figure>) {
    let swing: Vec<String> = s
        .max_swing
        .iter()
        .map(|v| v.map_or("not measured".into(), |v| format!("{v:.3}°")))
        .collect();
    let _ = write!(
        w,
        "<p>Inclinometer readings: {}; largest swing {}; cycles without a fresh reading after the first: {}.</p>",
        s.inclinometer_readings,
        if s.inclinometer_readings == 0 { "not measured".into() } else { swing.join(", ") },
        s.stale_inclinometer_cycles
    );
    figure(w, figs.next());
    let _ = write!(
        w,
        "<h3>Moves: the verdict 5 s after each (docs/COMMANDS.md: within ±{:.0} mm horizontally, swinging less than {SWING_TARGET_DEG}°, set points zero at rest)</h3>",
        POSITION_TARGET * 1e3
    );
    if s.moves.items.is_empty() {
        let _ = write!(w, "<p>No move was accepted in this log.</p>");
        return;
    }
    let _ = write!(w, "<table><tr><th>id</th><th>target, m</th><th>accepted / start / end, s</th><th>end by</th><th>horizontal</th><th>vertical</th><th>swing</th><th>set points not zero</th><th>verdict</th></tr>");
    for m in &s.moves.items {
        let swing: Vec<String> = m
            .swing
            .iter()
            .map(|v| v.map_or("not measured".into(), |v| format!("{v:.3}°")))
            .collect();
        let class = if m.verdict.starts_with("FAIL") {
            "bad"
        } else if m.verdict.starts_with("pass") {
            "ok"
        } else {
            ""
        };
        let _ = write!(
            w,
            "<tr><td>{}</td><td>{}</td><td>{:.2} / {} / {}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{} of {}</td><td class=\"{class}\">{}</td></tr>",
            m.id,
            m.target.iter().map(|v| format!("{v:.3}")).collect::<Vec<_>>().join(", "),
            m.accepted,
            opt(m.start, "", 1.0, 2),
            opt(m.end, "", 1.0, 2),
            esc(&m.ended_by),
            opt(m.horizontal, "mm", 1e3, 1),
            opt(m.vertical, "mm", 1e3, 1),
            swing.join(", "),
            m.moving_cycles,
            m.cycles,
            esc(&m.verdict)
        );
    }
    let _ = write!(w, "</table>");
}

fn faults_section(w: &mut String, s: &Summary) {
    let _ = write!(w, "<h2>Faults and EMCYs</h2>");
    if s.emcys.items.is_empty() {
        let _ = write!(w, "<p>No EMCY in this log.</p>");
        return;
    }
    let _ = write!(w, "<p>Reactions documented: {}.</p><table><tr><th>s</th><th>from</th><th>code</th><th>error register</th><th>manufacturer bytes</th><th>meaning</th><th>documented reaction</th><th>reaction taken (status)</th></tr>", esc(&s.reactions_source));
    for e in &s.emcys.items {
        let bits = if e.register_bits.is_empty() {
            "none set".to_string()
        } else {
            e.register_bits.join(", ")
        };
        let _ = write!(
            w,
            "<tr><td>{:.2}</td><td>{}</td><td>0x{:04X}</td><td>0x{:02X}: {bits}{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            e.t,
            esc(&e.from),
            e.code,
            e.register,
            if e.warning { " (a warning: the generic bit clear)" } else { "" },
            esc(&e.manufacturer),
            esc(&e.meaning),
            esc(e.documented.as_deref().unwrap_or("—")),
            esc(if e.taken.is_empty() { "—" } else { &e.taken })
        );
    }
    let _ = write!(w, "</table>");
    if s.emcys.dropped > 0 {
        let _ = write!(w, "<p>… and {} more EMCYs.</p>", s.emcys.dropped);
    }
}

fn timing_section<'a>(w: &mut String, s: &Summary, figs: &mut impl Iterator<Item = &'a Figure>) {
    let t = &s.timing;
    let i = &t.interval;
    let _ = match t.syncs {
        0 => write!(w, "<p>SYNC: none in this log.</p>"),
        1 => write!(w, "<p>SYNC: one in this log, no interval to measure.</p>"),
        n => write!(
            w,
            "<p>SYNC: {n} seen; interval mean {} ms, standard deviation {} ms, min {} ms, max {} ms (cycle {:.1} ms); missed cycles {}; SYNCs less than half a cycle apart {}.</p>",
            ms(i.get(|i| i.mean), 3),
            ms((i.count > 1).then_some(i.std), 3),
            ms(i.get(|i| i.min), 3),
            ms(i.get(|i| i.max), 3),
            t.period * 1e3,
            t.missed_cycles,
            t.doubled_syncs
        ),
    };
    figure(w, figs.next());
    figure(w, figs.next());
    if !t.gaps.items.is_empty() {
        let mut list: Vec<String> = t
            .gaps
            .items
            .iter()
            .map(|(at, g)| format!("{:.1} ms before {at:.2} s", g * 1e3))
            .collect();
        more(&mut list, t.gaps.dropped, "gaps");
        let _ = write!(
            w,
            "<p class=\"bad\">Gaps of more than 1.5 cycles between two SYNCs: {}</p>",
            list.join("; ")
        );
    }
    let _ = write!(w, "<table><tr><th>drive</th><th>cycles with its RPDO before the SYNC</th><th>without</th><th>with two</th><th>TPDO1 gap mean / max, ms</th><th>TPDO2 gap max, ms</th><th>gaps over the TPDO timeout</th><th>TPDO1 after SYNC mean / max, ms</th></tr>");
    for ((d, order), tp) in s.drives.iter().zip(&t.rpdo_order).zip(&t.tpdo) {
        let _ = write!(
            w,
            "<tr><td>{}</td><td>{}</td><td class=\"{}\">{}</td><td class=\"{}\">{}</td><td>{} / {}</td><td>{}</td><td class=\"{}\">{}</td><td>{} / {}</td></tr>",
            d.name,
            order[0],
            if order[1] > 0 { "bad" } else { "" },
            order[1],
            if order[2] > 0 { "bad" } else { "" },
            order[2],
            ms(tp.tpdo1_gap.get(|g| g.mean), 2),
            ms(tp.tpdo1_gap.get(|g| g.max), 2),
            ms(tp.tpdo2_gap.get(|g| g.max), 2),
            if tp.over_timeout > 0 { "bad" } else { "" },
            tp.over_timeout,
            ms(tp.after_sync.get(|a| a.mean), 2),
            ms(tp.after_sync.get(|a| a.max), 2)
        );
    }
    let _ = write!(w, "</table>");
    match s.last_counters {
        Some([ignored, misses, tx]) => {
            let _ = write!(w, "<p>The controller counted {ignored} frames ignored, {misses} deadline misses and {tx} transmit failures (status bytes 5–7 at the end).</p>");
        }
        None => {
            let _ = write!(
                w,
                "<p>Frames the controller ignored: not known (no status frame).</p>"
            );
        }
    }
}
