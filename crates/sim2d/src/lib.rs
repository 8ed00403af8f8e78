//! # sim2d
//!
//! The DDPEN evaluation (Gamayunov, Postnikov and Ferrer, §II-E, §II-F, §III) as a 2D
//! simulation: a rapier2d world with static obstacles, the sidewalk robot as a dynamic rigid
//! body driven through a velocity-tracking controller with actuation noise, a 2D lidar, the
//! local costmap (200 x 200 cells of 5 cm) with inflation, cost decay and a distance field, a
//! 278 m route with the paper's local goal, and DDP planners in the loop at 10 Hz.
//!
//! | module | what |
//! |---|---|
//! | [`scenario`] | TOML scenario files: route and obstacles |
//! | [`route`] | progress along the route, local goal |
//! | [`world`] | rapier2d world, robot, controller, lidar, collisions |
//! | [`perception`] | lidar -> costmap -> distance field, inflation |
//! | [`planner`] | DDP (eqs. 3-7, 4 epochs per cycle, shifted warm start) and DDP with an A* guess |
//! | [`ddpen`] | DDPEN: sub-goal sources (A* oracle, network), the sub-goal cost (eqs. 8-9), map frame |
//! | [`registry`] | every planner by name ([`PlannerKind`]) |
//! | [`run`] | the loop, [`RunConfig`], [`RunResult`], observers |
//! | [`log`] | MCAP logs through the Foxglove SDK (protobuf, transform tree `map` -> `base_link` -> `laser`) |
//! | `live` | (feature `live`) the same topics served live over Foxglove's WebSocket protocol |
//! | [`plot`] | PNG top views like the paper's Fig. 5, with axes, legend and title (`ddpkit-plot`) |
//! | [`table`] | the paper's Table I |
//! | [`traps`] | seeded random trap maps (U, L, cube clusters, cylinder cups) for `trap-bench` |
//! | [`batch`] | parallel runs with progress bar, logs and figures (the binaries) |
//! | [`sweep`] | Table I and the trap benchmark as seeded tasks (the binaries and `ddpkit.experiments`) |
//! | [`turtlebot`] | the Safe-CDDP Turtlebot experiment (Alcan and Kyrki (2022), §IV-C, Fig. 5): CDDP vs Safe-CDDP; its episodes as tasks in [`turtlebot::sweep`] |
//!
//! ```no_run
//! let scenario = sim2d::Scenario::from_file("scenarios/cylinders.toml")?;
//! let result = sim2d::run_scenario(&scenario, &sim2d::RunConfig::default())?;
//! assert!(result.completed);
//! # Ok::<(), sim2d::Error>(())
//! ```

pub mod batch;
pub mod cli;
pub mod ddpen;
pub mod error;
pub mod governor;
#[cfg(feature = "live")]
pub mod live;
pub mod log;
pub mod perception;
pub mod planner;
pub mod plot;
pub mod registry;
pub mod route;
pub mod run;
pub mod scenario;
pub mod sweep;
pub mod table;
pub mod traps;
pub mod turtlebot;
pub mod world;

pub use ddpen::DdpenParams;
pub use error::{Error, Result};
pub use planner::{DdpParams, Planner};
pub use registry::PlannerKind;
pub use route::Route;
pub use run::{run_scenario, run_scenario_with, Direction, Observer, Outcome, RunConfig, RunResult};
pub use scenario::{Obstacle, Scenario};
