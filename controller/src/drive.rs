//! The driven axes of the crane: a domain type, not a protocol one.

/// The two driven axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Drive {
    /// Trolley drive, input u1.
    Trolley,
    /// Winch drive, input u2.
    Winch,
}

impl Drive {
    /// Both drives, in input order.
    pub const ALL: [Drive; 2] = [Drive::Trolley, Drive::Winch];

    /// CANopen node id.
    #[must_use]
    pub const fn node(self) -> u8 {
        match self {
            Drive::Trolley => 1,
            Drive::Winch => 2,
        }
    }

    /// Position in `[trolley, winch]` arrays.
    #[must_use]
    pub const fn index(self) -> usize {
        match self {
            Drive::Trolley => 0,
            Drive::Winch => 1,
        }
    }

    /// This drive's element of a `[trolley, winch]` pair (no indexing: nothing to panic).
    pub fn of<T>(self, pair: &[T; 2]) -> &T {
        let [trolley, winch] = pair;
        match self {
            Drive::Trolley => trolley,
            Drive::Winch => winch,
        }
    }

    /// This drive's element of a `[trolley, winch]` pair, to change.
    pub fn of_mut<T>(self, pair: &mut [T; 2]) -> &mut T {
        let [trolley, winch] = pair;
        match self {
            Drive::Trolley => trolley,
            Drive::Winch => winch,
        }
    }

    /// The drive with CANopen node id `node`.
    #[must_use]
    pub fn from_node(node: u8) -> Option<Drive> {
        Drive::ALL.into_iter().find(|d| d.node() == node)
    }
}
