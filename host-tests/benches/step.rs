//! One step of each scheme and Jacobian mode, and a whole trajectory, on the host.
//!
//! `cargo bench -p host-tests` (or `cargo xtask bench`). One step is measured in the
//! middle of the move (t = 5 s for the crane, 4.5 s for the mass-on-car), from a clone
//! of the integrator, so every sample starts from the same state. Targets (this host,
//! h = 10 ms, the paper's accuracy): crane BDF4 ≤ 0.75 µs per step, Radau IIA ≤ 3 µs per
//! step — measured here, reported in docs/RESULTS.md, not asserted by tests.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use host_tests::run::JACOBIAN_MODES;
use host_tests::scenes::{crane_trajectory, mass_on_car_trajectory};
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::models::mass_on_car::{self, MassOnCar, MassOnCarParams};
use solver_core::{Bdf, DaeModel, JacobianMode, Radau, SolverSettings};

const MODES: [(&str, JacobianMode); 5] = JACOBIAN_MODES;

/// Benchmarks one step of BDF4 and Radau in every mode, starting at `t_mid`.
fn one_step<M, const N: usize, const NU: usize, const S: usize>(
    c: &mut Criterion,
    name: &str,
    model: &M,
    t_mid: f64,
) where
    M: DaeModel<f64, N, NU> + Clone,
{
    let mut group = c.benchmark_group(format!("{name} step h=10ms"));
    for (label, mode) in MODES {
        let settings = SolverSettings::paper(mode);
        let steps = (t_mid / settings.h).round() as usize;
        let mut bdf = Bdf::<f64, M, N, NU>::new(model, &settings, 4, 0.0).expect("valid scene");
        let mut radau = Radau::<f64, M, N, NU, S>::new(model, &settings, 0.0).expect("valid scene");
        for _ in 0..steps {
            bdf.step(model).expect("the reference scene runs");
            radau.step(model).expect("the reference scene runs");
        }
        group.bench_function(format!("BDF4 {label}"), |b| {
            b.iter_batched(
                || bdf.clone(),
                |mut i| black_box(i.step(model)),
                BatchSize::SmallInput,
            )
        });
        group.bench_function(format!("Radau {label}"), |b| {
            b.iter_batched(
                || radau.clone(),
                |mut i| black_box(i.step(model)),
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

/// Benchmarks a whole run from rest: BDF4 exact and J, Radau J~10.
fn whole_run<M, const N: usize, const NU: usize, const S: usize>(
    c: &mut Criterion,
    name: &str,
    model: &M,
    t_end: f64,
) where
    M: DaeModel<f64, N, NU>,
{
    let mut group = c.benchmark_group(format!("{name} whole run h=10ms"));
    group.sample_size(20);
    let steps = (t_end / 0.01).round() as usize;
    for (label, mode) in [
        ("BDF4 exact", JacobianMode::Exact),
        ("BDF4 J", JacobianMode::FiniteDifference),
    ] {
        let settings = SolverSettings::paper(mode);
        group.bench_function(label, |b| {
            b.iter(|| {
                let mut bdf =
                    Bdf::<f64, M, N, NU>::new(model, &settings, 4, 0.0).expect("valid scene");
                (0..steps).all(|_| black_box(bdf.step(model)).is_ok())
            })
        });
    }
    let settings = SolverSettings::paper(JacobianMode::Broyden {
        reinit_every: Some(10),
    });
    group.bench_function("Radau Jt10", |b| {
        b.iter(|| {
            let mut radau =
                Radau::<f64, M, N, NU, S>::new(model, &settings, 0.0).expect("valid scene");
            (0..steps).all(|_| black_box(radau.step(model)).is_ok())
        })
    });
    group.finish();
}

fn benches(c: &mut Criterion) {
    let crane = CraneSubs::new(CraneParams::PAPER, crane_trajectory(4)).expect("the paper's crane");
    one_step::<_, _, _, { crane_subs::S }>(c, "crane subs", &crane, 5.0);
    whole_run::<_, _, _, { crane_subs::S }>(c, "crane subs 10 s", &crane, 10.0);
    let car = MassOnCar::new(MassOnCarParams::PAPER, mass_on_car_trajectory(4))
        .expect("the paper's mass-on-car");
    one_step::<_, _, _, { mass_on_car::S }>(c, "mass-on-car", &car, 4.5);
    whole_run::<_, _, _, { mass_on_car::S }>(c, "mass-on-car 20 s", &car, 20.0);
}

criterion_group!(step, benches);
criterion_main!(step);
