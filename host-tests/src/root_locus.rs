//! The paper's Fig. 10: the root locus of the mass-on-car's internal dynamics over the
//! plane's inclination α, with the breakaway angle α̂ of Eq. 39 marked.
//!
//! The eigenvalues are those of the zero dynamics, Eq. 38 with `z_d ≡ 0`:
//! `m2 sin²α λ² + d λ + k = 0` (`solver_core::reference::mass_on_car`). Tab. 4's
//! parameters (m1 = m2 = 1 kg, k = 5 N/m) with d = 0 (on the imaginary axis for every
//! α) and d = 1 Ns/m (real below α̂ ≈ 12.9°, a complex pair above).

use std::fmt::Write as _;
use std::path::Path;

use solver_core::models::mass_on_car::MassOnCarParams;
use solver_core::reference::mass_on_car::{breakaway_angle, zero_dynamics_eigenvalues};

use crate::plot::{figure, Chart, Legend, Scale, Series};

/// Tab. 4's two dampings, Ns/m.
pub const DAMPINGS: [f64; 2] = [0.0, 1.0];

/// The α grid, degrees: 5° to 90° in 0.5° steps (below 5° the eigenvalues run off to
/// |λ| > 25 /s and −d/(m2 sin²α) → −∞, which would flatten the rest of the picture),
/// plus α̂ itself for every damping that has one, so the breakaway point is on the grid.
pub fn alpha_grid_deg() -> Vec<f64> {
    let mut grid: Vec<f64> = (10..=180).map(|i| f64::from(i) * 0.5).collect();
    // Undamped, Eq. 39 gives α̂ = 0°, where the plane is flat and Eq. 38 degenerates.
    for d in DAMPINGS.into_iter().filter(|&d| d > 0.0) {
        if let Some(a) = breakaway_angle(&params(d, 0.0)) {
            grid.push(a.to_degrees());
        }
    }
    grid.sort_by(f64::total_cmp);
    grid.dedup();
    grid
}

/// Tab. 4 with damping `d` at inclination `alpha_deg`.
pub fn params(d: f64, alpha_deg: f64) -> MassOnCarParams {
    MassOnCarParams {
        d,
        alpha: alpha_deg.to_radians(),
        ..MassOnCarParams::PAPER
    }
}

/// One point of the locus: both eigenvalues at one α and damping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocusPoint {
    /// Damping d, Ns/m.
    pub d: f64,
    /// Inclination α, degrees.
    pub alpha_deg: f64,
    /// λ₁ (the larger real part, or positive imaginary part), as (re, im).
    pub lambda1: (f64, f64),
    /// λ₂, as (re, im).
    pub lambda2: (f64, f64),
}

/// The locus for both dampings over [`alpha_grid_deg`].
pub fn locus() -> Vec<LocusPoint> {
    let grid = alpha_grid_deg();
    DAMPINGS
        .iter()
        .flat_map(|&d| {
            grid.iter().map(move |&alpha_deg| {
                let [l1, l2] = zero_dynamics_eigenvalues(&params(d, alpha_deg));
                // `+ 0.0` turns the undamped −0 (−d / 2a with d = 0) into 0 for the CSV.
                LocusPoint {
                    d,
                    alpha_deg,
                    lambda1: (l1.re + 0.0, l1.im),
                    lambda2: (l2.re + 0.0, l2.im),
                }
            })
        })
        .collect()
}

/// Writes `fig10-root-locus.csv` and `.svg` into `out`; returns α̂ (degrees) of the
/// damped system for the caller's summary.
pub fn write(out: &Path) -> Result<f64, String> {
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let points = locus();
    let alpha_hat = breakaway_angle(&params(1.0, 0.0))
        .ok_or("d = 1 Ns/m has no breakaway angle with Tab. 4's parameters")?;
    let mut csv = String::from("d,alpha_deg,re_lambda1,im_lambda1,re_lambda2,im_lambda2\n");
    for p in &points {
        let _ = writeln!(
            csv,
            "{},{},{:.9e},{:.9e},{:.9e},{:.9e}",
            p.d, p.alpha_deg, p.lambda1.0, p.lambda1.1, p.lambda2.0, p.lambda2.1
        );
    }
    let csv_path = out.join("fig10-root-locus.csv");
    std::fs::write(&csv_path, csv).map_err(|e| format!("{}: {e}", csv_path.display()))?;

    let branch = |d: f64, pick: fn(&LocusPoint) -> (f64, f64)| -> Vec<(f64, f64)> {
        points.iter().filter(|p| p.d == d).map(pick).collect()
    };
    let against_alpha = |d: f64, pick: fn(&LocusPoint) -> f64| -> Vec<(f64, f64)> {
        points
            .iter()
            .filter(|p| p.d == d)
            .map(|p| (p.alpha_deg, pick(p)))
            .collect()
    };
    // At α̂ both eigenvalues meet on the real axis at −d / (2 m2 sin²α̂) (critical damping).
    let hat = zero_dynamics_eigenvalues(&params(1.0, alpha_hat.to_degrees()))[0];
    let hat_label = format!("alpha^ = {:.2} deg (Eq. 39)", alpha_hat.to_degrees());
    let plane = vec![
        Series {
            name: "d = 0: lambda1".into(),
            points: branch(0.0, |p| p.lambda1),
        },
        Series {
            name: "d = 0: lambda2".into(),
            points: branch(0.0, |p| p.lambda2),
        },
        Series {
            name: "d = 1 Ns/m: lambda1".into(),
            points: branch(1.0, |p| p.lambda1),
        },
        Series {
            name: "d = 1 Ns/m: lambda2".into(),
            points: branch(1.0, |p| p.lambda2),
        },
        Series {
            name: hat_label.clone(),
            points: vec![(hat.re, hat.im)],
        },
    ];
    let parts = vec![
        Series {
            name: "d = 1: Re lambda1".into(),
            points: against_alpha(1.0, |p| p.lambda1.0),
        },
        Series {
            name: "d = 1: Re lambda2".into(),
            points: against_alpha(1.0, |p| p.lambda2.0),
        },
        Series {
            name: "d = 1: Im lambda1".into(),
            points: against_alpha(1.0, |p| p.lambda1.1),
        },
        Series {
            name: "d = 0: Im lambda1".into(),
            points: against_alpha(0.0, |p| p.lambda1.1),
        },
        Series {
            name: hat_label,
            points: vec![(alpha_hat.to_degrees(), hat.re)],
        },
    ];
    figure(
        &out.join("fig10-root-locus.svg"),
        &[
            (
                Chart {
                    title:
                        "Fig. 10: eigenvalues of the internal dynamics (Eq. 38), alpha 5..90 deg",
                    x_label: "Re lambda [1/s]",
                    y_label: "Im lambda [1/s]",
                    x_scale: Scale::Linear,
                    y_scale: Scale::Linear,
                    legend: Legend::OverData,
                },
                plane,
            ),
            (
                Chart {
                    title: "the same against alpha",
                    x_label: "alpha [deg]",
                    y_label: "lambda [1/s]",
                    x_scale: Scale::Linear,
                    y_scale: Scale::Linear,
                    legend: Legend::OverData,
                },
                parts,
            ),
        ],
        false,
    )?;
    Ok(alpha_hat.to_degrees())
}
