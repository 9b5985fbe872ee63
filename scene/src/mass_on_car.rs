//! The mass-on-car (Eqs. 31–34, Tab. 4), the rig the studies run beside the cranes and
//! the firmware does not drive: what its formulations share ([`ModelFamily`]).

use solver_core::models::mass_on_car::MassOnCarParams;
use solver_core::reference::dopri5::Dopri5Settings;
use solver_core::reference::mass_on_car::MassOnCarReference;
use solver_core::trajectory::PointToPoint;
use solver_core::Error;

use crate::family::{ExactInputs, ModelFamily};

impl ModelFamily<1> for MassOnCarParams {
    const NAME: &'static str = "the mass-on-car";
    /// 0.01 N: its input is the car's force.
    const ACCURACY_THRESHOLD: f64 = 1e-2;
    type Exact = MassOnCarReference<PointToPoint<f64, 1>>;
    /// It is not flat: its internal dynamics (Eq. 38) integrated along the move from
    /// rest at t = 0, and Eq. 37.
    fn exact(self, z: PointToPoint<f64, 1>) -> Result<Self::Exact, Error> {
        MassOnCarReference::new(self, z, 0.0, Dopri5Settings::default())
    }
}

impl ExactInputs for MassOnCarReference<PointToPoint<f64, 1>> {
    fn at(&mut self, t: f64, out: &mut Vec<f64>) -> Result<(), Error> {
        out.push(self.advance_to(t)?.f);
        Ok(())
    }
}
