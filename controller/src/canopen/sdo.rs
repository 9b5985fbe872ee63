//! CiA 301 service data objects (SDO, 7.2.4): the client the controller commissions its
//! drives with, and the server of its own object dictionary.
//!
//! Both are sans-I/O: they take the data bytes of a received frame and the time, and
//! return the frame to send. The client runs one transfer at a time per server and is
//! driven by the 100 Hz cycle — a transfer never blocks a cycle; a server that does not
//! answer within the timeout fails the transfer (and is told so by an abort).
//!
//! | transfer | request (client → server, 0x600 + node) | response (0x580 + node) |
//! |---|---|---|
//! | expedited download (≤ 4 bytes) | `0x23 \| (4−n)<<2`, index, sub, data | `0x60`, index, sub |
//! | segmented download | `0x21`, index, sub, size; then segments `t<<4 \| (7−n)<<1 \| c` | `0x60`; `0x20 \| t<<4` |
//! | upload | `0x40`, index, sub | `0x43 \| (4−n)<<2` + data (expedited) or `0x41` + size; segments on `0x60 \| t<<4` |
//! | abort | `0x80`, index, sub, abort code (u32) | the same |

use heapless::Vec;

use crate::frame::CanFrame;

/// COB-ID base of requests to a server (its receive SDO), + the server's node id.
pub const REQUEST: u16 = 0x600;
/// COB-ID base of a server's responses (its transmit SDO), + its node id.
pub const RESPONSE: u16 = 0x580;

/// The largest value a transfer carries (the controller reads identities and writes
/// PDO mappings: 4 bytes each; 32 leaves room for a device name).
pub const MAX_VALUE: usize = 32;

/// The bytes of an object's value, little endian as CiA 301 encodes numbers.
pub type Value = Vec<u8, MAX_VALUE>;

/// A value from bytes, cut at [`MAX_VALUE`]. (Not `collect()`: heapless's `FromIterator`
/// panics on overflow, and the link-time panic proof would rightly refuse it.)
#[must_use]
pub fn value(bytes: &[u8]) -> Value {
    let fitting = bytes.get(..bytes.len().min(MAX_VALUE)).unwrap_or(&[]);
    Value::from_slice(fitting).unwrap_or_default()
}

/// An object dictionary entry: index and sub-index.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Object {
    /// Index (0x1000..=0xFFFF).
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
}

impl Object {
    /// The entry `index:sub`.
    #[must_use]
    pub const fn new(index: u16, sub: u8) -> Self {
        Self { index, sub }
    }
}

/// SDO abort codes (CiA 301 Tab. 22) by name: the ones this code sends or names.
pub mod abort {
    /// Toggle bit not alternated.
    pub const TOGGLE: u32 = 0x0503_0000;
    /// SDO protocol timed out.
    pub const TIMEOUT: u32 = 0x0504_0000;
    /// Client/server command specifier not valid or unknown.
    pub const COMMAND: u32 = 0x0504_0001;
    /// Out of memory.
    pub const OUT_OF_MEMORY: u32 = 0x0504_0005;
    /// Unsupported access to an object.
    pub const UNSUPPORTED_ACCESS: u32 = 0x0601_0000;
    /// Attempt to read a write-only object.
    pub const WRITE_ONLY: u32 = 0x0601_0001;
    /// Attempt to write a read-only object.
    pub const READ_ONLY: u32 = 0x0601_0002;
    /// Object does not exist in the object dictionary.
    pub const NO_OBJECT: u32 = 0x0602_0000;
    /// Object cannot be mapped to the PDO.
    pub const NOT_MAPPABLE: u32 = 0x0604_0041;
    /// General parameter incompatibility.
    pub const PARAMETER_INCOMPATIBLE: u32 = 0x0604_0043;
    /// Data type does not match, length of service parameter does not match.
    pub const LENGTH: u32 = 0x0607_0010;
    /// Sub-index does not exist.
    pub const NO_SUB: u32 = 0x0609_0011;
    /// Invalid value for parameter (download only; also named "value range of
    /// parameter exceeded").
    pub const INVALID_VALUE: u32 = 0x0609_0030;
    /// Value of parameter written too high (download only).
    pub const VALUE_TOO_HIGH: u32 = 0x0609_0031;
    /// General error.
    pub const GENERAL: u32 = 0x0800_0000;
    /// Data cannot be transferred or stored to the application.
    pub const CANNOT_STORE: u32 = 0x0800_0020;
    /// … because of the present device state.
    pub const DEVICE_STATE: u32 = 0x0800_0022;

    /// What an abort code means, for logs and docs (CiA 301 Tab. 22).
    #[must_use]
    pub fn describe(code: u32) -> &'static str {
        match code {
            TOGGLE => "toggle bit not alternated",
            TIMEOUT => "SDO protocol timed out",
            COMMAND => "command specifier not valid or unknown",
            0x0504_0002 => "invalid block size",
            0x0504_0003 => "invalid sequence number",
            0x0504_0004 => "CRC error",
            OUT_OF_MEMORY => "out of memory",
            UNSUPPORTED_ACCESS => "unsupported access to an object",
            WRITE_ONLY => "attempt to read a write only object",
            READ_ONLY => "attempt to write a read only object",
            NO_OBJECT => "object does not exist in the object dictionary",
            NOT_MAPPABLE => "object cannot be mapped to the PDO",
            0x0604_0042 => "number and length of objects to be mapped would exceed PDO length",
            PARAMETER_INCOMPATIBLE => "general parameter incompatibility",
            0x0604_0047 => "general internal incompatibility in the device",
            0x0606_0000 => "access failed due to a hardware error",
            LENGTH => "data type does not match, length of service parameter does not match",
            0x0607_0012 => "data type does not match, length of service parameter too high",
            0x0607_0013 => "data type does not match, length of service parameter too low",
            NO_SUB => "sub-index does not exist",
            INVALID_VALUE => "invalid value for parameter",
            VALUE_TOO_HIGH => "value of parameter written too high",
            0x0609_0032 => "value of parameter written too low",
            0x0609_0036 => "maximum value is less than minimum value",
            0x060A_0023 => "resource not available: SDO connection",
            GENERAL => "general error",
            CANNOT_STORE => "data cannot be transferred or stored to the application",
            0x0800_0021 => "… because of local control",
            DEVICE_STATE => "… because of the present device state",
            0x0800_0023 => {
                "object dictionary dynamic generation fails or no object dictionary is present"
            }
            0x0800_0024 => "no data available",
            _ => "unknown abort code",
        }
    }
}

/// Why a transfer failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SdoError {
    /// The server aborted the transfer with this code.
    Aborted {
        /// The object.
        object: Object,
        /// CiA 301 abort code.
        code: u32,
    },
    /// The server did not answer in time (the client sent abort 0x0504_0000).
    Timeout {
        /// The object.
        object: Object,
    },
    /// The server answered out of protocol (the client sent this abort code).
    Protocol {
        /// The object.
        object: Object,
        /// The abort code the client sent.
        code: u32,
    },
}

impl SdoError {
    /// The object the transfer was about.
    #[must_use]
    pub fn object(&self) -> Object {
        match *self {
            SdoError::Aborted { object, .. }
            | SdoError::Timeout { object }
            | SdoError::Protocol { object, .. } => object,
        }
    }

    /// The abort code that ended the transfer (sent or received).
    #[must_use]
    pub fn code(&self) -> u32 {
        match *self {
            SdoError::Aborted { code, .. } | SdoError::Protocol { code, .. } => code,
            SdoError::Timeout { .. } => abort::TIMEOUT,
        }
    }
}

/// What the client asks of the caller after a response or a poll.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// Transmit this frame; the transfer goes on.
    Send(CanFrame),
    /// The transfer finished: a read's bytes, or nothing for a write.
    Complete(Value),
    /// The transfer failed; `abort`, if any, must be transmitted to tell the server.
    Failed {
        /// Why.
        error: SdoError,
        /// The abort frame to send.
        abort: Option<CanFrame>,
    },
}

#[derive(Debug, Clone, PartialEq, Eq)]
enum Transfer {
    Idle,
    DownloadInitiate {
        data: Value,
        segmented: bool,
    },
    DownloadSegment {
        data: Value,
        sent: usize,
        toggle: bool,
    },
    UploadInitiate,
    UploadSegment {
        data: Value,
        toggle: bool,
    },
}

/// An SDO client for one server (one drive): one transfer at a time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SdoClient {
    server: u8,
    timeout_ms: u32,
    object: Object,
    deadline_ms: u64,
    transfer: Transfer,
}

fn bytes(id: u16, data: [u8; 8]) -> CanFrame {
    CanFrame::fixed(id, &data)
}

fn addressed(cs: u8, object: Object, payload: [u8; 4]) -> [u8; 8] {
    let [i0, i1] = object.index.to_le_bytes();
    let [p0, p1, p2, p3] = payload;
    [cs, i0, i1, object.sub, p0, p1, p2, p3]
}

/// The abort frame for `object` with `code`, from a client to `server` or from a server.
#[must_use]
pub fn abort_frame(id: u16, object: Object, code: u32) -> CanFrame {
    bytes(id, addressed(0x80, object, code.to_le_bytes()))
}

impl SdoClient {
    /// A client of the server with node id `server`; a transfer whose server has not
    /// answered within `timeout_ms` fails.
    #[must_use]
    pub fn new(server: u8, timeout_ms: u32) -> Self {
        Self {
            server,
            timeout_ms,
            object: Object::new(0, 0),
            deadline_ms: 0,
            transfer: Transfer::Idle,
        }
    }

    /// COB-ID of this client's requests.
    #[must_use]
    pub fn request_id(&self) -> u16 {
        REQUEST + u16::from(self.server)
    }

    /// COB-ID of the server's responses.
    #[must_use]
    pub fn response_id(&self) -> u16 {
        RESPONSE + u16::from(self.server)
    }

    /// Whether a transfer is running.
    #[must_use]
    pub fn busy(&self) -> bool {
        self.transfer != Transfer::Idle
    }

    /// Forgets a running transfer (the server rebooted: it has forgotten it too).
    pub fn cancel(&mut self) {
        self.transfer = Transfer::Idle;
    }

    fn start(&mut self, object: Object, transfer: Transfer, now_ms: u64) {
        self.object = object;
        self.transfer = transfer;
        self.deadline_ms = now_ms.saturating_add(u64::from(self.timeout_ms));
    }

    /// Starts reading `object`; the frame to transmit. A running transfer is dropped.
    pub fn read(&mut self, object: Object, now_ms: u64) -> CanFrame {
        self.start(object, Transfer::UploadInitiate, now_ms);
        bytes(self.request_id(), addressed(0x40, object, [0; 4]))
    }

    /// Starts writing `data` (at most [`MAX_VALUE`] bytes; more are cut) to `object`:
    /// expedited up to 4 bytes, segmented beyond. The frame to transmit.
    pub fn write(&mut self, object: Object, data: &[u8], now_ms: u64) -> CanFrame {
        let data = value(data);
        let len = data.len();
        let (frame, segmented) = if len <= 4 {
            let mut payload = [0; 4];
            for (p, d) in payload.iter_mut().zip(&data) {
                *p = *d;
            }
            // e = 1, s = 1, n = 4 − len unused bytes.
            let cs = 0x23 | (((4 - len) as u8) << 2);
            (addressed(cs, object, payload), false)
        } else {
            (addressed(0x21, object, (len as u32).to_le_bytes()), true)
        };
        self.start(
            object,
            Transfer::DownloadInitiate { data, segmented },
            now_ms,
        );
        bytes(self.request_id(), frame)
    }

    /// Fails the running transfer if its server has not answered by now.
    pub fn poll(&mut self, now_ms: u64) -> Option<Event> {
        if self.transfer == Transfer::Idle || now_ms < self.deadline_ms {
            return None;
        }
        Some(self.fail(SdoError::Timeout {
            object: self.object,
        }))
    }

    fn fail(&mut self, error: SdoError) -> Event {
        self.transfer = Transfer::Idle;
        let abort = match error {
            SdoError::Aborted { .. } => None,
            SdoError::Timeout { .. } | SdoError::Protocol { .. } => {
                Some(abort_frame(self.request_id(), self.object, error.code()))
            }
        };
        Event::Failed { error, abort }
    }

    fn protocol(&mut self, code: u32) -> Event {
        self.fail(SdoError::Protocol {
            object: self.object,
            code,
        })
    }

    fn next_segment(&mut self, data: Value, sent: usize, toggle: bool, now_ms: u64) -> Event {
        let rest = data.get(sent..).unwrap_or(&[]);
        let n = rest.len().min(7);
        let last = sent + n >= data.len();
        let mut frame = [0; 8];
        frame[0] = (u8::from(toggle) << 4) | (((7 - n) as u8) << 1) | u8::from(last);
        for (f, d) in frame.iter_mut().skip(1).zip(rest.iter().take(n)) {
            *f = *d;
        }
        self.start(
            self.object,
            Transfer::DownloadSegment {
                data,
                sent: sent + n,
                toggle,
            },
            now_ms,
        );
        Event::Send(bytes(self.request_id(), frame))
    }

    /// Takes the data of a frame received on [`Self::response_id`]. `None`: the frame
    /// is not an answer to a running transfer (ignored by the caller, and counted).
    pub fn on_response(&mut self, data: &[u8], now_ms: u64) -> Option<Event> {
        let &[cs, i0, i1, sub, d0, d1, d2, d3] = data else {
            return (self.transfer != Transfer::Idle).then(|| self.protocol(abort::COMMAND));
        };
        let object = Object::new(u16::from_le_bytes([i0, i1]), sub);
        let payload = [d0, d1, d2, d3];
        let transfer = core::mem::replace(&mut self.transfer, Transfer::Idle);
        if transfer == Transfer::Idle {
            return None;
        }
        let initiate = matches!(
            transfer,
            Transfer::DownloadInitiate { .. } | Transfer::UploadInitiate
        );
        if cs == 0x80 {
            // An abort names its object; one for another object is not ours.
            if object != self.object {
                self.transfer = transfer;
                return None;
            }
            return Some(self.fail(SdoError::Aborted {
                object,
                code: u32::from_le_bytes(payload),
            }));
        }
        if initiate && object != self.object {
            return Some(self.protocol(abort::GENERAL));
        }
        Some(match transfer {
            Transfer::Idle => return None,
            Transfer::DownloadInitiate { data, segmented } => {
                if cs != 0x60 {
                    self.protocol(abort::COMMAND)
                } else if segmented {
                    self.next_segment(data, 0, false, now_ms)
                } else {
                    Event::Complete(Value::new())
                }
            }
            Transfer::DownloadSegment { data, sent, toggle } => {
                if cs & 0xE0 != 0x20 {
                    self.protocol(abort::COMMAND)
                } else if (cs & 0x10 != 0) != toggle {
                    self.protocol(abort::TOGGLE)
                } else if sent >= data.len() {
                    Event::Complete(Value::new())
                } else {
                    self.next_segment(data, sent, !toggle, now_ms)
                }
            }
            Transfer::UploadInitiate => match cs & 0xE3 {
                // Expedited: n unused bytes if the size is indicated.
                0x43 => {
                    let unused = usize::from((cs >> 2) & 0x03);
                    Event::Complete(value(payload.get(..4 - unused).unwrap_or(&payload)))
                }
                // Expedited without size: all four bytes.
                0x42 => Event::Complete(value(&payload)),
                // Segmented: the size follows (checked against what arrives).
                0x41 | 0x40 => {
                    let size = u32::from_le_bytes(payload);
                    if cs & 0x01 != 0 && size as usize > MAX_VALUE {
                        self.protocol(abort::OUT_OF_MEMORY)
                    } else {
                        self.start(
                            self.object,
                            Transfer::UploadSegment {
                                data: Value::new(),
                                toggle: false,
                            },
                            now_ms,
                        );
                        Event::Send(bytes(self.request_id(), [0x60, 0, 0, 0, 0, 0, 0, 0]))
                    }
                }
                _ => self.protocol(abort::COMMAND),
            },
            Transfer::UploadSegment { mut data, toggle } => {
                if cs & 0xE0 != 0x00 {
                    self.protocol(abort::COMMAND)
                } else if (cs & 0x10 != 0) != toggle {
                    self.protocol(abort::TOGGLE)
                } else {
                    let n = 7 - usize::from((cs >> 1) & 0x07);
                    let segment = data_after_command(data.len(), n);
                    let received = [i0, i1, sub, d0, d1, d2, d3];
                    if segment.is_none()
                        || data
                            .extend_from_slice(received.get(..n).unwrap_or(&[]))
                            .is_err()
                    {
                        self.protocol(abort::OUT_OF_MEMORY)
                    } else if cs & 0x01 != 0 {
                        Event::Complete(data)
                    } else {
                        let next = !toggle;
                        self.start(
                            self.object,
                            Transfer::UploadSegment { data, toggle: next },
                            now_ms,
                        );
                        Event::Send(bytes(
                            self.request_id(),
                            [0x60 | (u8::from(next) << 4), 0, 0, 0, 0, 0, 0, 0],
                        ))
                    }
                }
            }
        })
    }
}

/// Whether `n` more bytes fit after `have` (a segment carries at most 7).
fn data_after_command(have: usize, n: usize) -> Option<usize> {
    (n <= 7 && have + n <= MAX_VALUE).then_some(have + n)
}

/// Access to an object dictionary, for the SDO server. Values are little endian.
pub trait ObjectDictionary {
    /// The value of `object`, or the abort code that says why not.
    fn read(&self, object: Object) -> Result<Value, u32>;
    /// Writes `data` to `object`, or the abort code that says why not.
    fn write(&mut self, object: Object, data: &[u8]) -> Result<(), u32>;
}

/// The SDO server's answer to one request (expedited transfers; every object of the
/// controller fits 4 bytes, so a segmented request is answered with an abort).
/// `None` for a frame that is not 8 bytes long (CiA 301: such a request is ignored).
///
/// An abort carries the multiplexer (index, sub-index) of the transfer it ends (CiA 301
/// 7.2.4.3.17). Only an initiate request names one (bytes 1–3); a segment's bytes 1–7
/// are data. The server runs no transfer beyond the initiate's exchange, so a stray
/// segment — download or upload, or a block transfer's sub-command — is aborted with
/// 0x0504_0001 (command specifier not valid) naming no object: 0000h sub 0.
pub fn serve(od: &mut impl ObjectDictionary, node: u8, request: &[u8]) -> Option<CanFrame> {
    let &[cs, i0, i1, sub, d0, d1, d2, d3] = request else {
        return None;
    };
    let object = if initiates(cs) {
        Object::new(u16::from_le_bytes([i0, i1]), sub)
    } else {
        Object::new(0, 0)
    };
    let id = RESPONSE + u16::from(node);
    let abort = |code: u32| Some(abort_frame(id, object, code));
    match cs & 0xE0 {
        // Initiate download: expedited only.
        0x20 => {
            if cs & 0x02 == 0 {
                return abort(abort::COMMAND);
            }
            let len = if cs & 0x01 != 0 {
                4 - usize::from((cs >> 2) & 0x03)
            } else {
                4
            };
            let data = [d0, d1, d2, d3];
            match od.write(object, data.get(..len).unwrap_or(&[])) {
                Ok(()) => Some(bytes(id, addressed(0x60, object, [0; 4]))),
                Err(code) => abort(code),
            }
        }
        // Initiate upload.
        0x40 => match od.read(object) {
            Ok(value) if value.len() <= 4 => {
                let mut payload = [0; 4];
                for (p, v) in payload.iter_mut().zip(&value) {
                    *p = *v;
                }
                let cs = 0x43 | (((4 - value.len()) as u8) << 2);
                Some(bytes(id, addressed(cs, object, payload)))
            }
            Ok(_) => abort(abort::UNSUPPORTED_ACCESS),
            Err(code) => abort(code),
        },
        // An abort from the client ends nothing here: every transfer is one exchange.
        0x80 => None,
        _ => abort(abort::COMMAND),
    }
}

/// Whether a client's request with command byte `cs` initiates a transfer, and so names
/// its object in bytes 1–3 (CiA 301 7.2.4.3): initiate download (ccs 1), initiate upload
/// (2), block upload initiate (5, subcommand 0), block download initiate (6, cs bit 0
/// clear). Segments (ccs 0, 3), the block transfers' other sub-commands and an unknown
/// ccs (7) carry data or nothing there. An abort (ccs 4) names its object too.
fn initiates(cs: u8) -> bool {
    match cs >> 5 {
        1 | 2 | 4 => true,
        5 => cs & 0x03 == 0,
        6 => cs & 0x01 == 0,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
    use super::*;

    const OBJ: Object = Object::new(0x1018, 1);

    #[test]
    fn expedited_read_and_write() {
        let mut c = SdoClient::new(1, 100);
        let f = c.read(OBJ, 0);
        assert_eq!(f.id(), 0x601);
        assert_eq!(f.data(), &[0x40, 0x18, 0x10, 1, 0, 0, 0, 0]);
        let got = c.on_response(&[0x43, 0x18, 0x10, 1, 0x78, 0x56, 0x34, 0x12], 5);
        assert_eq!(
            got,
            Some(Event::Complete(
                Value::from_slice(&[0x78, 0x56, 0x34, 0x12]).unwrap()
            ))
        );
        assert!(!c.busy());

        let f = c.write(Object::new(0x6060, 0), &[9], 10);
        assert_eq!(f.data(), &[0x2F, 0x60, 0x60, 0, 9, 0, 0, 0]);
        assert_eq!(
            c.on_response(&[0x60, 0x60, 0x60, 0, 0, 0, 0, 0], 11),
            Some(Event::Complete(Value::new()))
        );
        // An answer nobody asked for is not an event.
        assert_eq!(c.on_response(&[0x60, 0x60, 0x60, 0, 0, 0, 0, 0], 12), None);
    }

    #[test]
    fn segmented_upload_and_download() {
        let mut c = SdoClient::new(2, 100);
        c.read(Object::new(0x1008, 0), 0);
        let Some(Event::Send(f)) = c.on_response(&[0x41, 0x08, 0x10, 0, 10, 0, 0, 0], 1) else {
            panic!("segment request expected")
        };
        assert_eq!(f.data()[0], 0x60);
        let Some(Event::Send(f)) =
            c.on_response(&[0x00, b'c', b'r', b'a', b'n', b'e', b'-', b'd'], 2)
        else {
            panic!("second segment request expected")
        };
        assert_eq!(f.data()[0], 0x70);
        // Last segment: 3 bytes (n = 4 unused), c = 1, toggle 1.
        let got = c.on_response(&[0x10 | (4 << 1) | 1, b'r', b'v', b'1', 0, 0, 0, 0], 3);
        assert_eq!(
            got,
            Some(Event::Complete(Value::from_slice(b"crane-drv1").unwrap()))
        );

        let data = *b"0123456789";
        let f = c.write(Object::new(0x2000, 1), &data, 10);
        assert_eq!(f.data(), &[0x21, 0, 0x20, 1, 10, 0, 0, 0]);
        let Some(Event::Send(f)) = c.on_response(&[0x60, 0, 0x20, 1, 0, 0, 0, 0], 11) else {
            panic!("first segment expected")
        };
        assert_eq!(f.data(), &[0x00, b'0', b'1', b'2', b'3', b'4', b'5', b'6']);
        let Some(Event::Send(f)) = c.on_response(&[0x20, 0, 0, 0, 0, 0, 0, 0], 12) else {
            panic!("second segment expected")
        };
        assert_eq!(
            f.data(),
            &[0x10 | (4 << 1) | 1, b'7', b'8', b'9', 0, 0, 0, 0]
        );
        assert_eq!(
            c.on_response(&[0x30, 0, 0, 0, 0, 0, 0, 0], 13),
            Some(Event::Complete(Value::new()))
        );
    }

    #[test]
    fn aborts_timeouts_and_protocol_errors() {
        let mut c = SdoClient::new(1, 100);
        c.write(Object::new(0x6060, 0), &[9], 0);
        let got = c.on_response(&[0x80, 0x60, 0x60, 0, 0x30, 0, 0x09, 0x06], 1);
        assert_eq!(
            got,
            Some(Event::Failed {
                error: SdoError::Aborted {
                    object: Object::new(0x6060, 0),
                    code: abort::INVALID_VALUE
                },
                abort: None
            })
        );
        assert_eq!(
            abort::describe(abort::INVALID_VALUE),
            "invalid value for parameter"
        );

        c.read(OBJ, 1000);
        assert_eq!(c.poll(1099), None);
        let Some(Event::Failed {
            error,
            abort: Some(f),
        }) = c.poll(1100)
        else {
            panic!("timeout expected")
        };
        assert_eq!(error, SdoError::Timeout { object: OBJ });
        assert_eq!(f.data(), &[0x80, 0x18, 0x10, 1, 0, 0, 0x04, 0x05]);

        // A toggle error in a segmented upload is the client's abort.
        c.read(Object::new(0x1008, 0), 0);
        c.on_response(&[0x41, 0x08, 0x10, 0, 10, 0, 0, 0], 1);
        let got = c.on_response(&[0x10, 1, 2, 3, 4, 5, 6, 7], 2);
        assert!(matches!(
            got,
            Some(Event::Failed {
                error: SdoError::Protocol {
                    code: abort::TOGGLE,
                    ..
                },
                abort: Some(_)
            })
        ));
        // A response for another object fails the transfer rather than being taken as ours.
        c.read(OBJ, 0);
        assert!(matches!(
            c.on_response(&[0x43, 0x00, 0x10, 0, 1, 2, 3, 4], 1),
            Some(Event::Failed {
                error: SdoError::Protocol { .. },
                ..
            })
        ));
    }

    struct Od(u32);
    impl ObjectDictionary for Od {
        fn read(&self, o: Object) -> Result<Value, u32> {
            match (o.index, o.sub) {
                (0x1017, 0) => Ok(Value::from_slice(&(self.0 as u16).to_le_bytes()).unwrap()),
                (0x1000, 0) => Ok(Value::from_slice(&0x0000_0000u32.to_le_bytes()).unwrap()),
                _ => Err(abort::NO_OBJECT),
            }
        }
        fn write(&mut self, o: Object, d: &[u8]) -> Result<(), u32> {
            match (o.index, o.sub, d) {
                (0x1017, 0, &[a, b]) => {
                    self.0 = u32::from(u16::from_le_bytes([a, b]));
                    Ok(())
                }
                (0x1017, 0, _) => Err(abort::LENGTH),
                (0x1000, 0, _) => Err(abort::READ_ONLY),
                _ => Err(abort::NO_OBJECT),
            }
        }
    }

    #[test]
    fn server_answers_expedited_transfers_and_a_client_understands_it() {
        let mut od = Od(100);
        let mut c = SdoClient::new(0x10, 100);
        let req = c.read(Object::new(0x1017, 0), 0);
        let resp = serve(&mut od, 0x10, req.data()).unwrap();
        assert_eq!(resp.id(), 0x590);
        assert_eq!(resp.data(), &[0x4B, 0x17, 0x10, 0, 100, 0, 0, 0]);
        assert_eq!(
            c.on_response(resp.data(), 1),
            Some(Event::Complete(Value::from_slice(&[100, 0]).unwrap()))
        );
        let req = c.write(Object::new(0x1017, 0), &250u16.to_le_bytes(), 2);
        let resp = serve(&mut od, 0x10, req.data()).unwrap();
        assert_eq!(
            c.on_response(resp.data(), 3),
            Some(Event::Complete(Value::new()))
        );
        assert_eq!(od.0, 250);
        // Read-only, missing, segmented, wrong length, unknown command: aborts.
        let req = c.write(Object::new(0x1000, 0), &[1, 2, 3, 4], 4);
        assert_eq!(
            serve(&mut od, 0x10, req.data()).unwrap().data(),
            &[0x80, 0, 0x10, 0, 0x02, 0, 0x01, 0x06]
        );
        let resp = serve(&mut od, 0x10, &[0x40, 0x34, 0x12, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(
            u32::from_le_bytes(resp.data()[4..8].try_into().unwrap()),
            abort::NO_OBJECT
        );
        let resp = serve(&mut od, 0x10, &[0x21, 0x17, 0x10, 0, 9, 0, 0, 0]).unwrap();
        assert_eq!(
            u32::from_le_bytes(resp.data()[4..8].try_into().unwrap()),
            abort::COMMAND
        );
        let resp = serve(&mut od, 0x10, &[0x2F, 0x17, 0x10, 0, 9, 0, 0, 0]).unwrap();
        assert_eq!(
            u32::from_le_bytes(resp.data()[4..8].try_into().unwrap()),
            abort::LENGTH
        );
        assert_eq!(serve(&mut od, 0x10, &[0x40, 0x17]), None);
    }

    /// A stray segment's bytes are data, not an object: its abort names none (issue 32,
    /// item 7: the data bytes were echoed as index and sub-index).
    #[test]
    fn a_stray_segment_is_aborted_naming_no_object() {
        let mut od = Od(100);
        // Download segments (toggle 0 and 1, last or not), an upload segment request,
        // a block download's end, a block upload's start, an unknown ccs.
        for cs in [0x00, 0x0B, 0x10, 0x1F, 0x60, 0x70, 0xC1, 0xA3, 0xE0] {
            let resp = serve(&mut od, 0x10, &[cs, 0x17, 0x10, 0x05, 1, 2, 3, 4]).unwrap();
            assert_eq!(
                resp.data(),
                &[0x80, 0, 0, 0, 0x01, 0x00, 0x04, 0x05],
                "cs 0x{cs:02X}"
            );
        }
        // Block initiates name their object (and are not supported here).
        for cs in [0xA0, 0xC0, 0xC6] {
            let resp = serve(&mut od, 0x10, &[cs, 0x17, 0x10, 0, 0, 0, 0, 0]).unwrap();
            assert_eq!(&resp.data()[..4], &[0x80, 0x17, 0x10, 0], "cs 0x{cs:02X}");
        }
        assert_eq!(od.0, 100, "nothing written");
    }
}
