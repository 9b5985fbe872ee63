//! The master switch the keyboard stands in for. A terminal sends key presses but no
//! key releases, so a held stick cannot be modelled; a master switch with notches can:
//! each key press moves one lever one notch, and the release (Space) centres every
//! lever, as letting go of a spring-centred stick does.
//!
//! The switch sends what a real one sends: the operator frame (RPDO3 0x410,
//! docs/COMMANDS.md) with an alive counter that changes every frame, the enable
//! (dead-man) and manual-request flags, and one demand per direction of the load.

use controller::operator::{Flags, OperatorFrame, FULL_SCALE};

/// Notches each way from the centre: full stick in 4 steps of 25 %.
pub const NOTCHES: i8 = 4;

/// One direction of the load, as the operator frame orders them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// x: the planar crane's trolley, the 3D crane's bridge.
    X,
    /// y: the 3D crane's trolley (the planar crane has none).
    Y,
    /// The hoist: positive lowers the load.
    Z,
}

impl Axis {
    /// Its slot in the frame's demands.
    #[must_use]
    pub const fn slot(self) -> usize {
        match self {
            Self::X => 0,
            Self::Y => 1,
            Self::Z => 2,
        }
    }
}

/// What the operator does with the switch (the keys' meaning, `crate::tui::action`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// One lever one notch: +1 or −1.
    Notch(Axis, i8),
    /// Every lever back to the centre (the stick released).
    Centre,
    /// The manual-mode request on or off.
    ToggleManual,
    /// The dead-man (enable) held or let go.
    ToggleEnable,
    /// A stop request (0x210) as the supervisor sends it.
    Stop,
    /// Leave the view.
    Quit,
}

/// The switch: lever positions in notches, the two flags, the alive counter.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MasterSwitch {
    /// Each lever's notch, −[`NOTCHES`]..=[`NOTCHES`], in the slots `[x, y, z]`.
    pub levers: [i8; 3],
    /// The dead-man switch is held (flags bit 0).
    pub enable: bool,
    /// Manual mode is asked for (flags bit 1).
    pub manual: bool,
    /// Whether the crane has a y direction (the 3D crane): the planar crane's
    /// controller takes a y demand as a malformed frame, so its lever stays centred.
    has_y: bool,
    counter: u8,
}

impl MasterSwitch {
    /// Levers centred, the dead-man held (so that asking for manual mode is one key),
    /// manual mode not asked for.
    #[must_use]
    pub fn new(has_y: bool) -> Self {
        Self {
            levers: [0; 3],
            enable: true,
            manual: false,
            has_y,
            counter: 0,
        }
    }

    /// Applies `action`; a lever stops at its last notch, the planar crane's y lever does
    /// not move. A stop request and quitting are not the switch's to carry out: it
    /// ignores them.
    pub fn apply(&mut self, action: Action) {
        match action {
            Action::Notch(axis, step) => {
                if axis == Axis::Y && !self.has_y {
                    return;
                }
                if let Some(lever) = self.levers.get_mut(axis.slot()) {
                    *lever = lever.saturating_add(step).clamp(-NOTCHES, NOTCHES);
                }
            }
            Action::Centre => self.levers = [0; 3],
            Action::ToggleManual => self.manual = !self.manual,
            Action::ToggleEnable => self.enable = !self.enable,
            Action::Stop | Action::Quit => {}
        }
    }

    /// The demands the levers ask for, a fraction of full stick each
    /// (±[`FULL_SCALE`] at the last notch).
    #[must_use]
    pub fn demand(&self) -> [i16; 3] {
        self.levers
            .map(|n| (i32::from(n) * i32::from(FULL_SCALE) / i32::from(NOTCHES)) as i16)
    }

    /// The next frame: the counter advanced (it must change every frame), the flags and
    /// the demands as they are now.
    pub fn next_frame(&mut self) -> OperatorFrame {
        self.counter = self.counter.wrapping_add(1);
        OperatorFrame {
            counter: self.counter,
            flags: Flags {
                enable: self.enable,
                manual: self.manual,
                micro: false,
            },
            demand: self.demand(),
        }
    }

    /// Whether every lever is at its centre.
    #[must_use]
    pub fn centred(&self) -> bool {
        self.levers == [0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_notches_reach_full_stick_and_stop_there() {
        let mut s = MasterSwitch::new(true);
        for _ in 0..6 {
            s.apply(Action::Notch(Axis::X, 1));
        }
        s.apply(Action::Notch(Axis::Z, -1));
        assert_eq!(s.levers, [4, 0, -1]);
        assert_eq!(s.demand(), [FULL_SCALE, 0, -FULL_SCALE / 4]);
        s.apply(Action::Centre);
        assert!(s.centred());
        assert_eq!(s.demand(), [0; 3]);
    }

    #[test]
    fn the_planar_crane_s_y_lever_stays_centred() {
        let mut s = MasterSwitch::new(false);
        s.apply(Action::Notch(Axis::Y, 1));
        assert_eq!(s.levers, [0; 3]);
        let mut s = MasterSwitch::new(true);
        s.apply(Action::Notch(Axis::Y, -1));
        assert_eq!(s.levers, [0, -1, 0]);
    }

    #[test]
    fn the_counter_changes_every_frame_and_the_flags_follow_the_keys() {
        let mut s = MasterSwitch::new(false);
        let first = s.next_frame();
        assert!(first.flags.enable && !first.flags.manual);
        s.apply(Action::ToggleManual);
        s.apply(Action::ToggleEnable);
        let second = s.next_frame();
        assert_ne!(first.counter, second.counter);
        assert!(!second.flags.enable && second.flags.manual);
        // 256 frames later the counter wrapped and still changed every frame.
        let mut last = second.counter;
        for _ in 0..300 {
            let c = s.next_frame().counter;
            assert_ne!(c, last);
            last = c;
        }
    }
}
