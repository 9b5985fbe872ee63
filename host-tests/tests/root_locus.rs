//! Fig. 10: the root locus of the mass-on-car's internal dynamics (Eq. 38) over α,
//! against what the paper states about it (Sec. 3.2, Eq. 39).

use host_tests::root_locus::{alpha_grid_deg, locus, params, write, LocusPoint};
use solver_core::models::mass_on_car::MassOnCarParams;

fn at(d: f64, alpha_deg: f64) -> LocusPoint {
    *locus()
        .iter()
        .find(|p| p.d == d && (p.alpha_deg - alpha_deg).abs() < 1e-12)
        .unwrap_or_else(|| panic!("no locus point at d = {d}, alpha = {alpha_deg}"))
}

#[test]
fn the_breakaway_point_is_where_the_paper_puts_it() {
    let dir = std::env::temp_dir().join(format!("root-locus-{}", std::process::id()));
    let alpha_hat = write(&dir).unwrap();
    // "For the chosen parameters holds α̂ ≈ 12.9° for d = 1 Ns/m."
    assert!((alpha_hat - 12.9).abs() < 0.05, "alpha^ = {alpha_hat}");
    // At α̂ the damping is critical: m2 sin²α̂ = d²/(4k), so both eigenvalues meet on
    // the real axis at λ = −d / (2 m2 sin²α̂) = −2k/d = −10 /s.
    let k = MassOnCarParams::PAPER.k;
    let p = at(1.0, alpha_hat);
    for (re, im) in [p.lambda1, p.lambda2] {
        assert!((re + 2.0 * k).abs() < 1e-6, "{p:?}");
        assert!(im.abs() < 1e-3, "{p:?}");
    }
    // Below α̂ two distinct negative real eigenvalues (strongly damped), above a complex
    // pair in the left half-plane.
    let below = at(1.0, 12.5);
    assert!(
        below.lambda1.1 == 0.0 && below.lambda2.1 == 0.0,
        "{below:?}"
    );
    assert!(
        below.lambda2.0 < below.lambda1.0 && below.lambda1.0 < 0.0,
        "{below:?}"
    );
    let above = at(1.0, 13.5);
    assert!(
        above.lambda1.1 > 0.0 && above.lambda2.1 == -above.lambda1.1,
        "{above:?}"
    );
    assert!(above.lambda1.0 < 0.0, "{above:?}");
    // The files carry the grid for both dampings.
    let csv = std::fs::read_to_string(dir.join("fig10-root-locus.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 * alpha_grid_deg().len());
    let svg = std::fs::read_to_string(dir.join("fig10-root-locus.svg")).unwrap();
    assert!(svg.contains("Eq. 39"), "the SVG does not mark alpha^");
}

#[test]
fn without_damping_the_eigenvalues_stay_on_the_imaginary_axis() {
    // "For the undamped system with d = 0 Ns/m, the eigenvalues λ_i of the internal
    // dynamics of Eq. (38) stay on the imaginary axis": ±i √(k / (m2 sin²α)).
    for alpha in alpha_grid_deg() {
        let p = at(0.0, alpha);
        let m = params(0.0, alpha);
        let omega = (m.k / (m.m2 * m.alpha.sin().powi(2))).sqrt();
        assert_eq!((p.lambda1.0, p.lambda2.0), (0.0, 0.0), "{p:?}");
        assert!((p.lambda1.1 - omega).abs() < 1e-9 * omega, "{p:?}");
        assert_eq!(p.lambda2.1, -p.lambda1.1, "{p:?}");
    }
}
