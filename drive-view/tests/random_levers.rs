//! The property of manual mode, through the real controller on the virtual bus
//! with the plant that is not the model (issue 28, "Proof"): random lever sequences on
//! the planar and the 3D crane — every lever at a random notch held for a random time,
//! a tenth of the time every lever released, the hoist included, the load driven into
//! the workspace's ends and away — and at every cycle: no gate refusal (a refused set
//! point is a controller fault, and the mode stays *ready*), manual mode running, every
//! set point finite and within its drive's speed limit, and the plant's drives inside
//! their ranges.
//!
//! `LEVER_SEQUENCES` sets the number of sequences per crane (default 300, the suite's;
//! the 10,000: `LEVER_SEQUENCES=10000 cargo test --release -p drive-view --test
//! random_levers -- --nocapture`, docs/OPERATOR.md).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

use std::path::PathBuf;

use controller::setpoint::DriveLimits;
use controller::Mode;
use drive_view::engine::{CraneKind, Engine, Snapshot};
use drive_view::switch::{Action, MasterSwitch, NOTCHES};

/// A small deterministic generator (xorshift64*): the same sequences on every run.
struct Random(u64);

impl Random {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in `0..n`.
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// What the sequences reached.
#[derive(Debug, Default)]
struct Worst {
    cycles: u64,
    /// The largest share of a drive's speed limit.
    speed_share: f64,
    /// The nearest approach of a drive to its range's end, m (negative: inside), and the
    /// drive's slot.
    approach: f64,
    approach_slot: usize,
    /// The largest swing, degrees.
    swing: f64,
}

fn check(snap: &Snapshot, limits: [f64; 3], ranges: [(f64, f64); 3], worst: &mut Worst) {
    assert_eq!(
        snap.mode,
        Mode::Ready,
        "t = {}: no gate refusal, no fault",
        snap.t
    );
    assert!(snap.manual(), "t = {}: manual mode runs", snap.t);
    for (slot, v) in snap.setpoints.iter().enumerate() {
        if limits[slot] > 0.0 {
            let share = v.abs() / limits[slot];
            assert!(share <= 1.0, "t = {}: slot {slot} at {v} m/s", snap.t);
            worst.speed_share = worst.speed_share.max(share);
        }
    }
    for (slot, (lo, hi)) in ranges.iter().enumerate() {
        if hi > lo {
            let p = snap.plant.drives[slot];
            let beyond = (lo - p).max(p - hi);
            if beyond > worst.approach {
                worst.approach = beyond;
                worst.approach_slot = slot;
            }
        }
    }
    worst.swing = worst
        .swing
        .max(snap.swing_deg().iter().fold(0.0, |m, s| m.max(s.abs())));
    worst.cycles += 1;
}

fn drive(name: &str, sequences: usize, seed: u64) -> Worst {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(name);
    let mut e = Engine::for_scene(&path).unwrap();
    let info = e.info().clone();
    let limits = match info.kind {
        CraneKind::Planar => {
            let [t, w] = DriveLimits::LAB.axes();
            [t.max_velocity, 0.0, w.max_velocity]
        }
        CraneKind::Spatial => DriveLimits::LAB_3D.map(|a| a.max_velocity),
    };
    let mut s = MasterSwitch::new(e.has_y());
    let per_second = 1000 / e.period_ms();
    let run = |e: &mut Engine, s: &mut MasterSwitch, cycles: u32| -> Vec<Snapshot> {
        (0..cycles).map(|_| e.cycle(s).unwrap()).collect()
    };
    let boot = run(&mut e, &mut s, 3 * per_second);
    assert_eq!(boot.last().unwrap().mode, Mode::Ready);
    s.apply(Action::ToggleManual);
    let entered = run(&mut e, &mut s, per_second / 3);
    assert!(entered.last().unwrap().manual());
    let mut random = Random(seed);
    let mut worst = Worst {
        approach: f64::NEG_INFINITY,
        ..Worst::default()
    };
    let axes: Vec<usize> = if e.has_y() { vec![0, 1, 2] } else { vec![0, 2] };
    for _ in 0..sequences {
        if random.below(10) == 0 {
            s.apply(Action::Centre);
        } else {
            for &slot in &axes {
                let notch = match random.below(10) {
                    // Full stick either way, more often than uniform: the limits.
                    0 => NOTCHES,
                    1 => -NOTCHES,
                    _ => random.below(2 * NOTCHES as u64 + 1) as i8 - NOTCHES,
                };
                s.levers[slot] = notch;
            }
        }
        // Held 0.1 to 3 s: short holds released before the speed is reached too.
        let hold = (10 + random.below(290)) as u32 * per_second / 100;
        for snap in run(&mut e, &mut s, hold) {
            check(&snap, limits, info.ranges, &mut worst);
        }
    }
    worst
}

/// How far the plant's drives may pass a range's end, m. The generator brings the
/// *model's* drives to rest at the end at the latest (its own property test, on the exact
/// inverse: never beyond); the plant here is not the model (its drives lag otherwise, its
/// pendulum is 10 % longer) and the state feedback corrects it, which the drives' range
/// guard (`controller::range`) limits to the room left: the plant's drive may still run
/// on a little, measured up to 1.8 mm (planar and 3D) over 10,000 sequences each
/// (docs/OPERATOR.md; 25 and 32 mm over 300 without the guard). A real crane's limit
/// switches sit beyond the software limits by more.
const BEYOND_TOLERANCE: f64 = 0.005;

fn sequences() -> usize {
    std::env::var("LEVER_SEQUENCES")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(300)
}

/// Runs the sequences on the scene `file` and checks what they reached.
fn levers_on(crane: &str, file: &str, seed: u64) {
    let n = sequences();
    let w = drive(file, n, seed);
    println!(
        "{crane}: {n} sequences, {} cycles; largest share of a speed limit {:.3}, nearest \
         approach to a range's end {:+.4} m (drive slot {}), largest swing {:.2}°",
        w.cycles, w.speed_share, w.approach, w.approach_slot, w.swing
    );
    assert!(
        w.approach <= BEYOND_TOLERANCE,
        "a drive left its range by {} m",
        w.approach
    );
}

#[test]
fn random_levers_on_the_planar_crane_never_meet_the_gate_nor_leave_the_workspace() {
    levers_on("planar", "paper-crane-manual-feedback.toml", 0x5EED_0001);
}

#[test]
fn random_levers_on_the_3d_crane_never_meet_the_gate_nor_leave_the_workspace() {
    levers_on("3D", "crane3d/crane3d-manual-feedback.toml", 0x5EED_0003);
}
