//! Bad input, end to end: each case counted and shown in the report, never a crash; an
//! unreadable file or an unknown format a clear error.

use super::*;

/// A candump `-L` log of `lines` (without time stamps: one every 1 ms from 1000 s).
fn log(name: &str, lines: &[String]) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("report-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let text: String = lines
        .iter()
        .enumerate()
        .map(|(i, l)| format!("({:.6}) can0 {l}\n", 1000.0 + i as f64 * 0.001))
        .collect();
    let path = dir.join(format!("{name}.log"));
    std::fs::write(&path, text).unwrap();
    (path, dir.join("out"))
}

fn run(path: &Path, out: &Path) -> Result<Summary, String> {
    report(&Options {
        log: path.to_path_buf(),
        scene: root().join(DEFAULT_SCENE),
        out: out.to_path_buf(),
        eds: Vec::new(),
    })
}

/// Ten cycles of a healthy planar bus: RPDOs, SYNC, TPDOs, heartbeats, a status.
fn cycles(n: usize) -> Vec<String> {
    let mut lines = Vec::new();
    for k in 0..n {
        lines.push("201#0F0000000000".to_string());
        lines.push("202#0F0000000000".to_string());
        lines.push("080#".to_string());
        lines.push("181#37020000000000".chars().take(16).collect());
        lines.push("182#370200000000".to_string());
        lines.push("281#001BB70009".to_string());
        lines.push("282#00127A0009".to_string());
        if k % 10 == 0 {
            lines.push("710#05".to_string());
            lines.push("701#05".to_string());
            lines.push("702#05".to_string());
            lines.push("190#0000000100000000".to_string());
        }
    }
    lines
}

#[test]
fn truncated_lines_unknown_ids_and_undecodable_frames_are_counted_and_shown() {
    let mut lines = cycles(20);
    lines.insert(5, "21".to_string()); // "(t) can0 21": truncated
    lines.insert(9, "7FF#0102".to_string()); // an id the DBC does not have
    lines.insert(12, "181#01".to_string()); // TPDO1_Trolley of 1 byte
    lines.insert(14, "210#0102".to_string()); // a command frame of 2 bytes
    let (path, out) = log("bad", &lines);
    let s = run(&path, &out).unwrap();
    assert_eq!(s.read.unreadable, 1);
    assert_eq!(s.decoding.unknown_ids.get("0x7FF"), Some(&1));
    assert_eq!(s.decoding.undecodable.get("0x181").map(|u| u.0), Some(1));
    assert_eq!(s.decoding.undecodable.get("0x210").map(|u| u.0), Some(1));
    assert!(matches!(
        s.requests.items[0].kind,
        requests::Kind::Malformed(_)
    ));
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("0x7FF ×1"), "the unknown id is shown");
    assert!(
        page.contains("TPDO1_Trolley: 1 bytes, the DBC says 6"),
        "the undecodable frame is shown"
    );
    assert!(
        page.contains("line 6: (1000.005000) can0 21"),
        "the truncated line is quoted"
    );
    assert!(s.controller_heard && s.two_controllers.is_empty());
    assert_eq!(s.timing.syncs, 20);
    assert_eq!(s.timing.rpdo_order[0], [20, 0, 0]);
}

#[test]
fn a_log_without_the_controller_says_so() {
    let lines: Vec<String> = (0..50).map(|k| format!("70{}#05", 1 + k % 2)).collect();
    let (path, out) = log("silent", &lines);
    let s = run(&path, &out).unwrap();
    assert!(!s.controller_heard);
    assert!(
        s.cannot_answer[0].starts_with("no controller traffic in this log"),
        "{:?}",
        s.cannot_answer
    );
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("No controller traffic in this log."));
    assert!(page.contains("no manual-mode frames (0x410) in this log"));
}

#[test]
fn two_controllers_on_one_bus_are_shown() {
    // Two SYNC producers and two heartbeats with the controller's id, 1 ms apart.
    let mut lines = Vec::new();
    for _ in 0..30 {
        lines.extend([
            "080#".to_string(),
            "080#".to_string(),
            "710#05".to_string(),
            "710#05".to_string(),
        ]);
        lines.extend(std::iter::repeat_n("701#05".to_string(), 6));
    }
    let (path, out) = log("two", &lines);
    let s = run(&path, &out).unwrap();
    assert_eq!(s.two_controllers.len(), 2, "{:?}", s.two_controllers);
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(page.contains("Two controllers on one bus?"));
}

#[test]
fn a_request_and_its_answer_and_a_refusal_with_its_reason() {
    let mut lines = cycles(3);
    // Move id 5 to (13, 7.5) in 4 s; then id 6 to (30, 7.5): rejected, reason 4.
    lines.push("210#0501C832F81C9001".to_string());
    lines.push("190#0501000100000000".to_string());
    lines.push("210#0601307578F9001".chars().take(20).collect());
    lines.push("210#060130752C1D9001".to_string());
    lines.push("190#0603040100000000".to_string());
    lines.push("190#0603040100000000".to_string()); // the periodic status repeats it
    let (path, out) = log("requests", &lines);
    let s = run(&path, &out).unwrap();
    let answered: Vec<_> = s
        .requests
        .items
        .iter()
        .filter(|r| !matches!(r.kind, requests::Kind::Malformed(_)))
        .map(|r| {
            (
                r.id,
                r.answers
                    .iter()
                    .map(|a| (a.1.as_str(), a.2.as_str()))
                    .collect::<Vec<_>>(),
            )
        })
        .collect();
    assert_eq!(
        answered,
        [
            (5, vec![("Accepted", "None")]),
            (6, vec![("Rejected", "TrolleyWorkspace")])
        ]
    );
    assert_eq!(s.moves.items.len(), 1);
    assert!(
        s.moves.items[0].verdict.starts_with("not judged"),
        "{:?}",
        s.moves.items[0]
    );
}

#[test]
fn an_unreadable_file_or_an_unknown_format_is_an_error() {
    let e = run(Path::new("/no/such/log.log"), Path::new("/tmp/x")).unwrap_err();
    assert!(e.contains("/no/such/log.log"), "{e}");
    let (path, out) = log("junk", &[]);
    std::fs::write(&path, "this is not a CAN log\n").unwrap();
    let e = run(&path, &out).unwrap_err();
    assert!(e.contains("unknown format"), "{e}");
}

#[test]
fn an_emcy_shows_its_register_bits_and_manufacturer_bytes() {
    let mut lines = cycles(3);
    // The winch: continuous over current, register generic + current, five bytes of its
    // own; then a warning (generic bit clear).
    lines.push("082#1023030102030405".to_string());
    lines.push("082#0042081122334455".to_string());
    let (path, out) = log("emcy", &lines);
    let s = run(&path, &out).unwrap();
    let e = &s.emcys.items;
    assert_eq!(e.len(), 2, "{e:?}");
    assert_eq!(e[0].manufacturer, "01 02 03 04 05");
    assert_eq!(e[0].register_bits, ["generic", "current"]);
    assert!(!e[0].warning && e[1].warning);
    assert_eq!(e[1].register_bits, ["temperature"]);
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        page.contains("0x03: generic, current"),
        "the register's bits"
    );
    assert!(page.contains("01 02 03 04 05"), "the manufacturer bytes");
}

#[test]
fn the_reaction_to_a_fault_is_read_however_many_mode_changes_came_before() {
    // 600 changes of mode (more than the page lists), then the controller's EMCY for
    // the winch's fault, the quick stop and halted.
    let mut lines = cycles(1);
    for k in 0..600 {
        lines.push(format!("190#000000{:02X}00000000", k % 2));
    }
    lines.push("090#02FF810302000000".to_string());
    lines.push("190#0000000303000000".to_string());
    lines.push("190#0000000403000000".to_string());
    let (path, out) = log("reaction", &lines);
    let s = run(&path, &out).unwrap();
    assert!(s.modes.dropped > 0, "the modes' list is full");
    let e = s.emcys.items.iter().find(|e| e.node == 0x10).unwrap();
    assert_eq!(e.fault.as_deref(), Some("DriveFault"));
    assert!(
        e.taken.contains("QuickStop") && e.taken.contains("Halted"),
        "{}",
        e.taken
    );
}

#[test]
fn the_report_names_the_repository_s_files_by_relative_paths() {
    // The committed example's summary.json is compared byte for byte on every machine:
    // no path of this checkout may be in it.
    let (path, out) = log("paths", &cycles(2));
    let s = run(&path, &out).unwrap();
    assert_eq!(s.reactions_source, "the fault table of docs/COMMANDS.md");
    assert_eq!(s.scene, DEFAULT_SCENE);
    let json = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    let checkout = root().display().to_string();
    assert!(!json.contains(&checkout) && !page.contains(&checkout));
}

#[test]
fn no_number_is_shown_where_the_log_has_none() {
    // Heartbeats only: no set point, no velocity, no SYNC, no TPDO, no inclinometer.
    let lines: Vec<String> = (0..30).map(|k| format!("70{}#05", 1 + k % 2)).collect();
    let (path, out) = log("nothing", &lines);
    run(&path, &out).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["max_swing"], serde_json::json!([null]));
    for d in json["drives"].as_array().unwrap() {
        for key in ["max_setpoint", "max_acceleration", "max_velocity"] {
            assert!(d[key].is_null(), "{key}: {}", d[key]);
        }
    }
    let interval = &json["timing"]["interval"];
    assert_eq!(interval["count"], 0);
    assert!(
        interval["mean"].is_null() && interval["max"].is_null(),
        "{interval}"
    );
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    for number in ["0.0000 m/s", "0.000 m/s²", "mean 0.000 ms", "0.00 / 0.00"] {
        assert!(!page.contains(number), "the page shows {number:?}");
    }
    assert!(page.contains("SYNC: none in this log"));
}

#[test]
fn a_controller_at_another_node_is_named_by_its_own_ids() {
    // The commissioning file puts the controller at node 0x20: its manual-mode frames
    // are 0x420, and the page says so.
    let dir = std::env::temp_dir().join(format!("report-test-{}-scene", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("crane.toml");
    std::fs::copy(root().join(DEFAULT_SCENE), &scene).unwrap();
    let stock = std::fs::read_to_string(root().join("scenes/commissioning.toml")).unwrap();
    let moved = stock.replacen("node = 16 ", "node = 32 ", 1);
    assert_ne!(moved, stock);
    std::fs::write(dir.join("commissioning.toml"), moved).unwrap();
    let (path, out) = log("node", &["720#05".to_string(), "420#0000".to_string()]);
    let s = report(&Options {
        log: path,
        scene,
        out: out.clone(),
        eds: Vec::new(),
    })
    .unwrap();
    assert_eq!(s.manual_frames, 1);
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        page.contains("1 manual-mode frames (0x420)"),
        "the page names 0x420"
    );
    assert!(!page.contains("0x410"), "and never the stock 0x410");
}

#[test]
fn the_cpu_time_read_is_this_thread_s_and_grows_with_work() {
    let before = cpu_seconds().unwrap();
    let mut x = 0u64;
    let began = std::time::Instant::now();
    while began.elapsed().as_secs_f64() < 0.2 {
        x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
    }
    let spent = cpu_seconds().unwrap() - before;
    // Busy for 0.2 s of wall clock: some CPU time, never more than the wall clock.
    assert!(spent > 0.0 && spent <= 0.25, "{spent}");
}

#[test]
fn both_formats_give_the_same_report_to_the_nanosecond() {
    // SYNCs 10 ms apart and one gap of exactly 1.5 cycles, stamped as python-can's
    // writers stamp them: candump since the epoch, ASC since the first frame.
    let start_us: u64 = 1_795_857_436_319_260;
    let mut at = vec![0u64];
    for gap in [10_000, 10_000, 15_000, 10_000, 10_000, 15_000, 10_000] {
        at.push(at[at.len() - 1] + gap);
    }
    let candump: Vec<String> = at
        .iter()
        .map(|us| {
            let t = start_us + us;
            format!("({}.{:06}) can0 080#", t / 1_000_000, t % 1_000_000)
        })
        .collect();
    let asc: Vec<String> = at
        .iter()
        .map(|us| format!("{:9.6} 1  80    Rx   d 0", *us as f64 / 1e6))
        .collect();
    let dir = std::env::temp_dir().join(format!("report-test-{}-formats", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("a.log"), candump.join("\n")).unwrap();
    std::fs::write(
        dir.join("a.asc"),
        format!(
            "date x\nbase hex  timestamps absolute\n{}\n",
            asc.join("\n")
        ),
    )
    .unwrap();
    let reports: Vec<Summary> = ["a.log", "a.asc"]
        .iter()
        .map(|name| run(&dir.join(name), &dir.join(format!("{name}-out"))).unwrap())
        .collect();
    let timing = |s: &Summary| serde_json::to_string(&s.timing).unwrap();
    assert_eq!(timing(&reports[0]), timing(&reports[1]));
    assert_eq!(reports[0].duration, 0.08);
    // 15 ms is 1.5 cycles, not more: no cycle missed.
    assert_eq!(reports[0].timing.missed_cycles, 0);
}

#[test]
fn the_example_check_refuses_a_changed_a_missing_and_a_stale_file() {
    let dir = std::env::temp_dir().join(format!("report-test-{}-same", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (made, kept) = (dir.join("made"), dir.join("kept"));
    for d in [&made, &kept] {
        std::fs::create_dir_all(d).unwrap();
        std::fs::write(d.join("index.html"), "page").unwrap();
        std::fs::write(d.join("a.svg"), "figure").unwrap();
    }
    std::fs::write(kept.join("x.log"), "the log").unwrap();
    assert_eq!(same_files(&made, &kept, "x.log"), Ok(()));
    std::fs::write(kept.join("a.svg"), "old figure").unwrap();
    let e = same_files(&made, &kept, "x.log").unwrap_err();
    assert!(e.contains("a.svg is not what the report makes now"), "{e}");
    std::fs::remove_file(kept.join("a.svg")).unwrap();
    assert!(same_files(&made, &kept, "x.log").is_err(), "a file missing");
    std::fs::write(kept.join("a.svg"), "figure").unwrap();
    std::fs::write(kept.join("old.svg"), "a figure no longer made").unwrap();
    let e = same_files(&made, &kept, "x.log").unwrap_err();
    assert!(
        e.contains("old.svg is not made by the report any more"),
        "{e}"
    );
}
