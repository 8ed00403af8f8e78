//! # subgoal-infer
//!
//! Costmaps, distance fields and A* for DDPEN (Gamayunov, Postnikov and Ferrer): the local
//! costmap of 200 x 200 cells of 5 cm centred on the robot, its inflation, the exact Euclidean
//! distance transform behind a smooth obstacle cost, and the A* planner whose paths give the
//! sub-goals the network imitates.
//!
//! | item | what | paper |
//! |---|---|---|
//! | [`grid::Costmap`] | rolling-window `u8` cost grid, world <-> cell, cost decay | §II-D, §II-E |
//! | [`grid::Inflation`] | cost dilation from obstacles into free space | §II-D |
//! | [`grid::Edt`], [`grid::DistanceField`] | exact EDT, bilinear distance and gradient | eq. (7) |
//! | [`DistanceFieldHinge`] | `w ReLU(d - dist(p))`, a [`ddp_core::TerminalCost`] | eq. (7) |
//! | [`grid::AStar`] | 8-connected cost-aware A* | §II-D |
//! | [`dataset`] | sub-goal dataset: random maps, A* sub-goals, safetensors shards | §II-D |
//! | [`SubgoalModel`] ([`model`]) | the sub-goal network `x_s = SG(map, x_goal)` from safetensors weights (small CNN or EfficientNet encoder, transformer decoder) | §II-C, eq. (10) |
//!
//! ```
//! use std::sync::Arc;
//! use ddp_core::{TerminalCost, Vector};
//! use subgoal_infer::grid::{Costmap, DistanceField, LETHAL};
//! use subgoal_infer::DistanceFieldHinge;
//!
//! // A 10 m x 10 m costmap around the robot with one obstacle cell 0.5 m ahead.
//! let mut map = Costmap::ddpen([0.0, 0.0]);
//! map.mark([0.5, 0.0], LETHAL);
//! let mut field = DistanceField::new(*map.geometry());
//! field.compute(&map, LETHAL)?;
//! // ReLU(0.8 - dist) on the position (x[0], x[1]) of a unicycle state.
//! let hinge = DistanceFieldHinge::<3>::new(Arc::new(field), 0.8, [0, 1], 1.0)?;
//! let c = hinge.value(&Vector::<3>::new(0.0, 0.0, 0.0));
//! assert!((c - 0.3).abs() < 0.05);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod dataset;
pub mod error;
pub mod grid;
mod hinge;
pub mod model;

pub use error::{Error, Result};
pub use hinge::DistanceFieldHinge;
pub use model::SubgoalModel;
