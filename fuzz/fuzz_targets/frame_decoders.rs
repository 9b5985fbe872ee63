//! Every frame decoder on arbitrary frames: no panic; a command that decodes encodes
//! back to the same bytes.
#![no_main]

use controller::commands::{decode_request, request_frame};
use controller::CanFrame;
use controller::{canopen, cia402, cia410};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: (u16, Vec<u8>)| {
    let (id, data) = input;
    let Ok(frame) = CanFrame::new(id & 0x7FF, &data) else {
        assert!(data.len() > 8, "only over-long data is refused");
        return;
    };
    if let Ok(canopen::Incoming::Tpdo { frame, .. }) = canopen::decode(&frame) {
        let _ = cia402::pdo::Tpdo::decode(&frame);
        let _ = cia410::decode_tpdo1(&frame, false);
        let _ = cia410::decode_tpdo1(&frame, true);
    }
    if let Ok(request) = decode_request(frame.data()) {
        assert_eq!(request_frame(&request).data(), frame.data(), "{request:?}");
    }
});
