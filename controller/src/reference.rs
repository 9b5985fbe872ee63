//! The reference state of a vertical plane of the crane — the drive's position, the rope
//! and its angle, and their rates — from the inverse model's solution: what the state
//! feedback ([`crate::feedback`]) and the inclinometer's offset check ([`crate::zero`])
//! compare the measurements with. Its own module, so that neither of those two imports
//! the other for it.

/// The reference state from the inverse model's solution, in the coordinates of Eq. 20.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reference {
    /// The drive's position in this plane x_d, m (planar: the trolley; the 3D crane's
    /// x–z plane: the bridge, y–z: the trolley).
    pub x: f64,
    /// Rope length l_d, m.
    pub l: f64,
    /// Swing angle φ_d, rad.
    pub phi: f64,
    /// ẋ_d, m/s.
    pub vx: f64,
    /// l̇_d, m/s.
    pub vl: f64,
    /// φ̇_d, rad/s.
    pub vphi: f64,
}

impl Reference {
    /// From the *subs* solution `[x, l, ẋ, l̇]` (the first four unknowns of
    /// `solver_core::models::crane_subs`) and the desired load position and velocity
    /// `z_d, ż_d` (Eq. 28): `φ = atan2(x_C − x, z_C)` (Eq. 27), and its rate.
    #[must_use]
    pub fn from_subs(subs: [f64; 4], load: [f64; 2], load_rate: [f64; 2]) -> Self {
        let [x, l, vx, vl] = subs;
        let [xc, zc] = load;
        let [vxc, vzc] = load_rate;
        let dx = xc - x;
        let r2 = dx * dx + zc * zc;
        let vphi = if r2 > 0.0 {
            ((vxc - vx) * zc - dx * vzc) / r2
        } else {
            0.0
        };
        Self {
            x,
            l,
            phi: libm::atan2(dx, zc),
            vx,
            vl,
            vphi,
        }
    }
}
