//! The driven axes of a crane: a domain type, not a protocol one.
//!
//! A crane names its drives in the order of its model's inputs u1 … uA
//! ([`crate::planner::Crane::DRIVES`]): the paper's planar crane `[Trolley, Winch]`, the
//! 3D crane `[Bridge, Trolley, Winch]`. Everything the controller keeps per drive is an
//! array in that order, looked up through [`position`].

/// A driven axis. With feature `serde`, a commissioning file's `axis = "trolley"`,
/// `"winch"` or `"bridge"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Deserialize),
    serde(rename_all = "kebab-case")
)]
pub enum Drive {
    /// Trolley drive: the planar crane's x (input u1), the 3D crane's y (u2).
    Trolley,
    /// Winch (hoist) drive: the rope length l, the last input.
    Winch,
    /// Bridge drive: the 3D crane's x along the runway (u1).
    Bridge,
}

/// The planar crane's drives, in input order (the paper's Eq. 24: u1 trolley, u2 winch).
pub const PLANAR: [Drive; 2] = [Drive::Trolley, Drive::Winch];

/// The 3D crane's drives, in input order (u1 bridge x, u2 trolley y, u3 winch l).
pub const SPATIAL: [Drive; 3] = [Drive::Bridge, Drive::Trolley, Drive::Winch];

impl Drive {
    /// The stock CANopen node id of this drive (the commissioning file may choose
    /// another): trolley 1, winch 2, bridge 4 (3 and 5 are the one- and two-axis
    /// inclinometers').
    #[must_use]
    pub const fn node(self) -> u8 {
        match self {
            Drive::Trolley => 1,
            Drive::Winch => 2,
            Drive::Bridge => 4,
        }
    }

    /// The name the commissioning file and the logs use.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Drive::Trolley => "trolley",
            Drive::Winch => "winch",
            Drive::Bridge => "bridge",
        }
    }
}

/// Where `drive` is in `order` (`None`: the crane has no such drive).
#[must_use]
pub fn position<const A: usize>(order: &[Drive; A], drive: Drive) -> Option<usize> {
    order.iter().position(|d| *d == drive)
}

/// `drive`'s element of `values`, kept in `order` (`None`: the crane has no such drive).
pub fn of<'a, T, const A: usize>(
    order: &[Drive; A],
    drive: Drive,
    values: &'a [T; A],
) -> Option<&'a T> {
    values.get(position(order, drive)?)
}

/// `drive`'s element of `values`, kept in `order`, to change.
pub fn of_mut<'a, T, const A: usize>(
    order: &[Drive; A],
    drive: Drive,
    values: &'a mut [T; A],
) -> Option<&'a mut T> {
    values.get_mut(position(order, drive)?)
}

/// A crane's drives in the model's input order, with where each is in it, looked up in
/// one step: the cycle looks up its drives dozens of times, and a search of the order
/// each time cost the default scene's tick about 10 % (`cargo xtask qemu-bench`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Order<const A: usize> {
    drives: [Drive; A],
    trolley: Option<usize>,
    winch: Option<usize>,
    bridge: Option<usize>,
}

impl<const A: usize> Order<A> {
    /// The order `drives`.
    #[must_use]
    pub fn new(drives: [Drive; A]) -> Self {
        Self {
            drives,
            trolley: position(&drives, Drive::Trolley),
            winch: position(&drives, Drive::Winch),
            bridge: position(&drives, Drive::Bridge),
        }
    }

    /// The drives, in order.
    #[must_use]
    pub fn drives(&self) -> [Drive; A] {
        self.drives
    }

    /// Where `drive` is (`None`: the crane has no such drive).
    #[must_use]
    pub fn index(&self, drive: Drive) -> Option<usize> {
        match drive {
            Drive::Trolley => self.trolley,
            Drive::Winch => self.winch,
            Drive::Bridge => self.bridge,
        }
    }

    /// `drive`'s element of `values`, kept in this order.
    pub fn of<'a, T>(&self, drive: Drive, values: &'a [T; A]) -> Option<&'a T> {
        values.get(self.index(drive)?)
    }

    /// `drive`'s element of `values`, kept in this order, to change.
    pub fn of_mut<'a, T>(&self, drive: Drive, values: &'a mut [T; A]) -> Option<&'a mut T> {
        values.get_mut(self.index(drive)?)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    #[test]
    fn each_crane_finds_its_own_drives_only() {
        assert_eq!(position(&PLANAR, Drive::Winch), Some(1));
        assert_eq!(position(&PLANAR, Drive::Bridge), None);
        assert_eq!(position(&SPATIAL, Drive::Trolley), Some(1));
        let mut v = [10, 20, 30];
        *of_mut(&SPATIAL, Drive::Winch, &mut v).unwrap() += 1;
        assert_eq!(of(&SPATIAL, Drive::Winch, &v), Some(&31));
        assert_eq!(of(&PLANAR, Drive::Bridge, &[1, 2]), None);
        for d in SPATIAL {
            assert_eq!(Order::new(SPATIAL).index(d), position(&SPATIAL, d));
            assert_eq!(Order::new(PLANAR).index(d), position(&PLANAR, d));
        }
    }

    #[test]
    fn stock_node_ids_are_distinct_and_leave_the_inclinometer_its_own() {
        let nodes = SPATIAL.map(Drive::node);
        assert!(!nodes.contains(&3) && !nodes.contains(&5));
        assert!(nodes
            .iter()
            .enumerate()
            .all(|(i, n)| !nodes[..i].contains(n)));
    }
}
