//! Every frame decoder on arbitrary frames: no panic; a command or 3D move that decodes
//! encodes back to the same bytes; the request staged in 0x2000 (a PLC without PDOs)
//! from arbitrary field values: no panic, and what it decodes to encodes back to its
//! fields (the command frame's, or for command 4 the 3D move frame's); an operator frame
//! (RPDO3) that decodes encodes back to the same bytes.
#![no_main]

use controller::commands::{decode_move3d, decode_request, request_frame};
use controller::node::{StagedRequest, MOVE3D_COMMAND};
use controller::operator::decode_operator;
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
    if let Ok(request) = decode_move3d(frame.data()) {
        assert_eq!(request_frame(&request).data(), frame.data(), "{request:?}");
    }
    if let Ok(operator) = decode_operator(frame.data()) {
        assert_eq!(operator.bytes(), frame.data(), "{operator:?}");
    }
    let mut staged = StagedRequest::default();
    for (field, byte) in staged
        .bytes
        .iter_mut()
        .chain(staged.y_and_duration.iter_mut())
        .zip(&data)
    {
        *field = *byte;
    }
    if let Ok(request) = staged.request() {
        let [id, command, x0, x1, z0, z1, ..] = staged.bytes;
        let [y0, y1, seconds] = staged.y_and_duration;
        let expected = if command == MOVE3D_COMMAND {
            [id, x0, x1, y0, y1, z0, z1, seconds]
        } else {
            staged.bytes
        };
        assert_eq!(request_frame(&request).data(), expected, "{staged:?}");
    }
});
