//! Every planner by name, in one table: the only module that knows both the plain DDP planners
//! ([`crate::planner`]) and DDPEN ([`crate::ddpen`]), so that neither imports the other. An entry
//! is a name, a summary, a constructor and an early check; a [`PlannerKind`] is a handle on an
//! entry that parses command-line names, builds the planner and serialises as its name.
//!
//! | name | planner |
//! |---|---|
//! | `ddp` | [`DdpPlanner`]: vanilla DDP, warm-started from the shifted previous trajectory |
//! | `ddp-astar` | [`AstarDdpPlanner`]: DDP with an A* initial guess every cycle |
//! | `ddpen` | [`DdpenPlanner::network`]: DDP with the sub-goal cost (eqs. 8-9), sub-goals from the network |
//! | `ddpen-oracle` | [`DdpenPlanner::oracle`]: the same with A* sub-goals (path steps 30, 50, 70 on the live costmap) |
//!
//! A new planner is a new [`PlannerEntry`] here and a constant in [`PlannerKind`].
//!
//! ```
//! use sim2d::ddpen::DdpenParams;
//! use sim2d::planner::DdpParams;
//! use sim2d::registry::PlannerKind;
//! let kind = PlannerKind::parse("ddpen-oracle")?;
//! assert_eq!(kind, PlannerKind::DDPEN_ORACLE);
//! let planner = kind.build(&DdpParams::default(), &DdpenParams::default())?;
//! assert_eq!(planner.name(), "ddpen-oracle");
//! # Ok::<(), sim2d::Error>(())
//! ```

use crate::ddpen::{load_model, DdpenParams, DdpenPlanner};
use crate::error::{Error, Result};
use crate::planner::{AstarDdpPlanner, DdpParams, DdpPlanner, Planner};

/// One planner of the registry.
#[derive(Debug)]
pub struct PlannerEntry {
    /// The command-line name, e.g. `"ddp-astar"`.
    pub name: &'static str,
    /// One line on what it is.
    pub summary: &'static str,
    /// Builds the planner from the optimiser's and DDPEN's parameters (validating those it uses).
    pub build: fn(&DdpParams, &DdpenParams) -> Result<Box<dyn Planner>>,
    /// What can fail once per process rather than in every run (loading a model), done early so
    /// that a batch stops before it starts.
    pub prepare: fn(&DdpParams, &DdpenParams) -> Result<()>,
}

fn nothing_to_prepare(_: &DdpParams, _: &DdpenParams) -> Result<()> {
    Ok(())
}

static DDP: PlannerEntry = PlannerEntry {
    name: "ddp",
    summary: "vanilla DDP, warm-started from the shifted previous trajectory",
    build: |ddp, _| Ok(Box::new(DdpPlanner::new(*ddp)?)),
    prepare: nothing_to_prepare,
};

static DDP_ASTAR: PlannerEntry = PlannerEntry {
    name: "ddp-astar",
    summary: "DDP with an A* initial guess every cycle",
    build: |ddp, _| Ok(Box::new(AstarDdpPlanner::new(*ddp)?)),
    prepare: nothing_to_prepare,
};

static DDPEN: PlannerEntry = PlannerEntry {
    name: "ddpen",
    summary: "DDPEN: DDP with the sub-goal cost (eqs. 8-9), sub-goals from the network",
    build: |ddp, ddpen| Ok(Box::new(DdpenPlanner::network(*ddp, ddpen)?)),
    prepare: |_, ddpen| load_model(ddpen.model.as_deref()).map(drop),
};

static DDPEN_ORACLE: PlannerEntry = PlannerEntry {
    name: "ddpen-oracle",
    summary: "DDPEN with oracle sub-goals: path steps 30, 50, 70 of A* on the live costmap",
    build: |ddp, ddpen| Ok(Box::new(DdpenPlanner::oracle(*ddp, ddpen)?)),
    prepare: nothing_to_prepare,
};

/// A planner of the registry, by name (`Copy`; compares, hashes, prints and serialises as its
/// name).
#[derive(Clone, Copy)]
pub struct PlannerKind(&'static PlannerEntry);

impl PlannerKind {
    /// Vanilla DDP, warm-started from the shifted previous trajectory.
    pub const DDP: Self = Self(&DDP);
    /// DDP with an A* initial guess every cycle.
    pub const DDP_ASTAR: Self = Self(&DDP_ASTAR);
    /// DDPEN: DDP with the sub-goal cost (eqs. 8-9), sub-goals from the network.
    pub const DDPEN: Self = Self(&DDPEN);
    /// DDPEN with oracle sub-goals: path steps 30, 50, 70 of A* on the live costmap.
    pub const DDPEN_ORACLE: Self = Self(&DDPEN_ORACLE);

    /// Every registered planner, in the order of the module docs' table.
    pub const ALL: [Self; 4] = [Self::DDP, Self::DDP_ASTAR, Self::DDPEN, Self::DDPEN_ORACLE];

    /// The command-line name.
    pub fn name(&self) -> &'static str {
        self.0.name
    }

    /// The registry entry.
    pub fn entry(&self) -> &'static PlannerEntry {
        self.0
    }

    /// Looks up a command-line name; the error lists the known names.
    pub fn parse(name: &str) -> Result<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name).ok_or_else(|| {
            Error::invalid(
                "planner",
                format!(
                    "unknown planner {name:?}; known: {}",
                    Self::ALL.map(|k| k.name()).join(", ")
                ),
            )
        })
    }

    /// Builds the planner (`ddpen` loads its model once per process, see
    /// [`crate::ddpen::load_model`]).
    pub fn build(&self, ddp: &DdpParams, ddpen: &DdpenParams) -> Result<Box<dyn Planner>> {
        (self.0.build)(ddp, ddpen)
    }

    /// Does now what would otherwise fail in every run (`ddpen`: loads the model, naming it in
    /// the error); nothing for the other planners.
    pub fn prepare(&self, ddp: &DdpParams, ddpen: &DdpenParams) -> Result<()> {
        (self.0.prepare)(ddp, ddpen)
    }
}

impl PartialEq for PlannerKind {
    fn eq(&self, other: &Self) -> bool {
        self.name() == other.name()
    }
}

impl Eq for PlannerKind {}

impl std::hash::Hash for PlannerKind {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.name().hash(state);
    }
}

impl std::fmt::Debug for PlannerKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("PlannerKind").field(&self.name()).finish()
    }
}

impl std::fmt::Display for PlannerKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl serde::Serialize for PlannerKind {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for PlannerKind {
    /// A name of the registry ([`PlannerKind::parse`]); an unknown name is an error listing the
    /// known ones.
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        Self::ALL.into_iter().find(|k| k.name() == name).ok_or_else(|| {
            serde::de::Error::custom(format!(
                "unknown planner {name:?}; known: {}",
                Self::ALL.map(|k| k.name()).join(", ")
            ))
        })
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::perception::{Perception, PerceptionParams};
    use crate::planner::{Plan, PlanRequest};
    use crate::world::Scan;

    fn perception_with_wall() -> Perception {
        let mut p = Perception::new(PerceptionParams::default()).unwrap();
        // A wall across y = 0..1 at x = 3 (lidar returns).
        let hits: Vec<[f64; 2]> = (0..20).map(|k| [3.0, 0.05 * k as f64 + 0.5]).collect();
        p.update(&Scan {
            pose: [0.0, 0.0, 0.0],
            ranges: vec![],
            max_range: 8.0,
            hits,
        });
        p
    }

    #[test]
    fn planned_trajectory_keeps_away_from_a_seen_wall() {
        let perception = perception_with_wall();
        // (`ddpen` follows its network, tested in tests/ddpen.rs.)
        for kind in [PlannerKind::DDP, PlannerKind::DDP_ASTAR, PlannerKind::DDPEN_ORACLE] {
            let mut planner = kind.build(&DdpParams::default(), &DdpenParams::default()).unwrap();
            let mut plan = Plan::default();
            for cycle in 0..10 {
                let req = PlanRequest {
                    time: 0.0,
                    state: [0.0, 0.0, 0.0],
                    goal: [5.0, 0.0],
                    far_goal: [15.0, 0.0],
                    perception: &perception,
                    steps_since_last: usize::from(cycle > 0),
                };
                plan = planner.plan(&req).unwrap().clone();
            }
            let min_dist = plan
                .states
                .iter()
                .map(|s| perception.field().sample([s[0], s[1]]).0)
                .fold(f64::INFINITY, f64::min);
            assert!(min_dist > 0.5, "{kind}: min distance {min_dist}");
        }
        // The field is not shared after planning: perception updates stay allocation-free.
        assert_eq!(Arc::strong_count(perception.field()), 1);
    }

    #[test]
    fn names_round_trip_and_unknown_is_an_error() {
        for k in PlannerKind::ALL {
            assert_eq!(PlannerKind::parse(k.name()).unwrap(), k);
            assert_eq!(
                k.build(&DdpParams::default(), &DdpenParams::default()).unwrap().name(),
                k.name()
            );
            assert_eq!(serde_json::to_string(&k).unwrap(), format!("\"{k}\""));
            assert_eq!(serde_json::from_str::<PlannerKind>(&format!("\"{k}\"")).unwrap(), k);
        }
        let names: Vec<&str> = PlannerKind::ALL.iter().map(|k| k.name()).collect();
        assert_eq!(names, ["ddp", "ddp-astar", "ddpen", "ddpen-oracle"]);
        let e = PlannerKind::parse("rrt").unwrap_err().to_string();
        assert_eq!(
            e,
            "planner is invalid: unknown planner \"rrt\"; known: ddp, ddp-astar, ddpen, ddpen-oracle"
        );
        assert_ne!(PlannerKind::DDP, PlannerKind::DDPEN);
        assert_eq!(format!("{:?}", PlannerKind::DDP_ASTAR), "PlannerKind(\"ddp-astar\")");
    }

    #[test]
    fn only_the_network_planner_prepares_and_names_a_missing_model() {
        let missing = DdpenParams {
            model: Some("/nonexistent/model.safetensors".into()),
            ..DdpenParams::default()
        };
        for k in [PlannerKind::DDP, PlannerKind::DDP_ASTAR, PlannerKind::DDPEN_ORACLE] {
            k.prepare(&DdpParams::default(), &missing).unwrap();
        }
        let e = PlannerKind::DDPEN
            .prepare(&DdpParams::default(), &missing)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("model is invalid: cannot load /nonexistent/model.safetensors"),
            "{e}"
        );
    }
}
