//! The controller with the state feedback, on the virtual bus's plant during the paper's
//! move, under arbitrary frames at arbitrary cycles — half of them the inclinometer's
//! (slopes of any value, heartbeats of any state, SDO answers of any content) and the
//! drives' positions: no panic, and every set point it sends is within the drive limits,
//! cycle after cycle.
#![no_main]

use crane_fuzz::{under_traffic, Rig};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|events: Vec<(u8, u16, Vec<u8>)>| {
    // Ready, the move not begun (it starts at 1 s).
    let mut rig = Rig::closed_loop(80);
    under_traffic(&mut rig, &events, |id| match id % 8 {
        0 | 1 => 0x183,
        2 => 0x703,
        3 => 0x583,
        4 => 0x281 + (id >> 3) % 2,
        5 => 0x083,
        _ => id & 0x7FF,
    });
});
