//! The models of the paper. Each is one small [`DaeModel`](crate::model::DaeModel)
//! implementation; a scene links only the one it needs.
//!
//! Each model's module also names its sizes (`N` unknowns, `NU` inputs, `S = 3N` for
//! Radau's stage system) and its schemes (`Bdf`, `Radau`, `Chosen`, and where the model
//! has a structured elimination the firmware's `StructuredBdf` and `StructuredRadau5`),
//! so that no caller spells a size: `crane_subs::Bdf<f64, Z>` is BDF on the *subs* crane.

/// The scheme aliases of the model `$model` in the invoking module, which defines `N`
/// and `NU`; with `structured`, also the strategies of its structured elimination.
macro_rules! schemes_of {
    ($model:ident) => {
        /// Radau IIA's stage-system size, `3 * N`.
        pub const S: usize = 3 * N;
        /// BDF on this model, its Newton iteration done by `J` (by default dense LUs and
        /// the settings' Jacobian mode).
        pub type Bdf<T, Z, J = $crate::newton::Newton<T, N>> =
            $crate::schemes::Bdf<T, $model<T, Z>, N, NU, J>;
        /// Radau IIA on this model, its stage system solved by `J` (by default chosen at
        /// run time by the settings' Jacobian mode).
        pub type Radau<T, Z, J = $crate::schemes::radau::StageSolver<T, N, S>> =
            $crate::schemes::Radau<T, $model<T, Z>, N, NU, S, J>;
        /// RADAU5's transformed Newton on dense LUs.
        pub type Radau5<T, Z> = Radau<T, Z, $crate::schemes::radau::transformed::Transformed<T, N>>;
        /// Radau IIA with the paper's modes on the 3N×3N system.
        pub type RadauFull<T, Z> = Radau<T, Z, $crate::schemes::radau::FullNewton<T, S>>;
        /// The scheme a [`Scheme`]($crate::schemes::Scheme) value names, chosen at run time.
        pub type Chosen<T, Z> = $crate::schemes::Chosen<T, $model<T, Z>, N, NU, S>;
    };
    ($model:ident, structured) => {
        schemes_of!($model);
        /// BDF with the structured elimination (the firmware's for the exact Jacobian
        /// below 5 ms), each step from the model's closed-form step where it has one
        /// ([`EliminatedOf`]($crate::schemes::bdf::EliminatedOf)), from the predictor
        /// otherwise.
        pub type StructuredBdf<T, Z> =
            Bdf<T, Z, $crate::schemes::bdf::EliminatedOf<T, $model<T, Z>, N, NU>>;
        /// [`StructuredBdf`] for step sizes from
        /// [`CORRECT_BELOW_H`]($crate::schemes::bdf::CORRECT_BELOW_H) on (smaller ones
        /// refused): the same steps, without the correction linked
        /// ([`EliminatedUncorrectedOf`]($crate::schemes::bdf::EliminatedUncorrectedOf)).
        pub type StructuredBdfUncorrected<T, Z> =
            Bdf<T, Z, $crate::schemes::bdf::EliminatedUncorrectedOf<T, $model<T, Z>, N, NU>>;
        /// RADAU5's transformed Newton with both stage systems by the structured
        /// elimination (the firmware's), the stages from the model's closed-form step
        /// where it has one
        /// ([`EliminatedStagesOf`]($crate::schemes::radau::transformed::EliminatedStagesOf)).
        pub type StructuredRadau5<T, Z> = Radau<
            T,
            Z,
            $crate::schemes::radau::transformed::Transformed<
                T,
                N,
                $crate::schemes::radau::transformed::EliminatedStagesOf<T, $model<T, Z>, N, NU>,
            >,
        >;
    };
}

pub mod crane;
pub mod crane3d;
pub mod crane_ext;
pub mod crane_hidden;
pub mod crane_proj;
pub mod crane_subs;
pub mod double_pendulum;
pub mod double_pendulum_crane;
pub mod double_pendulum_ext;
pub mod mass_on_car;
pub mod mass_on_car_ext;

/// What the models' tests share.
#[cfg(test)]
#[allow(clippy::indexing_slicing)]
pub(crate) mod test_support {
    use nalgebra::SVector;

    use crate::model::{DaeModel, DifferenceFormula};

    /// `M::DIFFERENTIAL` as the residual has it at `(x, ẋ, s)`: the first
    /// `M::DIFFERENTIAL` unknowns' derivatives each change `F` and have a column of
    /// `∂F/∂ẋ`, the others' change no bit of `F` and have a zero column.
    pub(crate) fn assert_differential_first<
        M: DaeModel<f64, N, NU>,
        const N: usize,
        const NU: usize,
    >(
        m: &M,
        x: &SVector<f64, N>,
        xdot: &SVector<f64, N>,
        s: &M::Sample,
    ) {
        let f = m.residual(x, xdot, s);
        let dxdot = m.partials(x, xdot, s).dxdot;
        for j in 0..N {
            let mut moved = *xdot;
            moved[j] += 0.75 + moved[j].abs();
            let changed = m.residual(x, &moved, s) != f;
            let column = dxdot.column(j).iter().any(|v| *v != 0.0);
            let differential = j < M::DIFFERENTIAL;
            assert_eq!(changed, differential, "{}: F", M::UNKNOWNS[j]);
            assert_eq!(column, differential, "{}: ∂F/∂ẋ", M::UNKNOWNS[j]);
        }
    }

    /// A difference formula as a scheme gives it: BDF-like (`K = 1`: `ẋ = (α₀ Δ + p)/h`)
    /// or Radau-like (`K = 3`: `X' = (A⁻¹/h) Z`), around an anchor, for a model with `N`
    /// unknowns.
    pub(crate) struct Formula<const N: usize, const K: usize> {
        pub(crate) anchor: SVector<f64, N>,
        pub(crate) weights: [[f64; K]; K],
        pub(crate) past: SVector<f64, N>,
    }

    impl<const N: usize, const K: usize> DifferenceFormula<f64, K> for Formula<N, K> {
        fn anchor(&self, j: usize) -> f64 {
            self.anchor[j]
        }
        fn derivative(&self, j: usize, increments: [f64; K]) -> [f64; K] {
            self.weights.map(|row| {
                row.iter()
                    .zip(increments)
                    .fold(self.past[j], |acc, (w, d)| acc + w * d)
            })
        }
    }
}
