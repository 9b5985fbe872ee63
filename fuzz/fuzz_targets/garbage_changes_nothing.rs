//! Garbage in the middle of the paper's move: frames the decoder refuses change no set
//! point and no mode — the controller fed them and its twin that never saw them send
//! the same set points for the next cycles. (A frame on one of the controller's own
//! COB-IDs is no garbage, whatever its bytes: another node has its node id, a fault by
//! rule — `controller/tests/plausibility.rs`.)
#![no_main]

use std::sync::LazyLock;

use controller::canopen;
use controller::cia402::pdo::Tpdo;
use controller::CanFrame;
use crane_fuzz::Rig;
use libfuzzer_sys::fuzz_target;

/// Drives enabled, the move under way (3 s).
static MID_MOVE: LazyLock<Rig> = LazyLock::new(|| Rig::after(300));

fuzz_target!(|frames: Vec<(u16, Vec<u8>)>| {
    let base = &*MID_MOVE;
    let mut noisy = Rig {
        controller: base.controller.clone(),
        bus: base.bus.clone(),
        cycle: base.cycle,
    };
    let mut clean = Rig {
        controller: base.controller.clone(),
        bus: base.bus.clone(),
        cycle: base.cycle,
    };
    let now = u64::from(noisy.now_ms());
    let mut fed = 0;
    for (id, data) in frames.iter().take(64) {
        let Ok(frame) = CanFrame::new(id & 0x7FF, data) else {
            continue;
        };
        let own = canopen::cob::produced_by(controller::canopen::CONTROLLER_NODE, frame.id());
        // Refused by CiA 301, or a drive's TPDO CiA 402 refuses (the default scene has
        // no inclinometer).
        let refused = match canopen::decode(&frame) {
            Err(_) => true,
            Ok(canopen::Incoming::Tpdo { frame, .. }) => Tpdo::decode(&frame).is_err(),
            Ok(_) => false,
        };
        if refused && !own {
            noisy.controller.on_frame(&frame, now);
            fed += 1;
        }
    }
    assert_eq!(
        noisy.controller.counters().frames_ignored,
        clean.controller.counters().frames_ignored + fed
    );
    for _ in 0..3 {
        let (a, b) = (clean.step(), noisy.step());
        assert_eq!(a.setpoints, b.setpoints);
        assert_eq!(a.mode, b.mode);
    }
});
