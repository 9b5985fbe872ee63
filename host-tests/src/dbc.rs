//! Decoding frames with the DBC file that documents them (`can/crane.dbc`), so the
//! encoder is checked against what standard CAN tools will read, and the firmware's
//! log is printed in signal names and units.

use std::fmt;

use can_dbc::{ByteOrder, MessageId, MultiplexIndicator, Signal as DbcSignal, ValueType};

/// A parsed DBC file.
pub struct Dbc(can_dbc::Dbc);

/// One decoded signal.
#[derive(Debug, Clone, PartialEq)]
pub struct Signal {
    /// Signal name.
    pub name: String,
    /// Physical value (raw · factor + offset).
    pub value: f64,
    /// Unit.
    pub unit: String,
    /// The DBC's name for the value (`VAL_`), if it has one.
    pub label: Option<String>,
}

/// One decoded frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Decoded {
    /// Message name.
    pub message: String,
    /// Its signals, in DBC order.
    pub signals: Vec<Signal>,
}

impl Decoded {
    /// The value of a signal, if the message has it.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.signals
            .iter()
            .find(|s| s.name == name)
            .map(|s| s.value)
    }
}

impl fmt::Display for Decoded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.message)?;
        for s in &self.signals {
            let unit = if s.unit.is_empty() {
                String::new()
            } else {
                format!(" {}", s.unit)
            };
            if s.value.fract() == 0.0 && s.value.abs() < 1e15 {
                write!(f, " {}={}{unit}", s.name, s.value as i64)?;
            } else {
                write!(f, " {}={:.6}{unit}", s.name, s.value)?;
            }
            if let Some(label) = &s.label {
                write!(f, "({label})")?;
            }
        }
        Ok(())
    }
}

/// The repository's DBC file.
pub const CRANE_DBC: &str = include_str!("../../can/crane.dbc");

impl Dbc {
    /// Parses DBC text.
    pub fn parse(text: &str) -> Result<Self, String> {
        can_dbc::Dbc::try_from(text)
            .map(Self)
            .map_err(|e| format!("DBC: {e:?}"))
    }

    /// The repository's `can/crane.dbc`.
    pub fn crane() -> Result<Self, String> {
        Self::parse(CRANE_DBC)
    }

    /// Number of messages defined.
    pub fn messages(&self) -> usize {
        self.0.messages.len()
    }

    /// The bit lengths of a message's fields, in the order of their start bits (a
    /// byte of bit signals is one 8-bit field).
    pub fn signal_sizes(&self, id: u16) -> Option<Vec<u64>> {
        self.0
            .messages
            .iter()
            .find(|m| m.id == MessageId::Standard(id))
            .map(|m| {
                // A field that multiplexed signals share (the status frame's byte 2:
                // a reason, or an overload answer's count) is one field of the layout.
                // Bits that share one byte (the operator frame's flags) are that byte,
                // one mapped UNSIGNED8.
                let mut fields: Vec<(u64, u64)> = m
                    .signals
                    .iter()
                    .map(|s| {
                        let in_one_byte = s.size > 0
                            && s.size < 8
                            && s.start_bit / 8 == (s.start_bit + s.size - 1) / 8;
                        if in_one_byte {
                            (s.start_bit / 8 * 8, 8)
                        } else {
                            (s.start_bit, s.size)
                        }
                    })
                    .collect();
                fields.sort_unstable();
                fields.dedup();
                fields.into_iter().map(|(_, size)| size).collect()
            })
    }

    /// Decodes a frame by the DBC's definition; refuses unknown ids and wrong lengths.
    pub fn decode(&self, id: u16, data: &[u8]) -> Result<Decoded, String> {
        let message = self
            .0
            .messages
            .iter()
            .find(|m| m.id == MessageId::Standard(id))
            .ok_or_else(|| format!("id {id:#05x} is not in the DBC"))?;
        if message.size != data.len() as u64 {
            return Err(format!(
                "{}: {} bytes, the DBC says {}",
                message.name,
                data.len(),
                message.size
            ));
        }
        let mut bytes = [0u8; 8];
        bytes.iter_mut().zip(data).for_each(|(b, d)| *b = *d);
        let word = u64::from_le_bytes(bytes);
        let raw_bits = |s: &DbcSignal| {
            if s.byte_order != ByteOrder::LittleEndian || s.size == 0 || s.start_bit + s.size > 64 {
                return Err(format!(
                    "{}.{}: only little-endian signals within 8 bytes",
                    message.name, s.name
                ));
            }
            let mask = if s.size == 64 {
                u64::MAX
            } else {
                (1u64 << s.size) - 1
            };
            Ok((word >> s.start_bit) & mask)
        };
        // Multiplexing: a signal marked `mK` is present when the multiplexor (`M`) is K,
        // or, with `SG_MUL_VAL_` ranges (extended multiplexing), within one of them.
        let switch = message
            .signals
            .iter()
            .find(|s| s.multiplexer_indicator == MultiplexIndicator::Multiplexor)
            .map(raw_bits)
            .transpose()?;
        let present = |s: &DbcSignal| match (&s.multiplexer_indicator, switch) {
            (MultiplexIndicator::MultiplexedSignal(k), Some(value)) => {
                let ranges: Vec<_> = self
                    .0
                    .extended_multiplex
                    .iter()
                    .filter(|e| e.message_id == message.id && e.signal_name == s.name)
                    .flat_map(|e| e.mappings.iter().map(|m| m.min_value..=m.max_value))
                    .collect();
                if ranges.is_empty() {
                    value == *k
                } else {
                    ranges.iter().any(|r| r.contains(&value))
                }
            }
            _ => true,
        };
        let signals = message
            .signals
            .iter()
            .filter(|s| present(s))
            .map(|s| {
                let raw = raw_bits(s)?;
                let raw = match s.value_type {
                    ValueType::Unsigned => raw as f64,
                    ValueType::Signed => {
                        let shift = 64 - s.size;
                        (((raw << shift) as i64) >> shift) as f64
                    }
                };
                let label = self
                    .0
                    .value_descriptions_for_signal(message.id, &s.name)
                    .and_then(|d| d.iter().find(|v| v.id as f64 == raw))
                    .map(|v| v.description.clone());
                Ok(Signal {
                    name: s.name.clone(),
                    value: raw * s.factor + s.offset,
                    unit: s.unit.clone(),
                    label,
                })
            })
            .collect::<Result<Vec<_>, String>>()?;
        Ok(Decoded {
            message: message.name.clone(),
            signals,
        })
    }
}
