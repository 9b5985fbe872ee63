//! The whole controller, on the virtual bus with the paper's move, under arbitrary
//! frames at arbitrary cycles — requests of every kind among them: no panic, and every
//! set point it sends is within the drive limits, cycle after cycle.
#![no_main]

use controller::CanFrame;
use crane_fuzz::{assert_admissible, Rig};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|events: Vec<(u8, u16, Vec<u8>)>| {
    let mut rig = Rig::after(5);
    let mut last = [0i64; 2];
    for (gap, id, data) in events.iter().take(32) {
        for _ in 0..*gap {
            let out = rig.step();
            assert_admissible(&out.frames, &mut last);
        }
        // Half of the ids land on the controller's own command and the drives' TPDOs.
        let id = match id % 4 {
            0 => 0x210,
            1 => 0x181 + (id >> 2) % 2,
            _ => id & 0x7FF,
        };
        if let Ok(frame) = CanFrame::new(id, data) {
            rig.controller.on_frame(&frame, u64::from(rig.now_ms()));
        }
    }
    for _ in 0..100 {
        let out = rig.step();
        assert_admissible(&out.frames, &mut last);
    }
});
