//! The dead-man: whether the operator's stick may move the crane (docs/COMMANDS.md).
//!
//! * **Deadline.** A frame must arrive within [`Deadman::deadline_ms`] of the last one
//!   (three frame periods, at most [`MAX_DEADLINE_MS`]; measured between the times the
//!   frames were taken, which the controller stamps with the start of the cycle that
//!   reads them, see [`Deadman::state`]): a stick whose frames stop is an
//!   operator who may have let go, a cut cable or a dead PLC.
//! * **Alive counter.** Each frame's counter must differ from the last one's: a frozen
//!   counter is a sender that repeats a stale frame (a hung PLC task, a gateway's
//!   buffer), whose demand no longer says what the operator does. A frozen frame does not
//!   restart the deadline.
//! * **Enable.** The dead-man switch released (flags bit 0 clear).
//!
//! Any of the three is a *dead-man loss* ([`State::Lost`]): the crane stops sway-free
//! and manual mode is left at rest (the controller's business).
//!
//! * **Zero-position interlock.** After any stop — a dead-man loss, or one from elsewhere
//!   ([`Deadman::interlock`]: a stop request, a fault, a reset, an entry into manual
//!   mode) — and at power-up,
//!   a held stick does not move the crane: motion resumes only after every demand was
//!   inside the deadband for [`CENTRED_FRAMES`] consecutive live frames asking for manual
//!   mode (flags bit 1). A stick that was
//!   deflected when the crane stopped would otherwise start it again unasked.
//!
//! A pure state machine: frames and time in, a state out; it moves nothing itself.

use super::frame::{OperatorFrame, FULL_SCALE};

/// The longest deadline the dead-man takes, ms: the bound (≤ 100 ms), three
/// frames of a master switch sending every 30 ms with room for one late one.
pub const MAX_DEADLINE_MS: u32 = 100;

/// Consecutive live frames with every demand inside the deadband that lift the
/// zero-position interlock: two, so that one frame's noise (or a glitching stick
/// passing through zero on its way across) does not.
pub const CENTRED_FRAMES: u8 = 2;

/// Why the stick may not move the crane.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Loss {
    /// No operator frame since power-up.
    Silent,
    /// No frame within the deadline.
    Deadline,
    /// A frame with the last frame's alive counter.
    FrozenCounter,
    /// The dead-man switch released (enable = 0).
    Released,
}

/// What the stick may do now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum State {
    /// A dead-man loss: the crane stops.
    Lost(Loss),
    /// The operator is there, but the stick has not been centred since the last stop:
    /// its demand counts as zero.
    Interlocked,
    /// The stick's demand moves the crane.
    Live,
}

/// The dead-man's state machine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deadman {
    deadline_ms: u32,
    deadband: f64,
    /// The last frame with a new counter, and when it came.
    last: Option<(OperatorFrame, u64)>,
    /// The current loss, if any.
    loss: Option<Loss>,
    /// The stick has to be centred before it moves the crane.
    interlocked: bool,
    /// Consecutive live frames with every demand inside the deadband.
    centred: u8,
}

impl Deadman {
    /// A dead-man with a deadline of `deadline_ms` (1 to [`MAX_DEADLINE_MS`]; clamped
    /// into that range: a longer one would not be the safety the issue asks for) and a
    /// deadband of `deadband` of full stick (the generator's, `Settings::deadband`).
    /// It starts silent and interlocked.
    #[must_use]
    pub fn new(deadline_ms: u32, deadband: f64) -> Self {
        Self {
            deadline_ms: deadline_ms.clamp(1, MAX_DEADLINE_MS),
            deadband,
            last: None,
            loss: Some(Loss::Silent),
            interlocked: true,
            centred: 0,
        }
    }

    /// The deadline, ms.
    #[must_use]
    pub fn deadline_ms(&self) -> u32 {
        self.deadline_ms
    }

    /// The stick's deadband, a share of full stick.
    #[must_use]
    pub fn deadband(&self) -> f64 {
        self.deadband
    }

    /// The last frame with a new counter (whatever its flags), if any.
    #[must_use]
    pub fn frame(&self) -> Option<OperatorFrame> {
        self.last.map(|(f, _)| f)
    }

    /// Whether every demand of `frame` is inside the deadband (of the stick's position,
    /// micro-speed or not).
    #[must_use]
    pub fn centred(&self, frame: &OperatorFrame) -> bool {
        frame
            .demand
            .iter()
            .all(|d| f64::from(d.unsigned_abs()) <= self.deadband * f64::from(FULL_SCALE))
    }

    /// Takes a well-formed operator frame received at `now_ms`.
    pub fn on_frame(&mut self, frame: &OperatorFrame, now_ms: u64) {
        if self
            .last
            .is_some_and(|(last, _)| last.counter == frame.counter)
        {
            self.lose(Loss::FrozenCounter);
            return;
        }
        self.last = Some((*frame, now_ms));
        if !frame.flags.enable {
            self.lose(Loss::Released);
            return;
        }
        self.loss = None;
        // Only frames that ask for manual mode count, and one that does not interlocks
        // the stick: the interlock is lifted by an operator centring the stick *in*
        // manual mode, or while asking for it during an automatic move (then a
        // deflection hands the move over to the stick) — never by centring it before
        // the request, however long ago (review s10, finding 1).
        if !frame.flags.manual {
            self.interlock();
            return;
        }
        self.centred = if self.centred(frame) {
            self.centred.saturating_add(1)
        } else {
            0
        };
        if self.centred >= CENTRED_FRAMES {
            self.interlocked = false;
        }
    }

    /// A stop from elsewhere (a stop request, a fault, a reset, an entry into manual
    /// mode): the stick has
    /// to be centred again before it moves the crane.
    pub fn interlock(&mut self) {
        self.interlocked = true;
        self.centred = 0;
    }

    /// The state at `now_ms`, the deadline applied: no new frame for the deadline is a
    /// loss at that very instant. The controller stamps a frame with the start of the
    /// cycle that reads it (up to one cycle after it arrived) and asks on its cycle grid:
    /// with `>=` the loss is latched in the cycle a deadline after the one that read the
    /// last frame (90 ms: the ninth cycle of 10 ms), less than a deadline plus one cycle
    /// after the frame arrived; a strict `>` would wait one cycle more.
    pub fn state(&mut self, now_ms: u64) -> State {
        if self.loss.is_none()
            && self
                .last
                .is_some_and(|(_, at)| now_ms.saturating_sub(at) >= u64::from(self.deadline_ms))
        {
            self.lose(Loss::Deadline);
        }
        match self.loss {
            Some(loss) => State::Lost(loss),
            None if self.interlocked => State::Interlocked,
            None => State::Live,
        }
    }

    fn lose(&mut self, loss: Loss) {
        self.loss = Some(loss);
        self.interlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::operator::frame::Flags;

    const HELD: Flags = Flags {
        enable: true,
        manual: true,
        micro: false,
    };

    fn frame(counter: u8, flags: Flags, x: i16) -> OperatorFrame {
        OperatorFrame {
            counter,
            flags,
            demand: [x, 0, 0],
        }
    }

    /// 30 ms frames, a 90 ms deadline, a 5 % deadband.
    fn deadman() -> Deadman {
        Deadman::new(90, 0.05)
    }

    /// Centred twice: live.
    fn live() -> Deadman {
        let mut d = deadman();
        d.on_frame(&frame(1, HELD, 0), 0);
        d.on_frame(&frame(2, HELD, 0), 30);
        assert_eq!(d.state(30), State::Live);
        d
    }

    #[test]
    fn it_starts_silent_and_a_held_stick_does_not_move_the_crane() {
        let mut d = deadman();
        assert_eq!(d.state(0), State::Lost(Loss::Silent));
        d.on_frame(&frame(1, HELD, FULL_SCALE), 0);
        assert_eq!(d.state(0), State::Interlocked);
        d.on_frame(&frame(2, HELD, FULL_SCALE), 30);
        assert_eq!(d.state(30), State::Interlocked);
    }

    #[test]
    fn two_centred_frames_lift_the_interlock_one_does_not() {
        let mut d = deadman();
        d.on_frame(&frame(1, HELD, 0), 0);
        assert_eq!(d.state(0), State::Interlocked, "one frame");
        // A deflected frame in between starts the count again.
        d.on_frame(&frame(2, HELD, 5000), 30);
        d.on_frame(&frame(3, HELD, 0), 60);
        assert_eq!(d.state(60), State::Interlocked);
        // Inside the deadband (5 % of 32767 = 1638) counts as centred.
        d.on_frame(&frame(4, HELD, -1638), 90);
        assert_eq!(d.state(90), State::Live);
        d.on_frame(&frame(5, HELD, FULL_SCALE), 120);
        assert_eq!(d.state(120), State::Live, "then the stick moves the crane");
        // Every axis counts.
        let mut d = deadman();
        for (k, at) in [(1, 0), (2, 30), (3, 60)] {
            d.on_frame(
                &OperatorFrame {
                    counter: k,
                    flags: HELD,
                    demand: [0, 0, 2000],
                },
                at,
            );
        }
        assert_eq!(d.state(60), State::Interlocked, "the hoist is deflected");
    }

    #[test]
    fn a_late_frame_is_a_loss_on_time_not_before() {
        let mut d = live();
        assert_eq!(d.state(30 + 89), State::Live, "within the deadline");
        assert_eq!(
            d.state(30 + 90),
            State::Lost(Loss::Deadline),
            "exactly the deadline"
        );
        // The operator is back: interlocked until centred twice again.
        d.on_frame(&frame(3, HELD, FULL_SCALE), 200);
        assert_eq!(d.state(200), State::Interlocked);
        d.on_frame(&frame(4, HELD, 0), 230);
        d.on_frame(&frame(5, HELD, 0), 260);
        assert_eq!(d.state(260), State::Live);
    }

    #[test]
    fn a_frozen_counter_is_a_loss_and_does_not_restart_the_deadline() {
        let mut d = live();
        d.on_frame(&frame(2, HELD, 0), 60);
        assert_eq!(d.state(60), State::Lost(Loss::FrozenCounter));
        let mut d = live();
        d.on_frame(&frame(3, HELD, 0), 60);
        assert_eq!(
            d.state(60),
            State::Live,
            "a counter that wraps or jumps is alive"
        );
        assert_eq!(d.frame().map(|f| f.counter), Some(3), "the last new frame");
        // The counter may wrap.
        let mut d = deadman();
        for (k, at) in [(254u8, 0), (255, 30), (0, 60), (1, 90)] {
            d.on_frame(&frame(k, HELD, 0), at);
            assert_ne!(d.state(at), State::Lost(Loss::FrozenCounter));
        }
        assert_eq!(d.state(90), State::Live);
    }

    #[test]
    fn a_released_switch_is_a_loss_whatever_the_stick() {
        let mut d = live();
        let released = Flags {
            enable: false,
            ..HELD
        };
        d.on_frame(&frame(3, released, 0), 60);
        assert_eq!(d.state(60), State::Lost(Loss::Released));
        // Released frames keep the loss (not a deadline's), and do not count as centred.
        d.on_frame(&frame(4, released, 0), 90);
        d.on_frame(&frame(5, HELD, 0), 120);
        assert_eq!(d.state(120), State::Interlocked);
        d.on_frame(&frame(6, HELD, 0), 150);
        assert_eq!(d.state(150), State::Live);
    }

    #[test]
    fn a_stop_from_elsewhere_interlocks_the_stick() {
        let mut d = live();
        d.on_frame(&frame(3, HELD, FULL_SCALE), 60);
        d.interlock();
        assert_eq!(d.state(60), State::Interlocked);
        d.on_frame(&frame(4, HELD, FULL_SCALE), 90);
        assert_eq!(d.state(90), State::Interlocked, "the stick still held");
        d.on_frame(&frame(5, HELD, 0), 120);
        d.on_frame(&frame(6, HELD, 0), 150);
        assert_eq!(d.state(150), State::Live);
    }

    #[test]
    fn the_deadline_is_at_most_a_hundred_milliseconds() {
        assert_eq!(Deadman::new(500, 0.05).deadline_ms(), MAX_DEADLINE_MS);
        assert_eq!(Deadman::new(0, 0.05).deadline_ms(), 1);
        assert_eq!(Deadman::new(90, 0.05).deadline_ms(), 90);
    }
}
