//! The closed loop in manual mode on plants that are not the model, one error at a time
//! and combined (issue 28, "Closed loop": "plant ≠ model (±10 % length, mass, drive
//! lags, drives without integral action, friction) with feedback: ±50 mm and ≤ 0.1°
//! within one swing period of rest, feedback correction travel ≤ 50 mm").
//!
//! Each case is `drive-view`'s closed-loop case (`tests/closed_loop.rs`) on a plant of
//! its own: the firmware of a scene with `[operator]` and `[feedback]`, built by
//! [`with_controller`] as the host's run of the firmware builds it, on the virtual bus
//! with the plant [`PLANTS`] names; the master switch's frame every 30 ms. Manual mode
//! entered, the hoist brought to the rope length with its lever and let rest, then a
//! stick [`Profile`] (the 3D crane: bridge and trolley at once, a diagonal) with the
//! hoist still, lowering or raising at half stick ([`Hoist`]), released. Two sets of
//! cases: [`Study::First`], the study docs/OPERATOR.md reported first, and
//! [`Study::More`], what it left unmeasured (pulsing, pendant levels, the hoist raising,
//! a P-only hoist, the travel errors on the 3D crane's trolley). Measured:
//!
//! * **rest**: the first cycle from which the inverse model's own set points `u_d` are
//!   exactly 0.0 on every drive for the rest of the run — the generator's rest, as the
//!   model follows it (the controller's set points, `u_d` with the feedback's
//!   correction, rest at or after it);
//! * **load error**: over the second swing period after rest (from one period of the
//!   plant's pendulum after rest, for one more period), the largest horizontal distance
//!   of the plant's load from the model's load at rest — straight under the model's
//!   drives, which stand at the plant's start plus `∫ u_d dt` (the model's drive follows
//!   its `u_d` through its lag, Eq. 22, so at rest it has gone exactly `∫ u_d dt`). Its
//!   depth is left out: a rope 10 % longer than the drum says hangs the load 10 % deeper
//!   whatever the feedback does (docs/OPERATOR.md, the rope calibration);
//! * **swing**: the largest rope slope in either vertical plane over the same period;
//! * **correction travel**: per drive, the largest `|∫ (u − u_d) dt|` over the run, `u`
//!   the set point the controller sent: how far the feedback has put the travel it
//!   commands, `∫ u dt`, off the model's, `∫ u_d dt`, at any instant: the feedback's doing
//!   alone, what it asks of the drive beyond the model's plan (where the plant's drive
//!   itself went also holds its own response: a PI loop catching up the lag the model's
//!   drive keeps, a P loop with friction drooping). The worst drive is reported, and held to
//!   the 50 mm. Printed beside it, not held to the target: `∫ |u − u_d| dt`, which also
//!   counts every to-and-fro of the correction against the sensors' noise and so grows
//!   with the run's length rather than with the distance the drive was put off its
//!   path;
//! * **drive off the model's** (not held to a target): per drive, the largest distance
//!   over the run between the plant's drive and a drive exactly like the model's (its
//!   lag, Eq. 22) driven by `u_d` from the same start — where the drive itself went
//!   against the plan, whatever the commands that took it there. A drive that droops
//!   and is made up by the feedback has a large correction travel and a small one of
//!   these; a pendulum off the model's, which the feedback damps by moving the drive,
//!   has both.

use std::path::PathBuf;

use drive_view::engine::Engine;
use drive_view::switch::{Action, Axis, MasterSwitch, NOTCHES};
use host_tests::operator::Crane;
use host_tests::operator_study::Shape;
use scene::Scene;
use sim::plant::{Mismatch, Rng, Travel3d};
use sim::simulated::TrueState;
use sim::MISMATCHED;

const G: f64 = 9.81;

/// The generator's setting against an error in the pendulum's length
/// (`[operator] robust`, docs/OPERATOR.md, "The robust setting and what it costs"): the
/// study's scenes run it plain; `--robust` runs every case with the second pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Generator {
    /// One zero-vibration pair (the scenes' setting).
    Plain,
    /// A second pair tuned to the load's depth when the motion starts.
    Robust,
}

/// What the travel levers do before the release.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Profile {
    /// Full stick held this many seconds.
    Step(f64),
    /// Full stick one way for 2 s, then the other way for 2 s.
    Reversal,
    /// The open-loop study's pulsing ([`Shape::Pulse`]): full stick on and off at this
    /// frequency, Hz, for 6 s.
    Pulse(f64),
    /// The open-loop study's pendant levels ([`Shape::Pendant`]): a quarter, half,
    /// three quarters and full stick, 1.5 s each — the master switch's notches.
    Pendant,
}

/// The open-loop study's cycle, ms: its shapes are given per 10 ms cycle.
const SHAPE_CYCLE_MS: u32 = 10;

impl Profile {
    /// For the tables.
    #[must_use]
    pub fn name(&self) -> String {
        match self {
            Self::Step(s) => format!("full stick {s} s"),
            Self::Reversal => "reversal 2 + 2 s".into(),
            Self::Pulse(hz) => format!("pulsing at {hz} Hz"),
            Self::Pendant => "pendant levels".into(),
        }
    }

    /// The open-loop study's shape this profile takes, if it is one of them.
    fn shape(&self) -> Option<Shape> {
        match *self {
            Self::Pulse(hz) => Some(Shape::Pulse { hz }),
            Self::Pendant => Some(Shape::Pendant),
            Self::Step(_) | Self::Reversal => None,
        }
    }

    /// How long the levers are held before the release, ms.
    fn held_ms(&self) -> u32 {
        match self {
            Self::Step(s) => (s * 1000.0).round() as u32,
            Self::Reversal => 4000,
            Self::Pulse(_) | Self::Pendant => self.shape().map_or(0, |shape| {
                u32::try_from(shape.release())
                    .unwrap_or(u32::MAX)
                    .saturating_mul(SHAPE_CYCLE_MS)
            }),
        }
    }

    /// The travel levers' notch `ms` after the travel began (before [`Profile::held_ms`]):
    /// the shape's share of full stick in the switch's notches, which give the pendant's
    /// quarters and the pulses' full stick and zero exactly.
    fn notch(&self, ms: u32) -> i8 {
        match self {
            Self::Step(_) => NOTCHES,
            Self::Reversal => {
                if ms < 2000 {
                    NOTCHES
                } else {
                    -NOTCHES
                }
            }
            Self::Pulse(_) | Self::Pendant => self.shape().map_or(0, |shape| {
                // Neither shape draws from the generator (only the noise does).
                let [x, _] = shape.at((ms / SHAPE_CYCLE_MS) as usize, &mut Rng::new(0));
                (x * f64::from(NOTCHES)).round() as i8
            }),
        }
    }
}

/// Full stick for 4 s: the travel `tests/closed_loop.rs` measures.
pub const FULL_STEP: Profile = Profile::Step(4.0);

/// The first study's profiles: the 4 s step, a 1 s step released before the speed is
/// reached, a reversal.
pub const PROFILES: [Profile; 3] = [FULL_STEP, Profile::Step(1.0), Profile::Reversal];

/// The profiles added: pulsing at 0.5, 1 and 2 Hz, the pendant's levels.
pub const MORE_PROFILES: [Profile; 4] = [
    Profile::Pulse(0.5),
    Profile::Pulse(1.0),
    Profile::Pulse(2.0),
    Profile::Pendant,
];

/// What the hoist's lever does during the travel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hoist {
    /// Centred.
    Still,
    /// Half stick down.
    Lowering,
    /// Half stick up.
    Raising,
}

impl Hoist {
    /// All three.
    pub const ALL: [Hoist; 3] = [Self::Still, Self::Lowering, Self::Raising];

    /// For the tables.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Still => "still",
            Self::Lowering => "lowering",
            Self::Raising => "raising",
        }
    }

    /// The hoist lever's notch (positive lowers).
    fn notch(self) -> i8 {
        match self {
            Self::Still => 0,
            Self::Lowering => NOTCHES / 2,
            Self::Raising => -NOTCHES / 2,
        }
    }
}

/// The rope lengths the hoist is brought to before the travel, m (lowering during the
/// travel adds up to about a metre): the manual scenes' range.
pub const ROPES: [f64; 4] = [3.5, 5.0, 6.5, 8.0];

/// The targets: the load within 50 mm, the swing below 0.1°, the correction
/// travel within 50 mm.
pub const TARGET_M: f64 = 0.05;
/// The swing's target, degrees.
pub const TARGET_DEG: f64 = 0.1;

/// The study's sensors on every plant (noise and quantisation of positions and angle),
/// nothing else: each error below is added to this alone.
const SENSED: Mismatch = Mismatch {
    position_noise: Mismatch::SENSORS.0,
    angle_noise: Mismatch::SENSORS.1,
    noise_seed: 7,
    ..Mismatch::NONE
};

/// Friction at the random study's upper ends (`Mismatch::random`): a Coulomb droop of
/// 10 mm/s on the trolley (bridge), 5 mm/s on the winch, 3 % viscous on both.
const ROUGH: Mismatch = Mismatch {
    coulomb: [0.01, 0.005],
    viscous: [0.03, 0.03],
    ..SENSED
};

/// Every error at once: friction, the lags 1.5 times the model's, the trolley's (bridge's)
/// loop P only, the loops tuned for the model's load; the rope and the load as given.
const fn combined(drum_scale: f64, load_mass: f64) -> Mismatch {
    Mismatch {
        drum_scale,
        load_mass,
        loops_for_model_load: true,
        tau1: 0.5,
        tau2: 0.5,
        proportional_only: [true, false],
        ..ROUGH
    }
}

/// A plant of the study: its name and how it differs from the model.
#[derive(Debug, Clone, Copy)]
pub struct PlantCase {
    /// For the tables.
    pub name: &'static str,
    /// The mismatch (the 3D crane takes the travel drive's errors on the drives its
    /// `travel_3d` names, by default the bridge, and the winch's on the hoist:
    /// `sim::plant3d::Mismatch3d::from_planar`).
    pub mismatch: Mismatch,
    /// Studied on the 3D crane only (an error on its trolley, which the planar crane
    /// does not have).
    pub only_3d: bool,
}

/// The plants: each error alone (on the study's sensors), both combinations, and the
/// keyboard view's plant (`drive_view::engine::PLANT`, what `tests/closed_loop.rs`
/// measures) for comparison.
pub const PLANTS: [PlantCase; 10] = [
    PlantCase {
        name: "rope +10 %",
        mismatch: Mismatch {
            drum_scale: 0.10,
            ..SENSED
        },
        only_3d: false,
    },
    PlantCase {
        name: "rope -10 %",
        mismatch: Mismatch {
            drum_scale: -0.10,
            ..SENSED
        },
        only_3d: false,
    },
    PlantCase {
        name: "load +20 %",
        mismatch: Mismatch {
            load_mass: 0.2,
            loops_for_model_load: true,
            ..SENSED
        },
        only_3d: false,
    },
    PlantCase {
        name: "load -20 %",
        mismatch: Mismatch {
            load_mass: -0.2,
            loops_for_model_load: true,
            ..SENSED
        },
        only_3d: false,
    },
    PlantCase {
        name: "lags x1.5",
        mismatch: Mismatch {
            tau1: 0.5,
            tau2: 0.5,
            ..SENSED
        },
        only_3d: false,
    },
    PlantCase {
        name: "P only (travel)",
        mismatch: Mismatch {
            proportional_only: [true, false],
            ..SENSED
        },
        only_3d: false,
    },
    PlantCase {
        name: "friction",
        mismatch: ROUGH,
        only_3d: false,
    },
    PlantCase {
        name: "all: rope +10 %, load +20 %",
        mismatch: combined(0.10, 0.2),
        only_3d: false,
    },
    PlantCase {
        name: "all: rope -10 %, load -20 %",
        mismatch: combined(-0.10, -0.2),
        only_3d: false,
    },
    PlantCase {
        name: "view's plant",
        mismatch: Mismatch {
            drum_scale: 0.09,
            ..MISMATCHED
        },
        only_3d: false,
    },
];

/// The plants added: the hoist's loop without integral action (holding the model's
/// load; and a load 20 % heavier, which it lets sink, `sim::plant`'s
/// `a_winch_without_integral_action_holds_only_the_load_it_was_tuned_for`), and on the
/// 3D crane the lags, the P-only loop and the friction on its trolley as well as its
/// bridge.
pub const MORE_PLANTS: [PlantCase; 5] = [
    PlantCase {
        name: "P only (hoist)",
        mismatch: Mismatch {
            proportional_only: [false, true],
            ..SENSED
        },
        only_3d: false,
    },
    PlantCase {
        name: "P only (hoist), load +20 %",
        mismatch: Mismatch {
            proportional_only: [false, true],
            load_mass: 0.2,
            loops_for_model_load: true,
            ..SENSED
        },
        only_3d: false,
    },
    PlantCase {
        name: "lags x1.5, trolley too",
        mismatch: Mismatch {
            tau1: 0.5,
            tau2: 0.5,
            travel_3d: Travel3d::Both,
            ..SENSED
        },
        only_3d: true,
    },
    PlantCase {
        name: "P only (bridge and trolley)",
        mismatch: Mismatch {
            proportional_only: [true, false],
            travel_3d: Travel3d::Both,
            ..SENSED
        },
        only_3d: true,
    },
    PlantCase {
        name: "friction, trolley too",
        mismatch: Mismatch {
            travel_3d: Travel3d::Both,
            ..ROUGH
        },
        only_3d: true,
    },
];

/// A crane of the study: its manual-feedback scene and the stick's travel axes.
#[derive(Debug, Clone, Copy)]
pub struct CraneCase {
    /// For the tables.
    pub name: &'static str,
    /// The scene under `scenes/`.
    pub scene: &'static str,
    /// The levers pushed to full stick.
    pub axes: &'static [Axis],
}

/// The planar crane and the 3D crane (a diagonal).
pub const CRANES: [CraneCase; 2] = [
    CraneCase {
        name: "planar",
        scene: "paper-crane-manual-feedback.toml",
        axes: &[Axis::X],
    },
    CraneCase {
        name: "3D",
        scene: "crane3d/crane3d-manual-feedback.toml",
        axes: &[Axis::X, Axis::Y],
    },
];

/// One recorded cycle.
#[derive(Debug, Clone, Copy)]
struct Sample {
    t: f64,
    setpoints: [f64; 3],
    feedforward: [f64; 3],
    plant: TrueState,
    /// Where the model's drives stand: the plant's start plus `∫ u_d dt`, m.
    model: [f64; 3],
}

/// The keyboard view's engine on the case's plant and its master switch, cycle by cycle,
/// with the feedback's correction integrated.
struct Run {
    engine: Engine,
    switch: MasterSwitch,
    /// Whether the last status frame says manual mode runs.
    manual: bool,
    /// The next cycle's time, ms.
    now_ms: u32,
    model: Option<[f64; 3]>,
    /// `∫ (u − u_d) dt` per drive, m.
    correction: [f64; 3],
    /// Its largest magnitude so far, per drive, m.
    correction_peak: [f64; 3],
    /// `∫ |u − u_d| dt` per drive, m.
    correction_total: [f64; 3],
    /// The model's drive lags `τ` per slot, s (Eq. 22; 0 for a slot the crane lacks).
    lags: [f64; 3],
    /// A drive like the model's under `u_d`: position and speed per slot, m, m/s.
    model_drive: Option<[(f64, f64); 3]>,
    /// The largest distance of the plant's drive from it so far, per slot, m.
    drive_offset: [f64; 3],
}

impl Run {
    /// The engine of `scene` on `plant`, its generator robust or plain as `generator`
    /// says.
    fn new(scene: &str, plant: Mismatch, generator: Generator) -> Result<Self, String> {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../scenes")
            .join(scene);
        let mut loaded = Scene::load(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        // A scene without [operator] is refused by the engine, naming the section.
        if let Some(operator) = loaded.operator.as_mut() {
            operator.robust = Some(generator == Generator::Robust);
        }
        let lags = if let Some(p) = loaded.model.crane3d() {
            Crane::Spatial(p.params()).taus()
        } else if let Some(p) = loaded.model.crane() {
            Crane::Planar(p.params()).taus()
        } else {
            return Err("the study needs the planar or the 3D crane".into());
        };
        let engine = Engine::for_loaded_scene(&loaded, &path, plant)?;
        if !engine.info().feedback {
            return Err("the study needs a scene with [operator] and [feedback]".into());
        }
        let switch = MasterSwitch::new(engine.has_y());
        Ok(Self {
            engine,
            switch,
            manual: false,
            now_ms: 0,
            model: None,
            correction: [0.0; 3],
            correction_peak: [0.0; 3],
            correction_total: [0.0; 3],
            lags,
            model_drive: None,
            drive_offset: [0.0; 3],
        })
    }

    fn h(&self) -> f64 {
        f64::from(self.engine.period_ms()) / 1000.0
    }

    /// One cycle of the engine (the switch's frame if due, the controller, the plant); a
    /// fault is an error.
    fn cycle(&mut self) -> Result<Sample, String> {
        let out = self.engine.checked_cycle(&mut self.switch)?;
        self.manual = out.manual();
        self.now_ms += self.engine.period_ms();
        let h = self.h();
        let model = self.model.get_or_insert(out.plant.drives);
        for (i, at) in model.iter_mut().enumerate() {
            let (u, u_d) = (out.setpoints[i], out.feedforward[i]);
            *at += u_d * h;
            self.correction[i] += (u - u_d) * h;
            self.correction_peak[i] = self.correction_peak[i].max(self.correction[i].abs());
            self.correction_total[i] += (u - u_d).abs() * h;
        }
        let drives = out.plant.drives;
        let model_drive = self.model_drive.get_or_insert(drives.map(|x| (x, 0.0)));
        for i in 0..3 {
            // The lag's exact step with `u_d` held over the cycle.
            let (x, v) = model_drive[i];
            let u_d = out.feedforward[i];
            let (x, v) = if self.lags[i] > 0.0 {
                let decay = (-h / self.lags[i]).exp();
                (
                    x + u_d * h + (v - u_d) * self.lags[i] * (1.0 - decay),
                    u_d + (v - u_d) * decay,
                )
            } else {
                (x + u_d * h, u_d)
            };
            model_drive[i] = (x, v);
            self.drive_offset[i] = self.drive_offset[i].max((drives[i] - x).abs());
        }
        Ok(Sample {
            t: out.t,
            setpoints: out.setpoints,
            feedforward: out.feedforward,
            plant: out.plant,
            model: *model,
        })
    }

    fn run_for(&mut self, seconds: f64) -> Result<Vec<Sample>, String> {
        let n = (seconds / self.h()).round() as usize;
        (0..n).map(|_| self.cycle()).collect()
    }

    /// Cycles until every set point is exactly 0.0 (at most `seconds`), recorded.
    fn until_rest(&mut self, seconds: f64) -> Result<Vec<Sample>, String> {
        let n = (seconds / self.h()).round() as usize;
        let mut out = Vec::new();
        for _ in 0..n {
            let s = self.cycle()?;
            out.push(s);
            if s.setpoints == [0.0; 3] {
                return Ok(out);
            }
        }
        Err(format!("the set points did not rest within {seconds} s"))
    }

    fn manual(&self) -> bool {
        self.manual
    }
}

/// One case's outcome.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The crane's name.
    pub crane: &'static str,
    /// The plant's name.
    pub plant: &'static str,
    /// The stick's profile.
    pub profile: Profile,
    /// The rope length asked for before the travel, m.
    pub rope: f64,
    /// What the hoist did during the travel.
    pub hoist: Hoist,
    /// What came of it: the measurements, or the fault or failure that ended the run.
    pub result: Result<Measured, String>,
}

/// What one case measured.
#[derive(Debug, Clone, Copy)]
pub struct Measured {
    /// The drum's rope at rest after the travel, m.
    pub rope_at_rest: f64,
    /// The plant's pendulum at rest, m.
    pub pendulum: f64,
    /// The load's largest horizontal distance from the model's load at rest over the
    /// second swing period after rest, m.
    pub load_error: f64,
    /// The largest swing over the same period, degrees.
    pub swing: f64,
    /// The largest swing over the first swing period after rest, degrees: what the
    /// feedback had left to damp when the model came to rest (not held to a target).
    pub swing_first: f64,
    /// The feedback's correction travel, the worst drive's largest `|∫ (u − u_d) dt|`, m.
    pub correction: f64,
    /// The worst drive's `∫ |u − u_d| dt`, m.
    pub correction_total: f64,
    /// The worst drive's largest distance from a drive like the model's under `u_d`, m.
    pub drive_offset: f64,
    /// Seconds from the release to rest.
    pub rest_after: f64,
}

impl Measured {
    /// Whether the three targets are met.
    #[must_use]
    pub fn meets_targets(&self) -> bool {
        self.load_error <= TARGET_M && self.swing <= TARGET_DEG && self.correction <= TARGET_M
    }
}

/// The case: `crane` on `plant`, the hoist brought to `rope` m, the travel levers as
/// `profile` has them and the hoist's as `hoist` has it, released.
#[must_use]
pub fn case(
    crane: &CraneCase,
    plant: &PlantCase,
    profile: Profile,
    rope: f64,
    hoist: Hoist,
    generator: Generator,
) -> Outcome {
    Outcome {
        crane: crane.name,
        plant: plant.name,
        profile,
        rope,
        hoist,
        result: measure(crane, plant.mismatch, profile, rope, hoist, generator),
    }
}

fn measure(
    crane: &CraneCase,
    plant: Mismatch,
    profile: Profile,
    rope: f64,
    hoist: Hoist,
    generator: Generator,
) -> Result<Measured, String> {
    let mut r = Run::new(crane.scene, plant, generator)?;
    r.run_for(3.0)?;
    r.switch.apply(Action::ToggleManual);
    r.run_for(0.3)?;
    if !r.manual() {
        return Err("manual mode not entered".into());
    }
    // The hoist to the rope length (the lever at full: 0.5 m/s), then still.
    let now = r.cycle()?.plant.drives[2];
    let step = if rope > now { 1 } else { -1 };
    for _ in 0..NOTCHES {
        r.switch.apply(Action::Notch(Axis::Z, step));
    }
    let mut l = now;
    let mut waited = 0.0;
    while (rope - l) * f64::from(step) > 0.3 {
        l = r.run_for(0.1)?.last().map_or(l, |s| s.plant.drives[2]);
        waited += 0.1;
        if waited > 30.0 {
            return Err(format!("the hoist did not reach {rope} m"));
        }
    }
    r.switch.apply(Action::Centre);
    r.until_rest(20.0)?;
    r.run_for(2.0)?;
    // The travel, the levers set every cycle as the profile has them, and the release.
    r.switch.levers[Axis::Z.slot()] = hoist.notch();
    let mut ms = 0;
    while ms < profile.held_ms() {
        for axis in crane.axes {
            r.switch.levers[axis.slot()] = profile.notch(ms);
        }
        r.cycle()?;
        ms += r.engine.period_ms();
    }
    r.switch.apply(Action::Centre);
    let released = f64::from(r.now_ms) / 1000.0;
    let mut after = r.until_rest(30.0)?;
    let at_rest = after.last().map(|s| s.plant).ok_or("no cycle")?;
    let pendulum = at_rest.load[2];
    let period = 2.0 * std::f64::consts::PI * (pendulum / G).sqrt();
    after.extend(r.run_for(2.0 * period)?);
    // The model's rest: from the last cycle with a `u_d` other than 0.0 on.
    let moving = after
        .iter()
        .rposition(|s| s.feedforward != [0.0; 3])
        .ok_or("u_d never moved after the release")?;
    let rest = after.get(moving + 1).ok_or("u_d did not rest")?.t;
    let window: Vec<&Sample> = after
        .iter()
        .filter(|s| s.t >= rest + period && s.t <= rest + 2.0 * period)
        .collect();
    if window.is_empty() {
        return Err("no cycle in the second period after rest".into());
    }
    let largest_swing = |samples: &mut dyn Iterator<Item = &Sample>| {
        samples
            .flat_map(|s| s.plant.swing)
            .fold(0.0_f64, |m, a| m.max(a.to_degrees().abs()))
    };
    let swing_first =
        largest_swing(&mut after.iter().filter(|s| s.t >= rest && s.t < rest + period));
    let load_error = window
        .iter()
        .map(|s| (s.plant.load[0] - s.model[0]).hypot(s.plant.load[1] - s.model[1]))
        .fold(0.0, f64::max);
    let swing = largest_swing(&mut window.iter().copied());
    if !r.manual() {
        return Err("manual mode left".into());
    }
    let worst = |v: [f64; 3]| v.into_iter().fold(0.0, f64::max);
    Ok(Measured {
        rope_at_rest: at_rest.drives[2],
        pendulum,
        load_error,
        swing,
        swing_first,
        correction: worst(r.correction_peak),
        correction_total: worst(r.correction_total),
        drive_offset: worst(r.drive_offset),
        rest_after: rest - released,
    })
}

/// Which set of cases to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Study {
    /// The first study: each crane, plant of [`PLANTS`], profile of [`PROFILES`], rope
    /// length, the hoist still and lowering.
    First,
    /// What the first left out: the profiles of [`MORE_PROFILES`] on every plant of
    /// [`PLANTS`] with the hoist still, lowering and raising; the first profiles with the
    /// hoist raising; the plants of [`MORE_PLANTS`] with every profile and hoist.
    More,
}

/// One case to run.
type Job = (&'static CraneCase, &'static PlantCase, Profile, f64, Hoist);

/// The cases of `study` at the rope lengths `ropes` on the plants whose name `keep`
/// keeps, in the tables' order.
#[must_use]
fn jobs(study: Study, ropes: &[f64], keep: &dyn Fn(&str) -> bool) -> Vec<Job> {
    let mut jobs = Vec::new();
    let mut add = |plants: &'static [PlantCase], profiles: &[Profile], hoists: &[Hoist]| {
        for crane in &CRANES {
            for plant in plants.iter().filter(|p| keep(p.name)) {
                if plant.only_3d && crane.axes.len() < 2 {
                    continue;
                }
                for &profile in profiles {
                    for &rope in ropes {
                        for &hoist in hoists {
                            jobs.push((crane, plant, profile, rope, hoist));
                        }
                    }
                }
            }
        }
    };
    match study {
        Study::First => add(&PLANTS, &PROFILES, &[Hoist::Still, Hoist::Lowering]),
        Study::More => {
            add(&PLANTS, &MORE_PROFILES, &Hoist::ALL);
            add(&PLANTS, &PROFILES, &[Hoist::Raising]);
            let every: Vec<Profile> = PROFILES.iter().chain(&MORE_PROFILES).copied().collect();
            add(&MORE_PLANTS, &every, &Hoist::ALL);
        }
    }
    jobs
}

/// Every case of `study` at the rope lengths `ropes` on the plants whose name `keep`
/// keeps, the generator as `generator` says, on `threads` threads.
#[must_use]
pub fn all_cases(
    study: Study,
    ropes: &[f64],
    keep: &(dyn Fn(&str) -> bool + Sync),
    generator: Generator,
    threads: usize,
) -> Vec<Outcome> {
    let jobs = jobs(study, ropes, keep);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut out: Vec<(usize, Outcome)> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads.max(1))
            .map(|_| {
                s.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(&(crane, plant, profile, rope, hoist)) = jobs.get(i) else {
                            return done;
                        };
                        done.push((i, case(crane, plant, profile, rope, hoist, generator)));
                    }
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().unwrap_or_default())
            .collect()
    });
    out.sort_by_key(|(i, _)| *i);
    out.into_iter().map(|(_, o)| o).collect()
}
