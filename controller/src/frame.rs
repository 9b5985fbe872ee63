//! A classic CAN data frame with an 11-bit identifier, as CANopen uses.

/// A CAN frame: 11-bit identifier, 0..=8 data bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CanFrame {
    id: u16,
    len: u8,
    data: [u8; 8],
}

/// Why bytes off the bus do not make a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The identifier does not fit 11 bits.
    IdTooLarge(u16),
    /// More than 8 data bytes.
    TooLong(usize),
}

impl CanFrame {
    /// Largest 11-bit identifier.
    pub const MAX_ID: u16 = 0x7FF;

    /// A frame from an identifier and up to 8 bytes.
    pub fn new(id: u16, data: &[u8]) -> Result<Self, FrameError> {
        if id > Self::MAX_ID {
            return Err(FrameError::IdTooLarge(id));
        }
        let mut bytes = [0; 8];
        bytes
            .get_mut(..data.len())
            .ok_or(FrameError::TooLong(data.len()))?
            .copy_from_slice(data);
        Ok(Self {
            id,
            len: data.len() as u8,
            data: bytes,
        })
    }

    /// A frame whose id and length are fixed by design (the controller's own, a
    /// simulated node's): the id is masked to 11 bits and the data cut at 8 bytes, so
    /// this cannot fail.
    #[must_use]
    pub fn fixed(id: u16, data: &[u8]) -> Self {
        let mut bytes = [0; 8];
        for (b, d) in bytes.iter_mut().zip(data) {
            *b = *d;
        }
        Self {
            id: id & Self::MAX_ID,
            len: data.len().min(8) as u8,
            data: bytes,
        }
    }

    /// The 11-bit identifier (COB-ID).
    #[must_use]
    pub fn id(&self) -> u16 {
        self.id
    }

    /// The data bytes.
    #[must_use]
    pub fn data(&self) -> &[u8] {
        self.data.get(..usize::from(self.len)).unwrap_or(&[])
    }
}
