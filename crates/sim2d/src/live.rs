//! The live view (feature `live`): the topics of the run logs ([`crate::log`]) served over
//! Foxglove's WebSocket protocol on 127.0.0.1 while the simulation runs, at real time or a
//! chosen rate. Open Foxglove, "Open connection", `ws://127.0.0.1:8765`, and the shipped layout
//! `foxglove/ddpkit-layout.json`.
//!
//! ```no_run
//! let view = sim2d::live::LiveView::start(8765, 1.0)?;
//! println!("serving on ws://127.0.0.1:{}", view.port());
//! // Give `view.link()` to `BatchOptions::live`: the runs go one after another, paced.
//! # Ok::<(), sim2d::Error>(())
//! ```

use std::sync::Arc;

use foxglove::{Context, WebSocketServer, WebSocketServerHandle};

use crate::error::{Error, Result};
use crate::log::{LiveLink, Topics};

/// A running live view: its own context, the server and the channels runs log to. Stops the
/// server when dropped.
pub struct LiveView {
    _ctx: Arc<Context>,
    server: Option<WebSocketServerHandle>,
    topics: Arc<Topics>,
    rate: f64,
    port: u16,
}

impl LiveView {
    /// Serves on `127.0.0.1:port` (0: any free port, see [`LiveView::port`]); the runs will go
    /// at `rate` simulated seconds per second (1: real time, 0: unpaced). A port in use is an
    /// error naming it, before any run starts.
    pub fn start(port: u16, rate: f64) -> Result<Self> {
        crate::error::nonnegative("rate", rate)?;
        let ctx = Context::new();
        let topics = Arc::new(Topics::new(&ctx));
        let server = WebSocketServer::new()
            .name("ddpkit-sim2d")
            .bind("127.0.0.1", port)
            .context(&ctx)
            .start_blocking()
            .map_err(|e| Error::invalid("live_port", format!("cannot serve on 127.0.0.1:{port}: {e}")))?;
        let port = server.port();
        Ok(Self {
            _ctx: ctx,
            server: Some(server),
            topics,
            rate,
            port,
        })
    }

    /// The port served.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Connected clients.
    pub fn clients(&self) -> usize {
        self.server.as_ref().map_or(0, |s| s.client_count())
    }

    /// What [`crate::batch::BatchOptions::live`] takes.
    pub fn link(&self) -> LiveLink {
        LiveLink {
            topics: self.topics.clone(),
            rate: self.rate,
        }
    }
}

impl Drop for LiveView {
    fn drop(&mut self) {
        if let Some(s) = self.server.take() {
            s.stop().wait_blocking();
        }
    }
}
