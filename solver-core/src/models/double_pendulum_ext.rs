//! The hook-and-load double pendulum minimally extended to index 1: *ext* (Altmann,
//! Betsch & Yang, the paper's ref. \[11\]; docs/MODELS.md, section 5's recipe).
//!
//! ## Why
//!
//! *subs* ([`double_pendulum`](super::double_pendulum)) has differentiation index 5: its
//! sling rows F9–F11 fix the hook and λ2 from the load path, its rope rows F7, F8, F12 fix
//! λ1, `x`, `l` only through the hook's acceleration, and the inputs need those twice more
//! — every scheme reaches them by differentiating through its difference formula, so
//! rounding grows like `h⁻⁴` below a floor at 1–50 ms and Radau IIA does not converge at
//! all (docs/MODELS.md, section 6).
//!
//! ## The extension
//!
//! Every position is a constrained one (the load is a flat output): the sling chain
//! `(x_H, z_H, λ2)` is fixed by F9–F11 and the rope chain `(x, l, λ1)` by F7, F8, F12 once
//! the hook's acceleration is known. The hidden constraints the index-5 system
//! differentiates implicitly are appended: F9–F11 differentiated 1–4 times (the rope rows
//! contain the hook's acceleration, their second derivatives its 4th derivative) and F7,
//! F8, F12 1–2 times (the inputs need the trolley's and rope's accelerations), 18 rows.
//! Each replaces one derivative by a new algebraic unknown: `ẋ, l̇, ẋ_H, ż_H` (F1–F4) by
//! `x', l', x_H', z_H'`, `v̇_x, v̇_l` (F5, F6) by `a_x, a_l`, `v̇_H` (F7, F8) by `a_H`, and
//! the higher rates the derivatives bring in get their own unknowns: the hook's jerk `j_H`
//! and snap `s_H`, `λ1', λ1''`, `λ2', …, λ2''''`. With `q^(k)` the k-th rate of a chain's
//! unknown (`x_H^(0..4) = [x_H, v_xH, a_xH, j_xH, s_xH]`, `x^(0..2) = [x, v_x, a_x]`,
//! `λ2^(0..4) = [λ2, λ2', …]`, and so on), the sling's offset `s = z_d − H`, the rope's
//! `r = x_H − x`, and Leibniz's sum `L_k(a, b) = Σ_j C(k, j) a^(j) b^(k−j)` (the k-th
//! derivative of a product):
//!
//! ```text
//! F1  = x' − v_x          F3 = x_H' − v_xH        F5 = τ1 a_x + v_x − u1     (24, 25)
//! F2  = l' − v_l          F4 = z_H' − v_zH        F6 = τ2 a_l + v_l − u2
//! F7^(k)  = μ x_H^(k+2) − 2 L_k(r, λ1) + 2 L_k(s_x, λ2)                 k = 0, 1, 2
//! F8^(k)  = μ z_H^(k+2) − μ g [k=0] − 2 L_k(z_H, λ1) + 2 L_k(s_z, λ2)   k = 0, 1, 2
//! F12^(k) = L_k(r, r) + L_k(z_H, z_H) − L_k(l, l)                       k = 0, 1, 2
//! F9^(k)  = x_d^(k+2) − 2 L_k(s_x, λ2)                                  k = 0 … 4
//! F10^(k) = z_d^(k+2) − g [k=0] − 2 L_k(s_z, λ2)                        k = 0 … 4
//! F11^(k) = L_k(s_x, s_x) + L_k(s_z, s_z) − l_s² [k=0]                  k = 0 … 4
//! ```
//!
//! The rows with `k = 0` are *subs*' F7–F12 with `v̇_H → a_H`; those with `k ≥ 1` are
//! their time derivatives written along the motion, the velocities and higher rates in
//! place of the positions' derivatives (F1–F4 make them equal), as a mechanical system's
//! velocity and acceleration constraints are. The unknowns, *subs*' first in *subs*'
//! order:
//!
//! ```text
//!  0 x     1 l     2 x_H   3 z_H   4 v_x   5 v_l   6 v_xH  7 v_zH  8 λ1    9 λ2
//! 10 u1   11 u2   12 x'   13 l'   14 x_H' 15 z_H' 16 a_x  17 a_l  18 a_xH 19 a_zH
//! 20 j_xH 21 j_zH 22 s_xH 23 s_zH 24 λ1'  25 λ1'' 26 λ2'  27 λ2'' 28 λ2''' 29 λ2''''
//! ```
//!
//! and the rows: *subs*' F1–F12 (0–11), then the first derivatives (F9'–F11' at 12–14,
//! F7', F8', F12' at 15–17), the second (18–20, 21–23), the sling's third (24–26) and
//! fourth (27–29).
//!
//! ## What it is
//!
//! No row has an `ẋ` left: the system is algebraic and `∂F/∂x` is block triangular with
//! nonzero pivots along every admissible motion (below), so it has index 1. As for the
//! planar crane's *ext* ([`crane_ext`](super::crane_ext)), every scheme solves the same
//! equations at its nodes, its solution is the flat inverse to rounding whatever h, and
//! its Newton matrix does not depend on h. The inputs need `z_d^(6)` (F9^(4)):
//! `MIN_SMOOTHNESS` 6, as *subs*'.

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::model::{DaeModel, Driven, Partials, StructuredJacobian};
use crate::models::double_pendulum_crane::{check_trajectory, DoublePendulumParams};
use crate::scalar::{c, is_finite, Real};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// Number of unknowns of the *ext* formulation.
pub const N: usize = 30;
/// Number of inputs.
pub const NU: usize = 2;
schemes_of!(DoublePendulumExt, structured);

/// The sling chain's rates kept: 0–4 (the rope rows' second derivative needs `s_H`).
const SLING_ORDERS: usize = 5;
/// The rope chain's rates kept: 0–2 (the inputs need `a_x`, `a_l`).
const ROPE_ORDERS: usize = 3;

/// Where the unknowns `q^(k)` of each chain sit in `x`.
const XH: [usize; SLING_ORDERS] = [2, 6, 18, 20, 22];
const ZH: [usize; SLING_ORDERS] = [3, 7, 19, 21, 23];
const LAMBDA2: [usize; SLING_ORDERS] = [9, 26, 27, 28, 29];
const XT: [usize; ROPE_ORDERS] = [0, 4, 16];
const ROPE: [usize; ROPE_ORDERS] = [1, 5, 17];
const LAMBDA1: [usize; ROPE_ORDERS] = [8, 24, 25];

/// Where the rows `F9^(k), F10^(k), F11^(k)` sit.
const SLING_ROWS: [[usize; 3]; SLING_ORDERS] = [
    [8, 9, 10],
    [12, 13, 14],
    [18, 19, 20],
    [24, 25, 26],
    [27, 28, 29],
];
/// Where the rows `F7^(k), F8^(k), F12^(k)` sit.
const ROPE_ROWS: [[usize; 3]; ROPE_ORDERS] = [[6, 7, 11], [15, 16, 17], [21, 22, 23]];

/// `C(k, j)` for `k ≤ 4`.
const BINOMIAL: [[f64; SLING_ORDERS]; SLING_ORDERS] = [
    [1.0, 0.0, 0.0, 0.0, 0.0],
    [1.0, 1.0, 0.0, 0.0, 0.0],
    [1.0, 2.0, 1.0, 0.0, 0.0],
    [1.0, 3.0, 3.0, 1.0, 0.0],
    [1.0, 4.0, 6.0, 4.0, 1.0],
];

/// Leibniz's sum `L_k(a, b) = Σ_{j=0}^{k} C(k, j) a^(j) b^(k−j)`, the k-th derivative of
/// `a b` from the rates of each (a rate beyond a slice counts 0).
fn leibniz<T: Real>(a: &[T], b: &[T], k: usize) -> T {
    let rate = |v: &[T], j: usize| v.get(j).copied().unwrap_or_else(T::zero);
    (0..=k).fold(T::zero(), |sum, j| {
        let cj = BINOMIAL
            .get(k)
            .and_then(|row| row.get(j))
            .copied()
            .unwrap_or(0.0);
        sum + c::<T>(cj) * rate(a, j) * rate(b, k - j)
    })
}

fn at<T: Real>(v: &[T], j: usize) -> T {
    v.get(j).copied().unwrap_or_else(T::zero)
}

fn put<T: Real>(v: &mut SVector<T, N>, j: usize, value: T) {
    if let Some(e) = v.get_mut(j) {
        *e = value;
    }
}

/// The two chains' rates, read from a vector of unknowns (a state or a Newton direction).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Chains<T> {
    xh: [T; SLING_ORDERS],
    zh: [T; SLING_ORDERS],
    lambda2: [T; SLING_ORDERS],
    xt: [T; ROPE_ORDERS],
    rope: [T; ROPE_ORDERS],
    lambda1: [T; ROPE_ORDERS],
}

impl<T: Real> Chains<T> {
    fn of(v: &SVector<T, N>) -> Self {
        let read = |j: usize| v.get(j).copied().unwrap_or_else(T::zero);
        Self {
            xh: XH.map(read),
            zh: ZH.map(read),
            lambda2: LAMBDA2.map(read),
            xt: XT.map(read),
            rope: ROPE.map(read),
            lambda1: LAMBDA1.map(read),
        }
    }

    /// The sling's offset `s = z_d − H` (`path` the load's rates; 0 for a direction,
    /// whose offset is `−δH`).
    fn sling(&self, path: &[[T; 2]; 7]) -> ([T; SLING_ORDERS], [T; SLING_ORDERS]) {
        (
            core::array::from_fn(|j| at(&path.map(|p| p[0]), j) - at(&self.xh, j)),
            core::array::from_fn(|j| at(&path.map(|p| p[1]), j) - at(&self.zh, j)),
        )
    }

    /// The rope's horizontal offset `r = x_H − x`.
    fn rope_offset(&self) -> [T; ROPE_ORDERS] {
        core::array::from_fn(|j| at(&self.xh, j) - at(&self.xt, j))
    }
}

/// Where the rows are evaluated: the chains at a state, with the load's rates.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Point<T> {
    chains: Chains<T>,
    sx: [T; SLING_ORDERS],
    sz: [T; SLING_ORDERS],
    r: [T; ROPE_ORDERS],
    mu: T,
}

impl<T: Real> Point<T> {
    fn new(x: &SVector<T, N>, path: &[[T; 2]; 7], mu: T) -> Self {
        let chains = Chains::of(x);
        let (sx, sz) = chains.sling(path);
        Self {
            r: chains.rope_offset(),
            chains,
            sx,
            sz,
            mu,
        }
    }

    /// The linearisation of the sling rows `F9^(k), F10^(k), F11^(k)` along the direction
    /// `d` (its offset `δs = −δH`): the product rule inside each Leibniz sum.
    fn sling_rows_along(&self, d: &Chains<T>, k: usize) -> [T; 3] {
        let two = c::<T>(2.0);
        let l2 = &self.chains.lambda2;
        let dsx = d.xh.map(|v| -v);
        let dsz = d.zh.map(|v| -v);
        [
            -two * (leibniz(&dsx, l2, k) + leibniz(&self.sx, &d.lambda2, k)),
            -two * (leibniz(&dsz, l2, k) + leibniz(&self.sz, &d.lambda2, k)),
            two * (leibniz(&self.sx, &dsx, k) + leibniz(&self.sz, &dsz, k)),
        ]
    }

    /// The linearisation of the rope rows `F7^(k), F8^(k), F12^(k)` along `d`.
    fn rope_rows_along(&self, d: &Chains<T>, k: usize) -> [T; 3] {
        let two = c::<T>(2.0);
        let p = &self.chains;
        let dsx = d.xh.map(|v| -v);
        let dsz = d.zh.map(|v| -v);
        let dr = d.rope_offset();
        [
            self.mu * at(&d.xh, k + 2)
                - two * (leibniz(&dr, &p.lambda1, k) + leibniz(&self.r, &d.lambda1, k))
                + two * (leibniz(&dsx, &p.lambda2, k) + leibniz(&self.sx, &d.lambda2, k)),
            self.mu * at(&d.zh, k + 2)
                - two * (leibniz(&d.zh, &p.lambda1, k) + leibniz(&p.zh, &d.lambda1, k))
                + two * (leibniz(&dsz, &p.lambda2, k) + leibniz(&self.sz, &d.lambda2, k)),
            two * (leibniz(&self.r, &dr, k) + leibniz(&p.zh, &d.zh, k)
                - leibniz(&p.rope, &d.rope, k)),
        ]
    }
}

/// The double pendulum *ext* inverse model, driven by a load trajectory `Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoublePendulumExt<T: Real, Z> {
    params: DoublePendulumParams,
    g: T,
    tau: [T; 2],
    mu: T,
    sling: T,
    trajectory: Z,
}

impl<T: Real, Z: Trajectory<T, 2>> DoublePendulumExt<T, Z> {
    /// Builds the model after checking the parameters and the whole trajectory
    /// (smoothness, tension margins, workspace), as *subs* does.
    pub fn new(params: DoublePendulumParams, trajectory: Z) -> Result<Self> {
        params.validate()?;
        let required = <Self as DaeModel<T, N, NU>>::MIN_SMOOTHNESS;
        if trajectory.smoothness() < required {
            return Err(Error::TrajectoryTooRough {
                smoothness: trajectory.smoothness(),
                required,
            });
        }
        check_trajectory(&params, &trajectory)?;
        Ok(Self {
            params,
            g: c(params.crane.g),
            tau: [c(params.crane.tau1), c(params.crane.tau2)],
            mu: c(params.hook_mass / params.crane.m),
            sling: c(params.sling),
            trajectory,
        })
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &DoublePendulumParams {
        &self.params
    }
}

impl<T: Real, Z> Driven for DoublePendulumExt<T, Z> {
    type Trajectory = Z;

    fn trajectory(&self) -> &Z {
        &self.trajectory
    }

    fn trajectory_mut(&mut self) -> &mut Z {
        &mut self.trajectory
    }
}

/// The load path's rates `[x_d, z_d]^(0..6)` of a sample.
fn path<T: Real>(s: &[SVector<T, 2>; 7]) -> [[T; 2]; 7] {
    s.map(<[T; 2]>::from)
}

impl<T: Real, Z: Trajectory<T, 2>> DaeModel<T, N, NU> for DoublePendulumExt<T, Z> {
    const UNKNOWNS: [&'static str; N] = [
        "x",
        "l",
        "x_h",
        "z_h",
        "vx",
        "vl",
        "vx_h",
        "vz_h",
        "lambda1",
        "lambda2",
        "u1",
        "u2",
        "x'",
        "l'",
        "x_h'",
        "z_h'",
        "ax",
        "al",
        "ax_h",
        "az_h",
        "jx_h",
        "jz_h",
        "sx_h",
        "sz_h",
        "lambda1'",
        "lambda1''",
        "lambda2'",
        "lambda2''",
        "lambda2'''",
        "lambda2''''",
    ];
    /// Every row: none has an `ẋ` (index 1, see the module's documentation).
    const ALGEBRAIC: [bool; N] = [true; N];
    /// None: no unknown's derivative enters F.
    const DIFFERENTIAL: usize = 0;
    const INPUTS: [usize; NU] = [10, 11];
    /// `u` contains `z_d^(6)` (F9^(4), F10^(4)).
    const MIN_SMOOTHNESS: usize = 6;

    /// `[z_d, ż_d, …, z_d^(6)]`.
    type Sample = [SVector<T, 2>; 7];

    fn sample(&self, t: T) -> Self::Sample {
        self.trajectory.derivatives::<7>(t)
    }

    fn residual(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
    ) -> SVector<T, N> {
        let z = path(s);
        let p = Point::new(x, &z, self.mu);
        let ch = &p.chains;
        let (two, o) = (c::<T>(2.0), T::zero());
        let v = |j: usize| x.get(j).copied().unwrap_or_else(T::zero);
        let [tau1, tau2] = self.tau;
        let mut f = SVector::<T, N>::zeros();
        for (row, value) in [
            (0, v(12) - v(4)),
            (1, v(13) - v(5)),
            (2, v(14) - v(6)),
            (3, v(15) - v(7)),
            (4, tau1 * v(16) + v(4) - v(10)),
            (5, tau2 * v(17) + v(5) - v(11)),
        ] {
            put(&mut f, row, value);
        }
        for (k, rows) in SLING_ROWS.iter().enumerate() {
            let first = if k == 0 { T::one() } else { o };
            let [xd, zd] = z.get(k + 2).copied().unwrap_or([o, o]);
            let values = [
                xd - two * leibniz(&p.sx, &ch.lambda2, k),
                zd - first * self.g - two * leibniz(&p.sz, &ch.lambda2, k),
                leibniz(&p.sx, &p.sx, k) + leibniz(&p.sz, &p.sz, k)
                    - first * self.sling * self.sling,
            ];
            for (row, value) in rows.iter().zip(values) {
                put(&mut f, *row, value);
            }
        }
        for (k, rows) in ROPE_ROWS.iter().enumerate() {
            let first = if k == 0 { T::one() } else { o };
            let values = [
                self.mu * at(&ch.xh, k + 2) - two * leibniz(&p.r, &ch.lambda1, k)
                    + two * leibniz(&p.sx, &ch.lambda2, k),
                self.mu * (at(&ch.zh, k + 2) - first * self.g)
                    - two * leibniz(&ch.zh, &ch.lambda1, k)
                    + two * leibniz(&p.sz, &ch.lambda2, k),
                leibniz(&p.r, &p.r, k) + leibniz(&ch.zh, &ch.zh, k)
                    - leibniz(&ch.rope, &ch.rope, k),
            ];
            for (row, value) in rows.iter().zip(values) {
                put(&mut f, *row, value);
            }
        }
        f
    }

    /// Column `j` is the rows' linearisation along the unit direction `e_j` (the
    /// product rule in each Leibniz sum, `Point`): exact, and the same expressions the
    /// structured elimination uses.
    fn partials(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
    ) -> Partials<T, N> {
        let p = Point::new(x, &path(s), self.mu);
        let mut dx = SMatrix::<T, N, N>::zeros();
        for j in 0..N {
            let mut e = SVector::<T, N>::zeros();
            put(&mut e, j, T::one());
            let column = linearised(&p, self.tau, &e);
            dx.set_column(j, &column);
        }
        Partials {
            dx,
            dxdot: SMatrix::zeros(),
        }
    }

    fn rest_state(&self, t: T) -> Result<SVector<T, N>> {
        ensure_at_rest(&self.trajectory, t)?;
        let [[xc, zc], ..] = path(&self.trajectory.derivatives::<7>(t));
        // Hanging straight down, as *subs*' rest state; every rate zero.
        let two = c::<T>(2.0);
        let zh = zc - self.sling;
        let mut x = SVector::<T, N>::zeros();
        for (j, v) in [
            (0, xc),
            (1, zh),
            (2, xc),
            (3, zh),
            (8, -(T::one() + self.mu) * self.g / (two * zh)),
            (9, -self.g / (two * self.sling)),
        ] {
            put(&mut x, j, v);
        }
        Ok(x)
    }

    /// The load position: the servo-constraints hold by construction, `z = z_d(t)`.
    fn output(&self, _x: &SVector<T, N>, s: &Self::Sample) -> SVector<T, NU> {
        let [z, ..] = *s;
        z
    }
}

/// `∂F/∂x · d` at the point `p` (drives' lags `tau`).
fn linearised<T: Real>(p: &Point<T>, tau: [T; 2], d: &SVector<T, N>) -> SVector<T, N> {
    let v = |j: usize| d.get(j).copied().unwrap_or_else(T::zero);
    let [tau1, tau2] = tau;
    let dc = Chains::of(d);
    let mut f = SVector::<T, N>::zeros();
    for (row, value) in [
        (0, v(12) - v(4)),
        (1, v(13) - v(5)),
        (2, v(14) - v(6)),
        (3, v(15) - v(7)),
        (4, tau1 * v(16) + v(4) - v(10)),
        (5, tau2 * v(17) + v(5) - v(11)),
    ] {
        put(&mut f, row, value);
    }
    for (k, rows) in SLING_ROWS.iter().enumerate() {
        for (row, value) in rows.iter().zip(p.sling_rows_along(&dc, k)) {
            put(&mut f, *row, value);
        }
    }
    for (k, rows) in ROPE_ROWS.iter().enumerate() {
        for (row, value) in rows.iter().zip(p.rope_rows_along(&dc, k)) {
            put(&mut f, *row, value);
        }
    }
    f
}

/// The factors of the *ext* Newton matrix (see [`StructuredJacobian`] for
/// [`DoublePendulumExt`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtFactors<T> {
    /// The chains where the matrix was formed.
    point: Point<T>,
    /// τ1, τ2.
    tau: [T; 2],
    /// Reciprocal pivots: `1/(2 λ2)`, `1/(2 |s|²)`, `1/(−2 z_H)`, `1/(2 λ1)`, `1/(−2 l)`.
    inv_pivot: [T; 5],
    /// `1/S_i` of every row.
    inv_scale: [T; N],
}

/// The Newton matrix `S·∂F/∂x` of *ext* (`∂F/∂ẋ = 0`: the shift does not enter) is block
/// triangular: the sling chain order by order, `k = 0 … 4`, each a 3×3 block in
/// `(x_H^(k), z_H^(k), λ2^(k))` that is *subs*' sling block at every order (the
/// Leibniz term `j = k` of each row),
///
/// ```text
/// F9^(k):   2 λ2 η_xH − 2 s_x η_λ2  = b9      b: the row's right-hand side less
/// F10^(k):  2 λ2 η_zH − 2 s_z η_λ2  = b10        the lower orders' terms
/// F11^(k): −2 s_x η_xH − 2 s_z η_zH = b11
/// ```
///
/// then the rope chain, `k = 0 … 2`, one pivot each for `λ1^(k)` (F8^(k): `−2 z_H`),
/// `x^(k)` (F7^(k): `2 λ1`) and `l^(k)` (F12^(k): `−2 l`), then `x', l', x_H', z_H'`
/// (F1–F4) and `u1, u2` (F5, F6). The five pivots are *subs*' and vanish only where
/// *subs*' do (a slack sling or rope, the hook at the load or at the rail, a rope of zero
/// length). The lower orders' terms are the rows' linearisation along the part of `η`
/// already solved (`Point::sling_rows_along`), so the elimination and
/// [`DaeModel::partials`] share their expressions. RADAU5's complex system is the real
/// one for each part.
impl<T: Real, Z: Trajectory<T, 2>> StructuredJacobian<T, N, NU> for DoublePendulumExt<T, Z> {
    type Factors = ExtFactors<T>;

    fn factor(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
        _c: T,
        scale: &SVector<T, N>,
    ) -> Option<ExtFactors<T>> {
        let point = Point::new(x, &path(s), self.mu);
        let two = c::<T>(2.0);
        let ch = &point.chains;
        let (sx, sz) = (at(&point.sx, 0), at(&point.sz, 0));
        let pivots = [
            two * at(&ch.lambda2, 0),
            two * (sx * sx + sz * sz),
            -two * at(&ch.zh, 0),
            two * at(&ch.lambda1, 0),
            -two * at(&ch.rope, 0),
        ];
        let inv_pivot = pivots.map(|p| T::one() / p);
        let inv_scale: [T; N] = scale.map(|s| T::one() / s).into();
        if !inv_pivot
            .iter()
            .chain(inv_scale.iter())
            .all(|v| is_finite(*v))
        {
            return None;
        }
        Some(ExtFactors {
            point,
            tau: self.tau,
            inv_pivot,
            inv_scale,
        })
    }

    fn solve(f: &ExtFactors<T>, r: &mut SVector<T, N>) {
        let b = SVector::<T, N>::from_fn(|i, _| {
            let (ri, si) = (r.get(i), f.inv_scale.get(i));
            ri.zip(si).map_or_else(T::zero, |(r, s)| *r * *s)
        });
        let rhs = |i: usize| b.get(i).copied().unwrap_or_else(T::zero);
        let two = c::<T>(2.0);
        let p = &f.point;
        let [inv_l2, inv_s2, inv_zh, inv_l1, inv_l] = f.inv_pivot;
        let (sx, sz, rx) = (at(&p.sx, 0), at(&p.sz, 0), at(&p.r, 0));
        let l2 = at(&p.chains.lambda2, 0);
        let mut eta = SVector::<T, N>::zeros();
        for (k, [r9, r10, r11]) in SLING_ROWS.iter().copied().enumerate() {
            // The lower orders' terms (η's order-k entries are still zero).
            let [a9, a10, a11] = p.sling_rows_along(&Chains::of(&eta), k);
            let (b9, b10, b11) = (rhs(r9) - a9, rhs(r10) - a10, rhs(r11) - a11);
            // Schur complement of the 2λ2 pivots: −2|s|²/λ2 η_λ2 = b11 + (s_x b9 + s_z b10)/λ2.
            let dl2 = -(b11 * l2 + sx * b9 + sz * b10) * inv_s2;
            let dxh = (b9 + two * sx * dl2) * inv_l2;
            let dzh = (b10 + two * sz * dl2) * inv_l2;
            for (j, v) in [(XH, dxh), (ZH, dzh), (LAMBDA2, dl2)] {
                if let Some(i) = j.get(k) {
                    put(&mut eta, *i, v);
                }
            }
        }
        for (k, [r7, r8, r12]) in ROPE_ROWS.iter().copied().enumerate() {
            let [a7, a8, a12] = p.rope_rows_along(&Chains::of(&eta), k);
            let (b7, b8, b12) = (rhs(r7) - a7, rhs(r8) - a8, rhs(r12) - a12);
            let dl1 = b8 * inv_zh;
            let dx = (b7 + two * rx * dl1) * inv_l1;
            let dl = (b12 + two * rx * dx) * inv_l;
            for (j, v) in [(XT, dx), (ROPE, dl), (LAMBDA1, dl1)] {
                if let Some(i) = j.get(k) {
                    put(&mut eta, *i, v);
                }
            }
        }
        let e = |j: usize| eta.get(j).copied().unwrap_or_else(T::zero);
        let [tau1, tau2] = f.tau;
        // F1–F4: η_q' − η_v = b; F5, F6: τ η_a + η_v − η_u = b.
        for (j, v) in [
            (12, rhs(0) + e(4)),
            (13, rhs(1) + e(5)),
            (14, rhs(2) + e(6)),
            (15, rhs(3) + e(7)),
            (10, tau1 * e(16) + e(4) - rhs(4)),
            (11, tau2 * e(17) + e(5) - rhs(5)),
        ] {
            put(&mut eta, j, v);
        }
        *r = eta;
    }

    /// `∂F/∂ẋ = 0`: the complex system is the real one for the real and the imaginary
    /// part alike.
    fn solve_complex(f: &ExtFactors<T>, _b: T, re: &mut SVector<T, N>, im: &mut SVector<T, N>) {
        Self::solve(f, re);
        Self::solve(f, im);
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use crate::trajectory::PointToPoint;

    type Model = DoublePendulumExt<f64, PointToPoint<f64, 2>>;

    fn model() -> Model {
        let z = PointToPoint::new(
            SVector::from([12.0, 8.0]),
            SVector::from([20.0, 4.0]),
            1.0,
            8.0,
            8,
        )
        .unwrap();
        DoublePendulumExt::new(DoublePendulumParams::EXAMPLE, z).unwrap()
    }

    /// A state off the solution, near the move's: trolley, hook and rope in the
    /// workspace, both forces in tension, every rate of order one.
    fn state(k: f64, i: usize) -> f64 {
        let base = match i {
            0 => 15.0,
            1 => 5.0,
            2 => 15.5,
            3 => 5.5,
            8 => -1.2,
            9 => -5.0,
            _ => 0.3 * ((i as f64) * 0.7).cos(),
        };
        base * (1.0 + 0.1 * (k * 0.37 + i as f64).sin()) + 0.01 * (k + i as f64).cos()
    }

    /// No derivative enters F (`DIFFERENTIAL` 0): every unknown's `ẋ` changes no bit.
    #[test]
    fn no_unknown_is_differential() {
        let m = model();
        let s = m.sample(3.8);
        let x = SVector::<f64, N>::from_fn(|i, _| state(1.0, i));
        let xdot = SVector::<f64, N>::from_fn(|i, _| 0.1 * i as f64 - 0.4);
        crate::models::test_support::assert_differential_first(&m, &x, &xdot, &s);
    }

    /// The structured elimination solves the dense system built from the partials, at
    /// states off the solution and with every row scaling of Sec. 3.1.1; its complex
    /// solve is the real one per part.
    #[test]
    fn structured_elimination_solves_the_dense_newton_system() {
        let m = model();
        for case in 0..200 {
            let k = case as f64;
            let s = m.sample(1.0 + 0.04 * k);
            let x = SVector::<f64, N>::from_fn(|i, _| state(k, i));
            let h: f64 = [0.0005, 0.01, 0.05][case % 3];
            let rho = 1.0 / h.powi((case % 4) as i32);
            let scale = SVector::<f64, N>::repeat(rho);
            let a = m.partials(&x, &x, &s).dx * rho;
            let r = SVector::<f64, N>::from_fn(|i, _| (k + 2.0 * i as f64).cos());
            let f = m.factor(&x, &x, &s, 25.0 / 12.0 / h, &scale).unwrap();
            let mut eta = r;
            Model::solve(&f, &mut eta);
            let size = a.abs().column_sum().max() * eta.amax() + r.amax();
            assert!(
                (a * eta - r).amax() <= 1e-12 * size,
                "case {case}: A η − r = {:e}",
                (a * eta - r).amax()
            );
            let mut lu = a;
            let mut piv = [0; N];
            assert!(crate::linalg::factor(&mut lu, &mut piv));
            let mut dense = r;
            crate::linalg::solve(&lu, &piv, &mut dense);
            assert!(
                (dense - eta).amax() <= 1e-8 * dense.amax(),
                "case {case}: {:e}",
                (dense - eta).amax()
            );
            let (mut re, mut im) = (r, r * 0.5);
            Model::solve_complex(&f, 3.0 / h, &mut re, &mut im);
            let mut half = r * 0.5;
            Model::solve(&f, &mut half);
            assert_eq!((re, im), (eta, half), "case {case}");
        }
    }

    /// A slack sling (λ2 = 0) or rope (λ1 = 0) makes the matrix singular: no factors.
    #[test]
    fn slack_ropes_have_no_factors() {
        let m = model();
        let s = m.sample(3.0);
        let scale = SVector::<f64, N>::repeat(1.0);
        for j in [8, 9] {
            let mut x = m.rest_state(0.0).unwrap();
            x[j] = 0.0;
            assert!(m.factor(&x, &x, &s, 200.0, &scale).is_none(), "unknown {j}");
        }
    }

    /// The rest state is consistent: `F(x_rest, ·, t) = 0` before and after the move.
    #[test]
    fn rest_state_is_consistent() {
        let m = model();
        for t in [0.0, 0.5, 9.0, 9.5] {
            let r = m.residual(&m.rest_state(t).unwrap(), &SVector::zeros(), &m.sample(t));
            assert!(r.amax() < 1e-14, "t = {t}: {r}");
        }
    }
}
