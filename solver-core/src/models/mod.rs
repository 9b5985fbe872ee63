//! The models of the paper. Each is one small [`DaeModel`](crate::model::DaeModel)
//! implementation; a scene links only the one it needs.

pub mod crane;
pub mod crane3d;
pub mod crane_proj;
pub mod crane_subs;
pub mod mass_on_car;
