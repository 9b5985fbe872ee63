//! The 100 Hz cycle with injected time and a scripted inverse model: the NMT/SYNC/
//! heartbeat schedule, the CiA 402 enable sequence, set points through the choke
//! point, and the controlled stop on every fault.

use controller::canopen::{self, cob, Drive, NmtState};
use controller::cia402::{controlword, DriveState};
use controller::units::{SetpointError, UNITS_PER_M_PER_S};
use controller::{
    CanFrame, Command, Config, Controller, Fault, Feedforward, FeedforwardStep, Mode,
};
use solver_core::{Error, NewtonStats};

/// Plays back a list of inputs, then fails with a Newton error.
struct Script {
    u: Vec<[f64; 2]>,
    next: usize,
}

impl Feedforward for Script {
    fn step(&mut self) -> Result<FeedforwardStep, Error> {
        let u = *self.u.get(self.next).ok_or(Error::NewtonNotConverged {
            t: 9.0,
            iterations: 20,
            residual: 1.0,
            increment: 2.0,
        })?;
        self.next += 1;
        Ok(FeedforwardStep {
            t: self.next as f64 * 0.01,
            u,
            stats: NewtonStats::default(),
        })
    }
}

fn controller(u: Vec<[f64; 2]>) -> Controller<Script> {
    Controller::new(Script { u, next: 0 }, Config::DEFAULT)
}

/// Both drives enabled and alive at `now_ms`.
fn drives_ready(c: &mut Controller<Script>, now_ms: u32) {
    for d in Drive::ALL {
        c.on_frame(&canopen::heartbeat(d.node(), NmtState::Operational), now_ms);
        c.on_frame(&canopen::tpdo1(d, 0x0237, 0), now_ms);
    }
}

fn ids(frames: &[CanFrame]) -> Vec<u16> {
    frames.iter().map(CanFrame::id).collect()
}

fn rpdo(frames: &[CanFrame], drive: Drive) -> (u16, i32) {
    let f = frames
        .iter()
        .find(|f| f.id() == cob::RPDO1 + u16::from(drive.node()))
        .expect("an RPDO per drive");
    let d = f.data();
    (
        u16::from_le_bytes([d[0], d[1]]),
        i32::from_le_bytes([d[2], d[3], d[4], d[5]]),
    )
}

#[test]
fn schedule_nmt_first_then_pdos_sync_and_a_heartbeat_every_100_ms() {
    let mut c = controller(vec![[0.0; 2]; 100]);
    let first = c.tick(0);
    assert_eq!(ids(&first.frames), vec![0x000, 0x710, 0x201, 0x202, 0x080]);
    assert_eq!(
        first.frames[0].data(),
        &[0x01, 0x00],
        "NMT start, all nodes"
    );
    assert_eq!(first.frames[1].data(), &[0x00], "boot-up");
    drives_ready(&mut c, 5);
    for cycle in 1..=30u32 {
        let out = c.tick(cycle * 10);
        let mut expected = vec![0x201, 0x202, 0x080];
        if cycle % 10 == 0 {
            expected.push(0x710);
        }
        assert_eq!(ids(&out.frames), expected, "cycle {cycle}");
    }
}

#[test]
fn drives_are_walked_to_operation_enabled() {
    let mut c = controller(vec![[0.0; 2]; 100]);
    let mut now = 0;
    let mut words = vec![];
    for status in [0x0250u16, 0x0231, 0x0233, 0x0237] {
        for d in Drive::ALL {
            c.on_frame(&canopen::heartbeat(d.node(), NmtState::Operational), now);
            c.on_frame(&canopen::tpdo1(d, status, 0), now);
        }
        let out = c.tick(now);
        words.push(rpdo(&out.frames, Drive::Winch).0);
        now += 10;
    }
    assert_eq!(
        words,
        vec![
            controlword::SHUTDOWN,
            controlword::SWITCH_ON,
            controlword::ENABLE_OPERATION,
            controlword::ENABLE_OPERATION
        ]
    );
    assert_eq!(c.drive_state(Drive::Trolley), DriveState::OperationEnabled);
}

#[test]
fn set_points_carry_the_model_inputs_in_drive_units() {
    let u: Vec<[f64; 2]> = (0..50)
        .map(|i| [0.01 * i as f64, -0.005 * i as f64])
        .collect();
    let mut c = controller(u.clone());
    drives_ready(&mut c, 0);
    for (i, want) in u.iter().enumerate() {
        let now = i as u32 * 10;
        c.on_frame(&canopen::heartbeat(1, NmtState::Operational), now);
        c.on_frame(&canopen::heartbeat(2, NmtState::Operational), now);
        let out = c.tick(now);
        assert_eq!(out.mode, Mode::Running);
        for d in Drive::ALL {
            let (cw, v) = rpdo(&out.frames, d);
            assert_eq!(cw, controlword::ENABLE_OPERATION);
            assert_eq!(v, (want[d.index()] * UNITS_PER_M_PER_S).round() as i32);
        }
    }
}

/// Runs until the mode leaves `Running`, then checks the ramp: within the acceleration
/// limit every cycle, ending at zero with quick stop.
fn assert_controlled_stop(c: &mut Controller<Script>, mut now: u32, fault: Fault) {
    let limits = Config::DEFAULT.limits;
    let first = c.tick(now);
    let mut last = first.setpoints.map(|s| s.units());
    assert_eq!(
        c.mode(),
        Mode::Stopping(fault),
        "moving drives ramp down first"
    );
    let mut stopped = false;
    for _ in 0..400 {
        now += 10;
        for d in Drive::ALL {
            c.on_frame(&canopen::heartbeat(d.node(), NmtState::Operational), now);
        }
        let out = c.tick(now);
        for d in Drive::ALL {
            let (cw, v) = rpdo(&out.frames, d);
            let dv = f64::from(v - last[d.index()]) / UNITS_PER_M_PER_S;
            assert!(
                dv.abs() <= limits.of(d).max_acceleration * 0.01 + 1e-6,
                "{d:?} jumps by {dv} m/s"
            );
            last[d.index()] = v;
            if out.mode == Mode::Stopped(fault) {
                // The cycle that reaches standstill still asks for operation at velocity 0 ...
                assert_eq!((cw, v), (controlword::ENABLE_OPERATION, 0), "{d:?}");
            }
        }
        if out.mode == Mode::Stopped(fault) {
            stopped = true;
            break;
        }
    }
    assert!(stopped, "never reached standstill");
    // ... and from the next cycle on the drives are held by quick stop.
    for _ in 0..3 {
        now += 10;
        let out = c.tick(now);
        assert_eq!(out.mode, Mode::Stopped(fault));
        for d in Drive::ALL {
            assert_eq!(rpdo(&out.frames, d), (controlword::QUICK_STOP, 0), "{d:?}");
        }
    }
}

fn moving(c: &mut Controller<Script>, cycles: u32) -> u32 {
    drives_ready(c, 0);
    for i in 0..cycles {
        for d in Drive::ALL {
            c.on_frame(&canopen::heartbeat(d.node(), NmtState::Operational), i * 10);
        }
        c.tick(i * 10);
    }
    cycles * 10
}

fn ramp_up(n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| [(0.02 * i as f64).min(2.5), (0.01 * i as f64).min(1.5)])
        .collect()
}

#[test]
fn newton_failure_ramps_down_then_quick_stops() {
    let mut c = controller(ramp_up(150));
    let now = moving(&mut c, 150);
    assert_controlled_stop(
        &mut c,
        now,
        Fault::Solver(Error::NewtonNotConverged {
            t: 9.0,
            iterations: 20,
            residual: 1.0,
            increment: 2.0,
        }),
    );
}

#[test]
fn drive_fault_statusword_stops() {
    let mut c = controller(ramp_up(400));
    let now = moving(&mut c, 100);
    c.on_frame(&canopen::tpdo1(Drive::Winch, 0x0218, 0), now);
    assert_controlled_stop(&mut c, now, Fault::DriveFault(Drive::Winch));
}

#[test]
fn lost_heartbeat_stops() {
    let mut c = controller(ramp_up(400));
    let mut now = moving(&mut c, 100);
    // Only the trolley keeps beating.
    for _ in 0..31 {
        c.on_frame(&canopen::heartbeat(1, NmtState::Operational), now);
        c.tick(now);
        now += 10;
        if c.mode() != Mode::Running {
            break;
        }
    }
    assert_eq!(c.mode(), Mode::Stopping(Fault::HeartbeatLost(Drive::Winch)));
}

#[test]
fn drives_that_never_beat_are_lost_after_the_boot_timeout() {
    let mut c = controller(vec![[0.0; 2]; 200]);
    for i in 0..=100 {
        c.tick(i * 10);
    }
    assert_eq!(c.mode(), Mode::Running, "within the 1 s boot timeout");
    // At standstill there is nothing to ramp: straight to quick stop.
    c.tick(1010);
    assert!(
        matches!(c.mode(), Mode::Stopped(Fault::HeartbeatLost(_))),
        "{:?}",
        c.mode()
    );
}

#[test]
fn model_beyond_the_drive_limit_is_refused_at_the_choke_point() {
    let mut u = ramp_up(200);
    u[150] = [f64::NAN, 0.0];
    let mut c = controller(u);
    let now = moving(&mut c, 150);
    assert_controlled_stop(
        &mut c,
        now,
        Fault::Setpoint(SetpointError::NonFinite {
            drive: Drive::Trolley,
        }),
    );
}

#[test]
fn motion_asked_of_a_disabled_drive_stops() {
    let mut c = controller(vec![[0.1, 0.0]; 10]);
    for d in Drive::ALL {
        c.on_frame(&canopen::heartbeat(d.node(), NmtState::Operational), 0);
    }
    let out = c.tick(0);
    assert_eq!(
        c.mode(),
        Mode::Stopped(Fault::DriveNotReady(Drive::Trolley))
    );
    assert_eq!(out.setpoints, [controller::units::Setpoint::ZERO; 2]);
}

#[test]
fn stop_command_brings_the_load_to_rest() {
    let mut c = controller(ramp_up(400));
    let now = moving(&mut c, 120);
    c.enqueue(Command::Stop).unwrap();
    assert_controlled_stop(&mut c, now, Fault::StopRequested);
}

#[test]
fn garbage_frames_are_counted_and_change_nothing() {
    let u = ramp_up(60);
    let (mut clean, mut noisy) = (controller(u.clone()), controller(u));
    drives_ready(&mut clean, 0);
    drives_ready(&mut noisy, 0);
    let garbage = [
        CanFrame::new(0x181, &[1, 2, 3]).unwrap(),
        CanFrame::new(0x701, &[0x99]).unwrap(),
        CanFrame::new(0x555, &[0; 8]).unwrap(),
        CanFrame::new(0x202, &[0xFF; 6]).unwrap(),
    ];
    for i in 0..60u32 {
        for d in Drive::ALL {
            clean.on_frame(&canopen::heartbeat(d.node(), NmtState::Operational), i * 10);
            noisy.on_frame(&canopen::heartbeat(d.node(), NmtState::Operational), i * 10);
        }
        for g in &garbage {
            noisy.on_frame(g, i * 10);
        }
        assert_eq!(
            clean.tick(i * 10).frames,
            noisy.tick(i * 10).frames,
            "cycle {i}"
        );
    }
    assert_eq!(noisy.counters().frames_ignored, 60 * 4);
    assert_eq!(noisy.mode(), Mode::Running);
}
