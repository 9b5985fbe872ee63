//! Where the closed loop parts two runs whose inverse models differ by rounding: the
//! feedback scene (`scenes/paper-crane-feedback.toml`) on each of the virtual bus's
//! feedback scenarios, stepped by BDF4 from the predictor (the firmware's before issue
//! 20) and from the closed-form step (the firmware's now), the state feedback's every
//! cycle logged. Prints, per scenario, the first cycle at which the inverse model's set
//! points, the measurements, and each of the feedback's discrete decisions differ, and
//! the largest set-point difference.
//!
//! `cargo run --release -p host-tests --example feedback_divergence`

use std::cell::RefCell;
use std::path::Path;

use controller::feedback::{Correction, Measurement, Output, Reference, StateFeedback};
use controller::setpoint::DriveLimits;
use controller::{Controller, Injectable, InverseModel};
use scene::commissioning::CommissioningFile;
use scene::cranes::planar::Planar;
use scene::firmware::firmware_scene;
use scene::Scene;
use sim::{run_cycle, Scenario, VirtualBus, FEEDBACK_SCENARIOS};
use solver_core::models::crane_subs::{self, CraneSubs, N, NU};
use solver_core::plan::Plan;
use solver_core::schemes::bdf::StructuredOf;

type P = Plan<f64, 2>;
type IteratedBdf = crane_subs::Bdf<f64, P, StructuredOf<f64, CraneSubs<f64, P>, N, NU>>;

/// One cycle of the feedback.
#[derive(Debug, Clone)]
struct Row {
    u_d: [f64; 2],
    measured: Option<Measurement>,
    out: Output,
    /// The stuck-sensor watch runs (the reading repeated): the correction is capped.
    held: bool,
    /// The set points last admitted by the gate (the previous cycle's, as sent).
    sent: [f64; 2],
    /// The cycle's time, ms.
    now_ms: u32,
}

thread_local! {
    static LOG: RefCell<Vec<Row>> = const { RefCell::new(Vec::new()) };
    /// The time of the cycle being run, ms.
    static NOW_MS: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// The state feedback, every cycle logged.
struct Logged(StateFeedback);

impl Correction for Logged {
    const ENABLED: bool = true;
    fn correct(
        &mut self,
        reference: &Reference,
        u_d: [f64; 2],
        measured: Option<Measurement>,
        last: [f64; 2],
        limits: &DriveLimits,
    ) -> Output {
        let out = self.0.cycle(reference, u_d, measured, last, limits);
        let held = !format!("{:?}", self.0).contains("run: None");
        LOG.with(|l| {
            l.borrow_mut().push(Row {
                u_d,
                measured,
                out,
                held,
                sent: last,
                now_ms: NOW_MS.get(),
            })
        });
        out
    }
    fn sent(&mut self, correction: [f64; 2]) {
        Correction::sent(&mut self.0, correction);
    }
    fn restart(&mut self) {
        self.0.reset();
    }
    fn let_go_at_rest(&mut self) {
        self.0.let_go_at_rest();
    }
    fn mode(&self) -> Option<controller::feedback::Mode> {
        Some(self.0.mode())
    }
    fn rope(&self) -> Option<&controller::rope::RopeLength> {
        Some(self.0.rope())
    }
}

fn run(scene: &Scene, scenario: &Scenario, closed_form: bool) -> Vec<Row> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let commissioning =
        CommissioningFile::for_scene(&root.join("scenes/paper-crane-feedback.toml")).unwrap();
    let f = firmware_scene::<Planar, 2>(scene, &commissioning).unwrap();
    let settings = scene.settings();
    let model = CraneSubs::new(f.params.0, f.plan).unwrap();
    let feedback = Logged(StateFeedback::new(f.feedback.unwrap()).unwrap());
    LOG.with(|l| l.borrow_mut().clear());
    let start: [f64; 2] = f.first_move.start().into();
    let mut bus = VirtualBus::new(*scenario, start);
    let cycles = if scenario.cycles == 0 {
        f.cycles
    } else {
        scenario.cycles
    };
    macro_rules! go {
        ($integrator:expr) => {{
            let ff = Injectable::new(InverseModel::<Planar, _, _, f64, N>::new(
                model,
                $integrator,
            ));
            let mut c = Controller::with_correction(ff, feedback, f.planner, f.config);
            c.demonstration_commanded();
            for cycle in 0..cycles {
                NOW_MS.set(cycle * f.config.period_ms);
                if run_cycle(&mut c, &mut bus, cycle * f.config.period_ms).is_none() {
                    break;
                }
            }
        }};
    }
    if closed_form {
        go!(crane_subs::StructuredBdf::<f64, P>::new(&model, &settings, 4, 0.0).unwrap());
    } else {
        go!(IteratedBdf::new(&model, &settings, 4, 0.0).unwrap());
    }
    LOG.with(|l| l.borrow().clone())
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let scene = Scene::load(&root.join("scenes/paper-crane-feedback.toml")).unwrap();
    for scenario in FEEDBACK_SCENARIOS {
        let (a, b) = (run(&scene, &scenario, false), run(&scene, &scenario, true));
        println!(
            "## {} ({} / {} cycles logged)",
            scenario.name,
            a.len(),
            b.len()
        );
        let first = |what: &str, differs: &dyn Fn(&Row, &Row) -> bool| match a
            .iter()
            .zip(&b)
            .position(|(x, y)| differs(x, y))
        {
            Some(i) => println!("  first {what}: t = {:.2} s", f64::from(a[i].now_ms) / 1e3),
            None => println!("  {what}: never"),
        };
        first("u_d differs (any bit)", &|x, y| x.u_d != y.u_d);
        first("u_d differs by > 0.5 µm/s", &|x, y| {
            x.u_d.iter().zip(y.u_d).any(|(p, q)| (p - q).abs() > 0.5e-6)
        });
        first("measurement differs", &|x, y| x.measured != y.measured);
        if let Some(i) = a.iter().zip(&b).position(|(x, y)| x.measured != y.measured) {
            for j in i.saturating_sub(1)..(i + 2).min(a.len()) {
                println!(
                    "    t = {} ms: measured {:?} / {:?}, u_d {:?} / {:?}, correction {:?} / {:?}",
                    a[j].now_ms,
                    a[j].measured,
                    b[j].measured,
                    a[j].u_d,
                    b[j].u_d,
                    a[j].out.correction,
                    b[j].out.correction
                );
            }
        }
        first("sent set point differs (after the gate)", &|x, y| {
            x.sent != y.sent
        });
        first(
            "sent set point differs in µm/s (the frames' unit)",
            &|x, y| {
                x.sent
                    .iter()
                    .zip(y.sent)
                    .any(|(p, q)| (p * 1e6).round() != (q * 1e6).round())
            },
        );
        first("angle reading differs", &|x, y| {
            x.measured.map(|m| m.phi) != y.measured.map(|m| m.phi)
        });
        first("mode differs", &|x, y| x.out.mode != y.out.mode);
        first("resting (let go) differs", &|x, y| {
            x.out.resting != y.out.resting
        });
        first("trusted differs", &|x, y| x.out.trusted != y.out.trusted);
        first("held (reading repeated, cap) differs", &|x, y| {
            x.held != y.held
        });
        first("set point differs by > 1 mm/s", &|x, y| {
            x.out
                .u
                .iter()
                .zip(y.out.u)
                .any(|(p, q)| (p - q).abs() > 1e-3)
        });
        let (i, d) = a
            .iter()
            .zip(&b)
            .enumerate()
            .map(|(i, (x, y))| {
                let d = x
                    .out
                    .u
                    .iter()
                    .zip(y.out.u)
                    .map(|(p, q)| (p - q).abs())
                    .fold(0.0, f64::max);
                (i, d)
            })
            .fold((0, 0.0), |m, c| if c.1 > m.1 { c } else { m });
        println!(
            "  largest set-point difference {:.1} mm/s at t = {:.2} s",
            d * 1e3,
            f64::from(a[i].now_ms) / 1e3
        );
        // The cycles around the first 1 mm/s difference.
        if let Some(k) = a.iter().zip(&b).position(|(x, y)| {
            x.out
                .u
                .iter()
                .zip(y.out.u)
                .any(|(p, q)| (p - q).abs() > 1e-3)
        }) {
            for j in k.saturating_sub(4)..(k + 3).min(a.len()) {
                let (x, y) = (&a[j], &b[j]);
                println!(
                    "    t = {} ms: u {:+.6} / {:+.6} m/s, held {} / {}, resting {} / {}, phi {:?} / {:?}, mode {:?} / {:?}",
                    x.now_ms,
                    x.out.u[0],
                    y.out.u[0],
                    x.held,
                    y.held,
                    x.out.resting,
                    y.out.resting,
                    x.measured.map(|m| m.phi),
                    y.measured.map(|m| m.phi),
                    x.out.mode,
                    y.out.mode
                );
            }
        }
    }
}
