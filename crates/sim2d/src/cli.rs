//! Command-line options shared by the `scenario`, `ddpen-table` and `trap-bench` binaries: the
//! planner's problem and the executor, as one `clap` group (`#[command(flatten)]`).

use std::path::PathBuf;

use crate::error::Result;
use crate::log::LiveLink;
use crate::run::RunConfig;

/// The live view's options, shared by the binaries.
#[derive(Debug, Clone, clap::Args)]
pub struct LiveArgs {
    /// Serve the run's topics live over Foxglove's WebSocket protocol on 127.0.0.1 (runs go one
    /// at a time, paced by --rate; needs the `live` feature).
    #[arg(long)]
    pub live: bool,
    /// Port of the live view (0: any free port).
    #[arg(long, default_value_t = 8765)]
    pub live_port: u16,
    /// Simulated seconds per wall-clock second with --live (1: real time; 0: as fast as it goes).
    #[arg(long, default_value_t = 1.0)]
    pub rate: f64,
}

/// A started live view (kept alive while the runs go) and the link the batch takes.
pub struct LiveSession {
    /// What [`crate::batch::BatchOptions::live`] takes.
    pub link: LiveLink,
    /// The port served.
    pub port: u16,
    #[cfg(feature = "live")]
    _view: crate::live::LiveView,
}

impl LiveArgs {
    /// Starts the live view when `--live` was given, before any run: a port in use or a bad
    /// rate is an error naming it. `Ok(None)` without `--live`.
    pub fn start(&self) -> Result<Option<LiveSession>> {
        if !self.live {
            return Ok(None);
        }
        crate::error::nonnegative("rate", self.rate)?;
        #[cfg(feature = "live")]
        {
            let view = crate::live::LiveView::start(self.live_port, self.rate)?;
            Ok(Some(LiveSession {
                link: view.link(),
                port: view.port(),
                _view: view,
            }))
        }
        #[cfg(not(feature = "live"))]
        {
            Err(crate::error::Error::invalid(
                "live",
                "this build has no live view: build sim2d with `--features live`",
            ))
        }
    }
}

/// Planner and executor options (each left out keeps [`RunConfig::default`]'s value). Also the
/// `options` of the sweeps' configurations ([`crate::sweep`]), where every field may be left out.
#[derive(Debug, Clone, Default, PartialEq, clap::Args, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlannerArgs {
    /// Planner horizon N (knots of 0.1 s).
    #[arg(long)]
    pub horizon: Option<usize>,
    /// Sub-goal model weights for `ddpen` [default: the shipped model].
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Weight `w_s` of each sub-goal's distance (eq. 9).
    #[arg(long)]
    pub w_subgoal: Option<f64>,
    /// New sub-goals every this many planning cycles.
    #[arg(long)]
    pub subgoal_every: Option<usize>,
    /// Weight of the quadratic contact wall added to eq. (7) (0: the paper's cost alone).
    #[arg(long)]
    pub w_contact: Option<f64>,
    /// Send the plans' speeds as they are, without the braking-distance cap (the paper's
    /// executor; see `sim2d::governor`).
    #[arg(long)]
    pub no_governor: bool,
}

impl PlannerArgs {
    /// Writes the given options into `config` (validate it afterwards).
    pub fn apply(&self, config: &mut RunConfig) {
        if let Some(n) = self.horizon {
            config.ddp.horizon = n;
        }
        if let Some(m) = &self.model {
            config.ddpen.model = Some(m.clone());
        }
        if let Some(w) = self.w_subgoal {
            config.ddpen.w_subgoal = w;
        }
        if let Some(k) = self.subgoal_every {
            config.ddpen.subgoal_every = k;
        }
        if let Some(w) = self.w_contact {
            config.ddp.w_contact = w;
        }
        if self.no_governor {
            config.governor.enabled = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        planner: PlannerArgs,
    }

    #[test]
    fn options_reach_the_config_and_bad_values_are_named() {
        let cli = Cli::try_parse_from(["x", "--w-contact", "0", "--no-governor", "--horizon", "30"]).unwrap();
        let mut c = RunConfig::default();
        cli.planner.apply(&mut c);
        assert_eq!((c.ddp.w_contact, c.governor.enabled, c.ddp.horizon), (0.0, false, 30));
        assert_eq!(c.ddpen, RunConfig::default().ddpen);
        let cli = Cli::try_parse_from([
            "x",
            "--model",
            "m.safetensors",
            "--w-subgoal",
            "1.5",
            "--subgoal-every",
            "3",
        ])
        .unwrap();
        let mut c = RunConfig::default();
        cli.planner.apply(&mut c);
        assert_eq!(c.ddpen.model.as_deref(), Some(std::path::Path::new("m.safetensors")));
        assert_eq!((c.ddpen.w_subgoal, c.ddpen.subgoal_every), (1.5, 3));
        let cli = Cli::try_parse_from(["x", "--w-contact=-1"]).unwrap();
        let mut c = RunConfig::default();
        cli.planner.apply(&mut c);
        let e = c.validate().unwrap_err().to_string();
        assert!(e.starts_with("ddp.w_contact"), "{e}");
        assert!(Cli::try_parse_from(["x", "--horizon", "many"]).is_err());
    }
}
