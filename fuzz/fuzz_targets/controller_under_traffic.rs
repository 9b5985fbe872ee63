//! The whole controller, on the virtual bus with the paper's move, under arbitrary
//! frames at arbitrary cycles — requests of every kind among them: no panic, and every
//! set point it sends is within the drive limits, cycle after cycle.
#![no_main]

use crane_fuzz::{under_traffic, Rig};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|events: Vec<(u8, u16, Vec<u8>)>| {
    let mut rig = Rig::after(5);
    // Half of the ids land on the controller's own command and the drives' TPDOs.
    under_traffic(&mut rig, &events, |id| match id % 4 {
        0 => 0x210,
        1 => 0x181 + (id >> 2) % 2,
        _ => id & 0x7FF,
    });
});
