//! The range guard in the controller (`controller::range`): a correction that pushes the
//! trolley towards its range's end on a move that ends 50 mm short of it, on the
//! virtual bus. The guard holds the drive inside its range, and the correction is told
//! what the drive was sent (`AxesCorrection::sent`) exactly in the cycles the guard
//! changed its set point, with what was sent — its observer must learn the correction
//! the drive got, not the one it asked for (anti-windup).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

mod common;

use std::cell::RefCell;
use std::rc::Rc;

use common::{feedforward, planner, Ff, HOME};
use controller::commands::Request;
use controller::drive::Drive;
use controller::feedback::{Correction, Measurement, Mode, Output, Reference};
use controller::rope::RopeLength;
use controller::setpoint::{DriveLimits, UNITS_PER_M_PER_S};
use controller::{Config, Controller};
use sim::{run_cycle, Action, Ending, Event, Scenario, VirtualBus};
use solver_core::models::crane::CraneParams;

/// The trolley's range's high end, m.
const END: f64 = CraneParams::PAPER.workspace.x_max;

/// The move towards the end, asked at 1 s: to 50 mm short of it in 12 s.
const MOVE: Event = Event {
    at_ms: 1_000,
    action: Action::Request(Request::Move {
        id: 1,
        target: [END - 0.05, HOME[1]],
        duration: Some(12.0),
    }),
};

const SCENARIO: Scenario = Scenario {
    name: "range-guard",
    expect: "",
    events: &[MOVE],
    cycles: 0,
    random: None,
    ends: Ending::Ready,
    plant: None,
};

/// What the correction saw in one cycle: the model's set points, what it asked for,
/// and what it was told was sent (`None`: it was not told).
#[derive(Debug, Clone, Copy)]
struct Row {
    u_d: [f64; 2],
    asked: [f64; 2],
    sent: Option<[f64; 2]>,
}

/// A correction that asks the trolley for `PUSH` m/s more than the model's, always —
/// as a feedback damping a swing the model does not have would, near an end — and logs
/// every cycle.
struct Pusher(Rc<RefCell<Vec<Row>>>);

/// The push, m/s: over the 12 s move the drive runs up to 0.6 m ahead of the model's.
const PUSH: f64 = 0.05;

impl Correction for Pusher {
    const ENABLED: bool = true;
    fn correct(
        &mut self,
        _reference: &Reference,
        u_d: [f64; 2],
        _measured: Option<Measurement>,
        _last: [f64; 2],
        _limits: &DriveLimits,
    ) -> Output {
        // Ramped in within the gate's step, as the feedback's clamp does.
        let push = (self.0.borrow().len() as f64 * 0.01).min(PUSH);
        let asked = [u_d[0] + push, u_d[1]];
        self.0.borrow_mut().push(Row {
            u_d,
            asked,
            sent: None,
        });
        Output {
            u: asked,
            correction: [push, 0.0],
            mode: Mode::Closed,
            resting: false,
            swing: 0.0,
            error: [0.0; 6],
            offset: 0.0,
            trusted: false,
        }
    }
    fn sent(&mut self, correction: [f64; 2]) {
        let mut rows = self.0.borrow_mut();
        let row = rows.last_mut().expect("told after it asked");
        assert!(row.sent.is_none(), "told once a cycle");
        row.sent = Some(correction);
    }
    fn restart(&mut self) {}
    fn let_go_at_rest(&mut self) {}
    fn mode(&self) -> Option<Mode> {
        Some(Mode::Closed)
    }
    fn rope(&self) -> Option<&RopeLength> {
        None
    }
}

/// A set point in drive units (what the RPDO carries) equals `u` m/s to the gate's
/// rounding.
fn carries(units: i32, u: f64) -> bool {
    (f64::from(units) - u * UNITS_PER_M_PER_S).abs() <= 0.5 + 1e-6
}

#[test]
fn the_guard_holds_a_pushed_drive_inside_and_tells_the_correction_exactly_when() {
    let rows = Rc::new(RefCell::new(Vec::new()));
    let ff: Ff = feedforward(HOME, None);
    let mut c = Controller::with_correction(ff, Pusher(rows.clone()), planner(), Config::DEFAULT);
    let mut bus = VirtualBus::new(SCENARIO, HOME);
    let (mut told, mut peak) = (0, f64::MIN);
    for k in 0..1_800_u32 {
        let before = rows.borrow().len();
        let cycle = run_cycle(&mut c, &mut bus, k * 10).expect("no hang");
        let rows = rows.borrow();
        let trolley = bus.drive(Drive::Trolley).unwrap().position();
        peak = peak.max(trolley);
        if rows.len() == before {
            continue;
        }
        assert_eq!(rows.len(), before + 1, "cycle {k}: one correction a cycle");
        let row = rows[before];
        let units = cycle.setpoints[0].units();
        match row.sent {
            // Told: what the trolley was sent is the model's set point plus what it
            // was told, and not what it asked.
            Some(correction) => {
                told += 1;
                assert!(
                    carries(units, row.u_d[0] + correction[0]),
                    "cycle {k}: sent {units}, told {correction:?} on {:?}",
                    row.u_d
                );
                assert!(!carries(units, row.asked[0]), "cycle {k}: nothing changed");
                assert_eq!(correction[1], 0.0, "cycle {k}: the winch as asked");
            }
            // Not told: the trolley got what the correction asked.
            None => assert!(
                carries(units, row.asked[0]),
                "cycle {k}: sent {units} for {} m/s, and not told",
                row.asked[0]
            ),
        }
        assert!(carries(cycle.setpoints[1].units(), row.asked[1]));
    }
    eprintln!("told in {told} cycles; the trolley's peak {peak:.4} m, the end {END} m");
    assert!(told > 100, "the guard bit (told in {told} cycles)");
    assert!(peak <= END + 1e-3, "the trolley passed the end: {peak} m");
    assert!(peak > END - 0.01, "held well short of the end: {peak} m");
}
