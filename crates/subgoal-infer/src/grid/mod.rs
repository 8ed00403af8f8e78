//! Grid tools shared by the simulator and the sub-goal dataset: a rolling-window [`Costmap`]
//! (world <-> cell transforms, cost decay), the exact Euclidean distance transform ([`Edt`],
//! Felzenszwalb-Huttenlocher), a [`DistanceField`] with bilinear lookup and gradient,
//! [`Inflation`] (cost dilation) and 8-connected cost-aware [`AStar`].

mod astar;
mod costmap;
mod distance;
mod edt;
mod inflation;

pub use astar::{nearest_free, path_cost, AStar, AStarParams};
pub use costmap::{Costmap, GridGeometry, FREE, INSCRIBED, LETHAL, MAX_NON_OBSTACLE};
pub use distance::DistanceField;
pub use edt::Edt;
pub use inflation::Inflation;
