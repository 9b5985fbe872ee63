//! Random traffic for the soak run: a supervisor that sends valid and invalid move
//! requests, stops and resets at random, garbage on the bus, and now and then a fault
//! (a drive fault, a silent drive, a failed solver step, a bus-off). Deterministic for a
//! seed, so the QEMU run and the host's run of the same seed see the same bus.

use controller::commands::Request;
use controller::drive::Drive;

use crate::scenario::Action;

/// One in how many cycles each kind of event happens, on average.
mod every {
    pub const MOVE: u32 = 150;
    pub const STOP: u32 = 1_500;
    pub const RESET: u32 = 500;
    pub const STORM: u32 = 1_000;
    pub const DRIVE_FAULT: u32 = 30_000;
    pub const SILENCE: u32 = 30_000;
    pub const SOLVER_FAILURE: u32 = 30_000;
    pub const BUS_OFF: u32 = 20_000;
}

/// How long a silenced drive stays silent, ms (longer than the 300 ms heartbeat timeout).
const SILENCE_MS: u32 = 500;

/// The random supervisor and fault source.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Traffic {
    rng: u32,
    next_id: u8,
    revive: Option<(u32, Drive)>,
}

impl Traffic {
    /// Traffic from `seed` (0 is replaced: xorshift needs a non-zero state).
    #[must_use]
    pub fn new(seed: u32) -> Self {
        Self {
            rng: if seed == 0 { 0x2545_F491 } else { seed },
            next_id: 1,
            revive: None,
        }
    }

    fn next(&mut self) -> u32 {
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 17;
        self.rng ^= self.rng << 5;
        self.rng
    }

    /// Uniform in `[0, 1)`.
    fn uniform(&mut self) -> f64 {
        f64::from(self.next() >> 8) / f64::from(1u32 << 24)
    }

    fn one_in(&mut self, n: u32) -> bool {
        self.next().is_multiple_of(n)
    }

    fn id(&mut self) -> u8 {
        let id = self.next_id;
        self.next_id = self.next_id.wrapping_add(1);
        id
    }

    fn drive(&mut self) -> Drive {
        if self.next() & 1 == 0 {
            Drive::Trolley
        } else {
            Drive::Winch
        }
    }

    /// A move request around the workspace: mostly plausible, some outside it, some
    /// malformed in value (a zero coordinate, a duration out of range).
    fn move_request(&mut self) -> Request {
        let id = self.id();
        let mut x = 9.0 + 15.0 * self.uniform();
        let mut z = 2.0 + 8.5 * self.uniform();
        if self.one_in(40) {
            x = 0.0;
        }
        if self.one_in(40) {
            z = 0.0;
        }
        let duration = match self.next() % 20 {
            0..=6 => None,
            7 => Some(0.2),
            8 => Some(650.0),
            _ => Some(libm::exp(libm::log(0.5) + self.uniform() * libm::log(40.0))),
        };
        Request::Move {
            id,
            target: [x, z],
            duration,
        }
    }

    /// The actions of the cycle at `now_ms`, in order, handed to `act`.
    pub fn cycle(&mut self, now_ms: u32, mut act: impl FnMut(Action)) {
        if let Some((at, drive)) = self.revive {
            if now_ms >= at {
                self.revive = None;
                act(Action::Revive(drive));
            }
        }
        if self.one_in(every::MOVE) {
            let r = self.move_request();
            act(Action::Request(r));
        }
        if self.one_in(every::STOP) {
            let id = self.id();
            act(Action::Request(Request::Stop { id }));
        }
        if self.one_in(every::RESET) {
            let id = self.id();
            act(Action::Request(Request::Reset { id }));
        }
        if self.one_in(every::STORM) {
            let count = (self.next() % 20 + 1) as u8;
            act(Action::Storm { count });
        }
        if self.one_in(every::DRIVE_FAULT) {
            let d = self.drive();
            act(Action::DriveFault(d));
        }
        if self.revive.is_none() && self.one_in(every::SILENCE) {
            let d = self.drive();
            self.revive = Some((now_ms + SILENCE_MS, d));
            act(Action::Silence(d));
        }
        if self.one_in(every::SOLVER_FAILURE) {
            act(Action::SolverFailure);
        }
        if self.one_in(every::BUS_OFF) {
            let cycles = (self.next() % 6 + 1) as u8;
            act(Action::BusOff { cycles });
        }
    }
}
