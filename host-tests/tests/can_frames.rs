//! The encoder against the DBC file that documents the frames (`can/crane.dbc`):
//! what the controller sends is what a CAN tool reading the DBC will see.

use controller::canopen::{self, emcy, nmt, NmtCommand, NmtState, CONTROLLER_NODE};
use controller::cia402::{controlword, pdo};
use controller::commands::{
    decode_move3d, decode_request, request_frame, status_frame, Answer, Reject, Request, Status,
};
use controller::commissioning::CommissioningError;
use controller::drive::Drive;
use controller::fault::{FollowingError, Foreign, Implausibility, Reaction};
use controller::operator::{
    decode_operator, operator_frame, Flags, OperatorFrame, FULL_SCALE, OPERATOR_ID,
};
use controller::setpoint::SetpointError;
use controller::setpoint::{DriveLimits, SetpointGate, UNITS_PER_M_PER_S};
use controller::{CanFrame, Fault};
use host_tests::dbc::Dbc;
use proptest::prelude::*;

fn decode(frame: &CanFrame) -> host_tests::dbc::Decoded {
    Dbc::crane()
        .unwrap()
        .decode(frame.id(), frame.data())
        .unwrap()
}

#[test]
fn dbc_parses_and_covers_every_frame() {
    let dbc = Dbc::crane().unwrap();
    assert_eq!(dbc.messages(), 41);
    let frames = [
        nmt::command(NmtCommand::Start, 0),
        canopen::sync(),
        canopen::heartbeat(CONTROLLER_NODE, NmtState::Operational),
        canopen::heartbeat(1, NmtState::Operational),
        canopen::heartbeat(2, NmtState::BootUp),
        pdo::rpdo1(
            Drive::Trolley.node(),
            0x000F,
            controller::setpoint::Setpoint::ZERO,
        ),
        pdo::rpdo1(
            Drive::Winch.node(),
            0x000F,
            controller::setpoint::Setpoint::ZERO,
        ),
        pdo::tpdo1(Drive::Trolley.node(), 0x0237, 0),
        pdo::tpdo1(Drive::Winch.node(), 0x0237, 0),
        canopen::emcy(CONTROLLER_NODE, 0x6100, 0x01, [1, 2, 3, 4, 5]),
        canopen::emcy(1, 0x2310, 0x03, [0; 5]),
        canopen::emcy(2, 0x2310, 0x03, [0; 5]),
        pdo::tpdo2(1, 12_000_000, 9),
        pdo::tpdo2(2, 8_000_000, 9),
        CanFrame::new(0x601, &[0x40, 0, 0x10, 0, 0, 0, 0, 0]).unwrap(),
        CanFrame::new(0x602, &[0x2F, 0x60, 0x60, 0, 9, 0, 0, 0]).unwrap(),
        CanFrame::new(0x581, &[0x43, 0, 0x10, 0, 0x92, 1, 2, 0]).unwrap(),
        CanFrame::new(0x582, &[0x80, 0x60, 0x60, 0, 0x30, 0, 9, 6]).unwrap(),
        CanFrame::new(0x610, &[0x40, 0x18, 0x10, 1, 0, 0, 0, 0]).unwrap(),
        CanFrame::new(0x590, &[0x43, 0x18, 0x10, 1, 0, 0, 0, 0]).unwrap(),
        // The inclinometer (CiA 410, node 3): its slope, SDO, heartbeat, EMCY.
        CanFrame::new(0x183, &(-1234i16).to_le_bytes()).unwrap(),
        CanFrame::new(0x603, &[0x2B, 0x00, 0x60, 0, 10, 0, 0, 0]).unwrap(),
        CanFrame::new(0x583, &[0x43, 0, 0x10, 0, 0x9A, 1, 1, 0]).unwrap(),
        canopen::heartbeat(3, NmtState::Operational),
        canopen::emcy(3, 0x5000, 0x01, [0; 5]),
        // The 3D crane's two-axis inclinometer (CiA 410, node 5): both slopes, SDO,
        // heartbeat, EMCY.
        controller::cia410::tpdo1(
            5,
            controller::cia410::Slopes {
                long: -1234,
                lateral: Some(567),
            },
        ),
        CanFrame::new(0x605, &[0x2B, 0x00, 0x60, 0, 10, 0, 0, 0]).unwrap(),
        CanFrame::new(0x585, &[0x60, 0x00, 0x60, 0, 0, 0, 0, 0]).unwrap(),
        canopen::heartbeat(5, NmtState::Operational),
        canopen::emcy(5, 0x5000, 0x01, [0; 5]),
        // The 3D crane's bridge drive (node 4): every frame of a drive.
        pdo::rpdo1(
            Drive::Bridge.node(),
            0x000F,
            controller::setpoint::Setpoint::ZERO,
        ),
        pdo::tpdo1(Drive::Bridge.node(), 0x0237, 0),
        pdo::tpdo2(Drive::Bridge.node(), 14_000_000, 9),
        CanFrame::new(0x604, &[0x40, 0, 0x10, 0, 0, 0, 0, 0]).unwrap(),
        CanFrame::new(0x584, &[0x43, 0, 0x10, 0, 0x92, 1, 2, 0]).unwrap(),
        canopen::heartbeat(Drive::Bridge.node(), NmtState::Operational),
        canopen::emcy(Drive::Bridge.node(), 0x2310, 0x03, [0; 5]),
        request_frame(&Request::Stop { id: 1 }),
        request_frame(&Request::Move3d {
            id: 2,
            target: [20.0, 6.0, 4.0],
            duration: None,
        }),
        operator_frame(
            CONTROLLER_NODE,
            &OperatorFrame {
                counter: 1,
                flags: Flags {
                    enable: true,
                    manual: true,
                    micro: false,
                },
                demand: [FULL_SCALE, 0, -100],
            },
        ),
        status_frame(
            CONTROLLER_NODE,
            &Status {
                last_id: 1,
                answer: Answer::Accepted,
                reason: None,
                overload: 0,
                mode: 1,
                fault: 0,
                ignored: 0,
                deadline_misses: 0,
                tx_failures: 0,
            },
        ),
    ];
    for f in frames {
        dbc.decode(f.id(), f.data())
            .unwrap_or_else(|e| panic!("{f:?}: {e}"));
    }
}

#[test]
fn nmt_and_heartbeat_decode_to_their_fields() {
    let nmt = decode(&nmt::command(NmtCommand::Start, 0));
    assert_eq!(
        (nmt.message.as_str(), nmt.get("command"), nmt.get("node")),
        ("NMT", Some(1.0), Some(0.0))
    );
    let hb = decode(&canopen::heartbeat(CONTROLLER_NODE, NmtState::Operational));
    assert_eq!(
        (hb.message.as_str(), hb.get("nmt_state")),
        ("Heartbeat_Controller", Some(5.0))
    );
    assert_eq!(decode(&canopen::sync()).message, "SYNC");
}

#[test]
fn emcy_fields() {
    let e = decode(&canopen::emcy(
        CONTROLLER_NODE,
        0x6100,
        0x81,
        [1, 0, 0, 0, 0],
    ));
    assert_eq!(
        (
            e.get("error_code"),
            e.get("error_register"),
            e.get("fault"),
            e.get("node"),
            e.get("abort_code")
        ),
        (Some(24832.0), Some(129.0), Some(1.0), Some(0.0), None)
    );
    let drive = decode(&canopen::emcy(2, 0x2310, 0x03, [0xAA, 0, 0, 0, 0]));
    assert_eq!(drive.get("manufacturer"), Some(170.0));
}

/// A commissioning failure is two EMCYs: 0xFF10 with the drive and the object, 0xFF12
/// with the SDO abort code — the DBC multiplexes the manufacturer bytes on the fault byte.
#[test]
fn commissioning_emcys_name_drive_object_and_abort_code() {
    let failed = decode(&canopen::emcy(
        CONTROLLER_NODE,
        emcy::COMMISSIONING,
        0x81,
        [12, 1, 0, 0x60, 0x60],
    ));
    assert_eq!(
        (
            failed.get("fault"),
            failed.get("node"),
            failed.get("detail"),
            failed.get("object_index"),
            failed.get("abort_code")
        ),
        (Some(12.0), Some(1.0), Some(0.0), Some(24672.0), None)
    );
    let [a0, a1, a2, a3] = 0x0609_0030_u32.to_le_bytes();
    let abort = decode(&canopen::emcy(
        CONTROLLER_NODE,
        emcy::COMMISSIONING_ABORT,
        0x81,
        [emcy::ABORT_CODE_FOLLOWS, a0, a1, a2, a3],
    ));
    assert_eq!(
        (
            abort.get("error_code"),
            abort.get("fault"),
            abort.get("abort_code"),
            abort.get("node")
        ),
        (
            Some(65298.0),
            Some(16.0),
            Some(f64::from(0x0609_0030_u32)),
            None
        )
    );
}

/// One fault of each kind; the match makes a new kind a compile error here.
fn every_fault() -> Vec<Fault> {
    let d = Drive::Trolley;
    let all = vec![
        Fault::Solver(solver_core::Error::InvalidStepSize { h: 0.0 }),
        Fault::Setpoint(SetpointError::NonFinite { drive: d }),
        Fault::DriveFault(d),
        Fault::HeartbeatLost(d),
        Fault::Deadline,
        Fault::Undeliverable,
        Fault::DriveNotReady(d),
        Fault::Watchdog,
        Fault::DriveLeftOperational(d, NmtState::Stopped),
        Fault::TpdoTimeout(d),
        Fault::DriveMode(d),
        Fault::Commissioning(d, CommissioningError::DeviceType { found: 0 }),
        Fault::NotOperational,
        Fault::SupervisorLost,
        Fault::Implausible(d, Implausibility::Jump),
        Fault::DuplicateNodeId,
        Fault::ForeignProducer(Foreign::Sync),
        Fault::Standstill(d),
        Fault::FollowingError(d, FollowingError::Velocity),
    ];
    for f in &all {
        match f {
            Fault::Solver(_)
            | Fault::Setpoint(_)
            | Fault::DriveFault(_)
            | Fault::HeartbeatLost(_)
            | Fault::Deadline
            | Fault::Undeliverable
            | Fault::DriveNotReady(_)
            | Fault::Watchdog
            | Fault::DriveLeftOperational(..)
            | Fault::TpdoTimeout(_)
            | Fault::DriveMode(_)
            | Fault::Commissioning(..)
            | Fault::NotOperational
            | Fault::SupervisorLost
            | Fault::Implausible(..)
            | Fault::DuplicateNodeId
            | Fault::ForeignProducer(_)
            | Fault::Standstill(_)
            | Fault::FollowingError(..) => {}
        }
    }
    all
}

/// The DBC's multiplexor ranges hold for every fault: each code is distinct, in
/// 1..=`Fault::MAX_CODE` but for the two the EMCY's first manufacturer byte means
/// otherwise (15 the feedback warning, 16 the abort code), and decodes with the fault
/// signals, never as the abort code.
#[test]
fn every_fault_code_is_in_the_dbc_fault_range() {
    let faults = every_fault();
    let mut codes: Vec<u8> = faults.iter().map(Fault::code).collect();
    codes.sort_unstable();
    codes.dedup();
    assert_eq!(codes.len(), faults.len(), "distinct codes");
    let taken = [15, emcy::ABORT_CODE_FOLLOWS];
    assert_eq!(
        codes,
        (1..=Fault::MAX_CODE)
            .filter(|c| !taken.contains(c))
            .collect::<Vec<_>>()
    );
    for code in codes {
        let e = decode(&canopen::emcy(
            CONTROLLER_NODE,
            emcy::COMMISSIONING,
            0x81,
            [code, 1, 0, 0, 0],
        ));
        assert_eq!(
            (e.get("fault"), e.get("node"), e.get("abort_code")),
            (Some(f64::from(code)), Some(1.0), None),
            "fault {code}"
        );
    }
}

/// A refused request for manual mode (EMCY 0xFF21, a warning) decodes with the DBC as
/// what it is: error code "ManualRefused", the first manufacturer byte 22 outside every
/// fault's code, its reason in `detail` (the same place as a fault's), never an abort code;
/// a move the operator's stick ended (EMCY 0xFF22) as "MoveTakenOver"; the status frame's
/// fault byte names neither (it carries faults only).
#[test]
fn a_refused_manual_mode_and_a_move_taken_over_decode_as_warnings() {
    use controller::operator::Refusal;
    const { assert!(emcy::MANUAL_REFUSED_BYTE > Fault::MAX_CODE) };
    for refusal in [Refusal::Unsupported, Refusal::NotReady, Refusal::Generator] {
        let frame = canopen::emcy(
            CONTROLLER_NODE,
            emcy::MANUAL_REFUSED,
            emcy::REGISTER_MANUFACTURER,
            [emcy::MANUAL_REFUSED_BYTE, 0, refusal.code(), 0, 0],
        );
        assert_eq!(
            label(&frame, "error_code").as_deref(),
            Some("ManualRefused")
        );
        assert_eq!(label(&frame, "fault").as_deref(), Some("ManualRefused"));
        let e = decode(&frame);
        assert_eq!(
            (e.get("detail"), e.get("abort_code")),
            (Some(f64::from(refusal.code())), None),
            "{refusal:?}"
        );
    }
    let taken_over = canopen::emcy(
        CONTROLLER_NODE,
        emcy::MOVE_TAKEN_OVER,
        emcy::REGISTER_MANUFACTURER,
        [emcy::MOVE_TAKEN_OVER_BYTE, 0, 0, 0, 0],
    );
    assert_eq!(
        label(&taken_over, "error_code").as_deref(),
        Some("MoveTakenOver")
    );
    assert_eq!(
        label(&taken_over, "fault").as_deref(),
        Some("MoveTakenOver")
    );
    // The status frame's fault byte carries faults only: neither warning is named there.
    let status = controller::commands::status_frame(
        CONTROLLER_NODE,
        &controller::commands::Status {
            last_id: 0,
            answer: controller::commands::Answer::None,
            reason: None,
            overload: 0,
            mode: 1,
            fault: emcy::MANUAL_REFUSED_BYTE,
            ignored: 0,
            deadline_misses: 0,
            tx_failures: 0,
        },
    );
    assert_eq!(label(&status, "fault"), None);
}

/// Every EMCY error code the controller sends is named in the DBC's value table, so that
/// a CAN tool shows it by the name CiA 301 and CiA 402 give it (0x8150 CAN-ID collision,
/// 0x8500 position controller, 0x8611 following error, …).
#[test]
fn every_emcy_error_code_is_named_in_the_dbc() {
    let label = |code: u16| {
        label(
            &canopen::emcy(CONTROLLER_NODE, code, 0x81, [18, 1, 0, 0, 0]),
            "error_code",
        )
    };
    let faults = every_fault();
    let sent = faults.iter().map(Fault::emcy_code).chain([
        emcy::NO_ERROR,
        emcy::COMMISSIONING_ABORT,
        emcy::FEEDBACK_OFF,
        emcy::MANUAL_REFUSED,
        emcy::MOVE_TAKEN_OVER,
    ]);
    for code in sent {
        assert!(label(code).is_some(), "0x{code:04X} has no name in the DBC");
    }
    assert_eq!(label(0x8611).as_deref(), Some("FollowingError"));
    assert_eq!(label(0x8500).as_deref(), Some("PositionController"));
    assert_eq!(label(0x8150).as_deref(), Some("CanIdCollision"));
}

/// The label the DBC gives `signal` in `frame`.
fn label(frame: &CanFrame, signal: &str) -> Option<String> {
    decode(frame)
        .signals
        .into_iter()
        .find(|s| s.name == signal)
        .and_then(|s| s.label)
}

/// Each row of the fault table (`Fault::facts`) is what the DBC says of its code: the
/// same name in the EMCY's and the status frame's value tables (and the variant's), an
/// EMCY error code the DBC names; and the error register's class bit is CiA 301's for
/// that code: communication for the 0x81xx and 0x82xx codes, manufacturer otherwise.
#[test]
fn every_fault_s_facts_agree_with_the_dbc() {
    for fault in every_fault() {
        let facts = fault.facts();
        let register = emcy::REGISTER_GENERIC | facts.register;
        let sent = canopen::emcy(
            CONTROLLER_NODE,
            facts.emcy_code,
            register,
            [facts.code, 1, 0, 0, 0],
        );
        assert_eq!(
            label(&sent, "fault").as_deref(),
            Some(facts.name),
            "{fault:?}"
        );
        assert!(label(&sent, "error_code").is_some(), "{fault:?}");
        let status = status_frame(
            CONTROLLER_NODE,
            &Status {
                last_id: 0,
                answer: Answer::None,
                reason: None,
                overload: 0,
                mode: 4,
                fault: facts.code,
                ignored: 0,
                deadline_misses: 0,
                tx_failures: 0,
            },
        );
        assert_eq!(
            label(&status, "fault").as_deref(),
            Some(facts.name),
            "{fault:?}"
        );
        let variant = format!("{fault:?}");
        assert_eq!(
            variant.split('(').next(),
            Some(facts.name),
            "{fault:?} named {}",
            facts.name
        );
        let communication = matches!(facts.emcy_code & 0xFF00, 0x8100 | 0x8200);
        let expected = if communication {
            emcy::REGISTER_COMMUNICATION
        } else {
            emcy::REGISTER_MANUFACTURER
        };
        assert_eq!(facts.register, expected, "{fault:?}");
    }
}

/// docs/COMMANDS.md's fault table ("## Faults": code, reaction, EMCY code) says what
/// the fault table of the code (`Fault::facts`) says, row for row.
#[test]
fn the_documented_fault_table_is_the_code_s() {
    let doc = include_str!("../../docs/COMMANDS.md");
    let table = doc
        .split("\n## Faults\n")
        .nth(1)
        .expect("docs/COMMANDS.md has a section \"## Faults\"");
    let rows: Vec<Vec<&str>> = table
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    let faults = every_fault();
    let mut documented = 0;
    for row in &rows {
        let Some(code) = row[0].split(' ').next().and_then(|c| c.parse::<u8>().ok()) else {
            continue;
        };
        documented += 1;
        let fault = faults
            .iter()
            .find(|f| f.code() == code)
            .unwrap_or_else(|| panic!("fault {code} of the docs is not the code's"));
        let facts = fault.facts();
        let reaction = match facts.reaction {
            Reaction::Controlled => "controlled stop",
            Reaction::Quick => "quick stop",
            Reaction::Halt => "halted",
        };
        assert!(row[1].starts_with(reaction), "fault {code}: {}", row[1]);
        let emcy_code = format!("0x{:04X}", facts.emcy_code);
        assert!(row[2].starts_with(&emcy_code), "fault {code}: {}", row[2]);
    }
    assert_eq!(documented, faults.len(), "faults in docs/COMMANDS.md");
}

#[test]
fn status_names_its_answer_reason_mode_and_fault() {
    let s = decode(&status_frame(
        CONTROLLER_NODE,
        &Status {
            last_id: 7,
            answer: Answer::Rejected,
            reason: Some(Reject::WinchAcceleration),
            overload: 0,
            mode: 4,
            fault: 6,
            ignored: 300,
            deadline_misses: 2,
            tx_failures: 1,
        },
    ));
    assert_eq!(
        s.to_string(),
        "Status_Controller last_id=7 answer=3(Rejected) reason=10(WinchAcceleration) mode=4(Halted) \
         fault=6(Undeliverable) ignored=44 deadline_misses=2 tx_failures=1"
    );
}

/// Manual mode's status byte (issue 28) is named in the DBC, additive to modes 0–4.
#[test]
fn status_names_manual_mode() {
    let s = decode(&status_frame(
        CONTROLLER_NODE,
        &Status {
            last_id: 0,
            answer: Answer::None,
            reason: None,
            overload: 0,
            mode: controller::operator::MANUAL_MODE_CODE,
            fault: 0,
            ignored: 0,
            deadline_misses: 0,
            tx_failures: 0,
        },
    ));
    assert!(s.to_string().contains("mode=5(Manual)"), "{s}");
}

/// An overload answer: the last request it answers and how many, in byte 2 where a
/// rejection has its reason (the DBC multiplexes byte 2 on the answer).
#[test]
fn an_overload_answer_names_how_many_requests_it_answers() {
    let s = decode(&status_frame(
        CONTROLLER_NODE,
        &Status {
            last_id: 200,
            answer: Answer::Overload,
            reason: None,
            overload: 77,
            mode: 1,
            fault: 0,
            ignored: 256,
            deadline_misses: 0,
            tx_failures: 0,
        },
    ));
    assert_eq!(
        s.to_string(),
        "Status_Controller last_id=200 answer=4(Overload) overloaded=77 mode=1(Ready) \
         fault=0(None) ignored=0 deadline_misses=0 tx_failures=0"
    );
}

/// Every rejection reason the controller gives is named in the DBC by its own name.
#[test]
fn every_reject_reason_is_named_in_the_dbc() {
    let reasons = [
        Reject::Busy,
        Reject::NotReady,
        Reject::Invalid,
        Reject::TrolleyWorkspace,
        Reject::RopeWorkspace,
        Reject::SlackRope,
        Reject::TrolleyVelocity,
        Reject::WinchVelocity,
        Reject::TrolleyAcceleration,
        Reject::WinchAcceleration,
        Reject::BridgeWorkspace,
        Reject::BridgeVelocity,
        Reject::BridgeAcceleration,
        Reject::NotInPlace,
        Reject::Moving,
        Reject::HookAtRail,
    ];
    // Each its own code (14 is another rule's: a reset while the crane moves).
    let codes: std::collections::BTreeSet<u8> = reasons.iter().map(|r| *r as u8).collect();
    assert_eq!(codes.len(), reasons.len());
    for reason in reasons {
        let code = reason as u8;
        let s = decode(&status_frame(
            CONTROLLER_NODE,
            &Status {
                last_id: 1,
                answer: Answer::Rejected,
                reason: Some(reason),
                overload: 0,
                mode: 1,
                fault: 0,
                ignored: 0,
                deadline_misses: 0,
                tx_failures: 0,
            },
        ))
        .to_string();
        let named = format!("reason={code}({reason:?})");
        assert!(s.contains(&named), "{s} lacks {named}");
    }
}

proptest! {
    /// Any move request: the DBC reads back what the controller decodes.
    #[test]
    fn commands_agree_with_the_dbc(id in any::<u8>(), x in 0.0..65.0f64, z in 0.0..65.0f64, d in prop::option::of(0.01..655.0f64)) {
        let f = request_frame(&Request::Move { id, target: [x, z], duration: d });
        let dbc = decode(&f);
        let Ok(Request::Move { id: i, target: [dx, dz], duration }) = decode_request(f.data()) else {
            return Err(TestCaseError::fail("a move request decodes"));
        };
        prop_assert_eq!(dbc.get("request_id"), Some(f64::from(i)));
        prop_assert_eq!(dbc.get("command"), Some(1.0));
        prop_assert!((dbc.get("target_x").unwrap() - dx).abs() < 1e-9);
        prop_assert!((dbc.get("target_z").unwrap() - dz).abs() < 1e-9);
        prop_assert!((dbc.get("duration").unwrap() - duration.unwrap_or(0.0)).abs() < 1e-9);
        prop_assert!((dx - x).abs() <= 0.0005 + 1e-12 && (dz - z).abs() <= 0.0005 + 1e-12);
    }

    /// Any 3D move: the DBC reads back what the controller decodes (RPDO2, 0x310).
    #[test]
    fn move3d_frames_agree_with_the_dbc(id in any::<u8>(), x in 0.0..65.0f64, y in 0.0..65.0f64, z in 0.0..65.0f64, d in prop::option::of(1.0..255.0f64)) {
        let f = request_frame(&Request::Move3d { id, target: [x, y, z], duration: d });
        prop_assert_eq!(f.id(), 0x310);
        let dbc = decode(&f);
        prop_assert_eq!(dbc.message.as_str(), "Move3d_Controller");
        let Ok(Request::Move3d { id: i, target, duration }) = decode_move3d(f.data()) else {
            return Err(TestCaseError::fail("a 3D move decodes"));
        };
        prop_assert_eq!(dbc.get("request_id"), Some(f64::from(i)));
        for (name, (v, asked)) in ["target_x", "target_y", "target_z"].into_iter().zip(target.into_iter().zip([x, y, z])) {
            prop_assert!((dbc.get(name).unwrap() - v).abs() < 1e-9, "{}", name);
            prop_assert!((v - asked).abs() <= 0.0005 + 1e-12);
        }
        prop_assert!((dbc.get("duration").unwrap() - duration.unwrap_or(0.0)).abs() < 1e-9);
    }
}

proptest! {
    /// Any well-formed operator frame (RPDO3, 0x410): the DBC reads back the counter, each
    /// flag and each demand as the fraction of the manual speed the controller takes.
    #[test]
    fn operator_frames_agree_with_the_dbc(counter in any::<u8>(), flags in 0u8..8, demand in prop::array::uniform3(-FULL_SCALE..=FULL_SCALE)) {
        let data = {
            let f = OperatorFrame { counter, flags: Flags::default(), demand };
            let mut d = f.bytes();
            d[1] = flags;
            d
        };
        let operator = decode_operator(&data).unwrap();
        let f = operator_frame(CONTROLLER_NODE, &operator);
        prop_assert_eq!(f.id(), OPERATOR_ID);
        prop_assert_eq!(f.data(), data);
        let dbc = decode(&f);
        prop_assert_eq!(dbc.message.as_str(), "Operator_Controller");
        prop_assert_eq!(dbc.get("alive_counter"), Some(f64::from(counter)));
        prop_assert_eq!(dbc.get("enable"), Some(f64::from(flags & 1)));
        prop_assert_eq!(dbc.get("manual_request"), Some(f64::from((flags >> 1) & 1)));
        prop_assert_eq!(dbc.get("micro_speed"), Some(f64::from((flags >> 2) & 1)));
        // Without micro-speed the fraction is the DBC's scaled value.
        let plain = OperatorFrame { flags: Flags { micro: false, ..operator.flags }, ..operator };
        let (h, z) = plain.stick::<2>().unwrap();
        for (name, v) in ["demand_x", "demand_y", "demand_z"].into_iter().zip([h[0], h[1], z]) {
            prop_assert!((dbc.get(name).unwrap() - v).abs() < 1e-12, "{}", name);
        }
    }
}

proptest! {
    /// Any admissible set point: the DBC reads back the controlword and the velocity in m/s.
    #[test]
    fn rpdo_round_trips_through_the_dbc(v in -3.0..3.0f64, cw in prop::sample::select(vec![controlword::SHUTDOWN, controlword::SWITCH_ON, controlword::ENABLE_OPERATION, controlword::QUICK_STOP])) {
        let limits = DriveLimits { trolley: controller::setpoint::AxisLimits { max_velocity: 3.0, max_acceleration: 1e9 }, ..DriveLimits::LAB };
        let mut gate = SetpointGate::new(limits, 0.01);
        let sp = gate.admit(Drive::Trolley, v).unwrap();
        let d = decode(&pdo::rpdo1(Drive::Trolley.node(), cw, sp));
        prop_assert_eq!(d.message.as_str(), "RPDO1_Trolley");
        prop_assert_eq!(d.get("controlword"), Some(f64::from(cw)));
        let back = d.get("target_velocity").unwrap();
        prop_assert!((back - v).abs() <= 0.5 / UNITS_PER_M_PER_S + 1e-12, "{} -> {}", v, back);
    }

    /// TPDOs the drives send decode the same through the DBC and through the controller.
    #[test]
    fn tpdo_agrees_with_the_dbc(sw in any::<u16>(), vel in any::<i32>(), winch in any::<bool>()) {
        let drive = if winch { Drive::Winch } else { Drive::Trolley };
        let node = drive.node();
        let f = pdo::tpdo1(node, sw, vel);
        let d = decode(&f);
        prop_assert_eq!(d.get("statusword"), Some(f64::from(sw)));
        prop_assert!((d.get("velocity_actual").unwrap() - f64::from(vel) / UNITS_PER_M_PER_S).abs() < 1e-9);
        prop_assert_eq!(canopen::decode(&f), Ok(canopen::Incoming::Tpdo { node, frame: f }));
        prop_assert_eq!(pdo::Tpdo::decode(&f), Ok(pdo::Tpdo::Status { statusword: sw, velocity: vel }));
    }

    /// TPDO2 (position actual, mode display) and the SDO frames decode the same through
    /// the DBC and through the controller.
    #[test]
    fn tpdo2_and_sdo_agree_with_the_dbc(pos in any::<i32>(), mode in any::<i8>(), winch in any::<bool>(), bytes in any::<[u8; 8]>()) {
        let node = if winch { 2 } else { 1 };
        let f = pdo::tpdo2(node, pos, mode);
        let d = decode(&f);
        prop_assert!((d.get("position_actual").unwrap() - f64::from(pos) * 1e-6).abs() < 1e-9);
        prop_assert_eq!(d.get("mode_display"), Some(f64::from(mode)));
        prop_assert_eq!(canopen::decode(&f), Ok(canopen::Incoming::Tpdo { node, frame: f }));
        prop_assert_eq!(pdo::Tpdo::decode(&f), Ok(pdo::Tpdo::Position { position: pos, mode }));
        let f = CanFrame::new(0x580 + u16::from(node), &bytes).unwrap();
        let d = decode(&f);
        prop_assert_eq!(d.get("command"), Some(f64::from(bytes[0])));
        prop_assert_eq!(d.get("index"), Some(f64::from(u16::from_le_bytes([bytes[1], bytes[2]]))));
        prop_assert_eq!(d.get("subindex"), Some(f64::from(bytes[3])));
        prop_assert_eq!(canopen::decode(&f), Ok(canopen::Incoming::SdoResponse { node, data: bytes }));
    }
}

#[test]
fn the_inclinometer_slope_decodes_to_the_angle_the_controller_uses() {
    use controller::commissioning::InclinometerSetup;
    for raw in [-1234i16, 0, 1, 2600, i16::MAX] {
        let d = decode(&CanFrame::new(0x183, &raw.to_le_bytes()).unwrap());
        assert_eq!(d.message, "TPDO1_Inclinometer");
        let degrees = d.get("slope_long16").unwrap();
        let angle = InclinometerSetup::STOCK.angle(raw);
        assert!((degrees.to_radians() - angle).abs() < 1e-12, "{raw}");
    }
}

/// The two-axis inclinometer's TPDO1 (node 5, 4 bytes) decodes to both slopes in
/// degrees, as the controller reads them at 0.01° per unit.
#[test]
fn the_two_axis_inclinometer_decodes_both_slopes() {
    use controller::cia410::{tpdo1, Slopes};
    let frame = tpdo1(
        5,
        Slopes {
            long: -1234,
            lateral: Some(567),
        },
    );
    let d = decode(&frame);
    assert_eq!(d.message, "TPDO1_Inclinometer2");
    assert!((d.get("slope_long16").unwrap() + 12.34).abs() < 1e-9);
    assert!((d.get("slope_lateral16").unwrap() - 5.67).abs() < 1e-9);
}
