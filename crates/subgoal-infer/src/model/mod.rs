//! The DDPEN sub-goal network (Gamayunov et al. (2023), §II-C, Fig. 2),
//! `x_s = SG_theta(map, x_goal)`, run from the safetensors file that
//! `python -m ddpkit.train subgoal` exports.
//!
//! ```
//! use subgoal_infer::grid::{Costmap, LETHAL};
//! use subgoal_infer::SubgoalModel;
//!
//! let model = SubgoalModel::default_model()?;      // the weights shipped in models/
//! let mut map = Costmap::ddpen([0.0, 0.0]);        // 200 x 200 cells of 5 cm around the robot
//! map.mark([1.0, 0.2], LETHAL);
//! // The goal in metres relative to the map centre, in map axes (x: columns, y: rows).
//! let subgoals = model.predict(map.cells(), [4.5, 0.0])?;
//! assert_eq!(subgoals.len(), model.num_subgoals());
//! # Ok::<(), subgoal_infer::Error>(())
//! ```
//!
//! ## Network
//!
//! | stage | tensors (torch `state_dict` names) | shape |
//! |---|---|---|
//! | input | `cells * input_scale` | `1 x 200 x 200` |
//! | encoder, `arch = "cnn"` | `encoder.layers.{i}.conv`, `.bn`: strided conv-BN-ReLU | `C x h x w` |
//! | encoder, `arch = "efficientnet"` | `encoder.features.*`: torchvision EfficientNet (B0 or smaller) with a 1-channel stem | `C x h x w` |
//! | tokens | `input_proj` (linear `C -> d`) + `pos_embed` (learned, `hw x d`) | `hw x d` |
//! | goal | `goal_embed` (linear `2 -> d`) of `goal / goal_scale`, added to each query | `d` |
//! | queries | `queries`, one learned query per sub-goal | `S x d` |
//! | decoder | `decoder.layers.{i}`: `torch.nn.TransformerDecoderLayer` (self-attention, cross-attention to the tokens, FFN; post- or pre-norm), `decoder.norm` when pre-norm | `S x d` |
//! | head | `head` (linear `d -> 2`) times `output_scale` | `S x 2` metres |
//!
//! The architecture (every size above) is JSON in the safetensors header metadata under
//! [`METADATA_KEY`] ([`ModelConfig`]). Loading checks every tensor's presence, dtype (`F32`) and
//! shape against it, and rejects tensors the architecture does not use; errors name the tensor.
//! Batch norms are folded into the convolutions at load time (eval mode, running statistics).
//!
//! ## Why hand-written
//!
//! The two architectures are fixed and small, so the whole forward pass is a few hundred lines:
//! dense convolutions are `im2col` + SGEMM (nalgebra's safe strided views, which call
//! `matrixmultiply::sgemm`, the same kernel ndarray uses; the workspace forbids `unsafe`, so the
//! raw-pointer `matrixmultiply` API is not called directly), depthwise convolutions, squeeze-
//! excitation, layer norm and attention are loops. Compared with candle or tract this adds no
//! dependency tree (candle-core brings in `gemm`, `half`, `safetensors`, ... and compiles for
//! minutes on the CI's 2 cores; tract would need an ONNX export step with its own parity risk),
//! lets loading fold batch norms and name the exact torch tensor in every error, and runs one
//! sample on one thread with no dispatch overhead: the default model takes about a millisecond
//! (see `benches/inference.rs` and the crate README).

mod config;
mod decoder;
mod encoder;
mod ops;
mod weights;

use std::path::Path;

use safetensors::SafeTensors;

pub use config::{
    Arch, CnnLayer, EfficientNetConfig, FfnActivation, MbStage, ModelConfig, FORMAT, METADATA_KEY, VERSION,
};
use decoder::{Decoder, DecoderScratch};
use encoder::{Encoder, EncoderScratch};
use ops::{gemm, Linear};
use weights::Weights;

use crate::error::{Error, Result};

/// The default weights: the small CNN trained by the command in the crate README.
static DEFAULT_WEIGHTS: &[u8] = include_bytes!("../../models/default.safetensors");

thread_local! {
    /// Activation buffers reused by every prediction on this thread (no page faults from fresh
    /// multi-megabyte allocations on each call; EfficientNet-B0 keeps about 15 MB per thread).
    static SCRATCH: std::cell::RefCell<(EncoderScratch, DecoderScratch)> = Default::default();
}

/// A loaded sub-goal network: immutable, `Send + Sync`; [`predict`](Self::predict) works in
/// activation buffers kept per thread and grown on first use (about 1 MB for the default model).
#[derive(Debug, Clone)]
pub struct SubgoalModel {
    config: ModelConfig,
    encoder: Encoder,
    input_proj: Linear,
    pos_embed: Vec<f32>,
    goal_embed: Linear,
    queries: Vec<f32>,
    decoder: Decoder,
    head: Linear,
    tokens: usize,
}

impl SubgoalModel {
    /// Reads a safetensors file written by `ddpkit.subgoal_model.export`.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let bytes =
            std::fs::read(path).map_err(|e| Error::invalid("path", format!("cannot read {}: {e}", path.display())))?;
        Self::from_safetensors(&bytes)
    }

    /// Parses the bytes of a safetensors file: the header metadata gives the architecture, the
    /// tensors the weights. Errors name the tensor (missing, wrong dtype or shape, not finite,
    /// unexpected) or the metadata field.
    pub fn from_safetensors(bytes: &[u8]) -> Result<Self> {
        let (_, meta) = SafeTensors::read_metadata(bytes)
            .map_err(|e| Error::invalid("weights", format!("not a valid safetensors file: {e}")))?;
        let json = meta
            .metadata()
            .as_ref()
            .and_then(|m| m.get(METADATA_KEY))
            .ok_or_else(|| Error::invalid(format!("metadata {METADATA_KEY}"), "is missing from the header"))?;
        let config = ModelConfig::from_json(json)?;
        let st = SafeTensors::deserialize(bytes)
            .map_err(|e| Error::invalid("weights", format!("not a valid safetensors file: {e}")))?;
        let mut w = Weights::new(st);
        Self::build(config, &mut w).and_then(|m| w.finish().map(|_| m))
    }

    fn build(config: ModelConfig, w: &mut Weights) -> Result<Self> {
        let encoder = match config.arch {
            Arch::Cnn => Encoder::cnn(&config, w)?,
            Arch::Efficientnet => {
                let e = config.efficientnet.clone().ok_or_else(|| {
                    Error::invalid(
                        format!("metadata {METADATA_KEY}.efficientnet"),
                        "is required when arch is \"efficientnet\"",
                    )
                })?;
                Encoder::efficientnet(&config, &e, w)?
            }
        };
        let d = config.d_model;
        let tokens = encoder.side * encoder.side;
        Ok(Self {
            input_proj: w.linear("input_proj", encoder.channels, d)?,
            pos_embed: w.take("pos_embed", &[tokens, d])?,
            goal_embed: w.linear("goal_embed", 2, d)?,
            queries: w.take("queries", &[config.num_subgoals, d])?,
            decoder: Decoder::load(&config, w)?,
            head: w.linear("head", d, 2)?,
            encoder,
            tokens,
            config,
        })
    }

    /// The network of `config` with seeded random weights (uniform in `+-1/sqrt(fan_in)`): for
    /// benchmarks of architectures whose trained weights are not at hand, and for tests.
    pub fn with_random_weights(config: ModelConfig, seed: u64) -> Result<Self> {
        config.validate()?;
        Self::build(config, &mut Weights::random(seed))
    }

    /// The shipped default model (small CNN), compiled into the library.
    pub fn default_model() -> Result<Self> {
        Self::from_safetensors(DEFAULT_WEIGHTS)
    }

    /// Number of sub-goals per prediction (3 for the paper's steps 30, 50, 70).
    pub fn num_subgoals(&self) -> usize {
        self.config.num_subgoals
    }

    /// The architecture read from the file.
    pub fn config(&self) -> &ModelConfig {
        &self.config
    }

    /// `cells`: the 200 x 200 costmap laid out as `grid::Costmap::cells()`; `goal`: metres
    /// relative to the map centre in map axes. Returns the sub-goals in the same frame.
    pub fn predict(&self, cells: &[u8], goal: [f32; 2]) -> Result<Vec<[f32; 2]>> {
        let n = self.config.in_size;
        if cells.len() != n * n {
            return Err(Error::invalid(
                "cells",
                format!("must hold {n} x {n} = {} costs, got {}", n * n, cells.len()),
            ));
        }
        for (i, g) in goal.iter().enumerate() {
            if !g.is_finite() {
                return Err(Error::invalid(format!("goal[{i}]"), format!("must be finite, got {g}")));
            }
        }
        let pooled = SCRATCH.try_with(|scratch| {
            scratch.try_borrow_mut().ok().map(|mut sc| {
                let (es, ds) = &mut *sc;
                self.forward(cells, goal, es, ds)
            })
        });
        match pooled {
            Ok(Some(result)) => result,
            // Thread-local storage torn down, or already borrowed: fresh buffers.
            _ => self.forward(
                cells,
                goal,
                &mut EncoderScratch::default(),
                &mut DecoderScratch::default(),
            ),
        }
    }

    fn forward(
        &self,
        cells: &[u8],
        goal: [f32; 2],
        es: &mut EncoderScratch,
        ds: &mut DecoderScratch,
    ) -> Result<Vec<[f32; 2]>> {
        let n = self.config.in_size;
        let cfg = &self.config;
        let feat = self.encoder.forward(cells, cfg.input_scale, n, es);
        // Tokens: features transposed to `t x C`, projected to `d`, plus the positional embedding.
        let (t, c, d) = (self.tokens, self.encoder.channels, cfg.d_model);
        let mut memory = self.pos_embed.clone();
        for row in memory.chunks_exact_mut(d) {
            row.iter_mut().zip(&self.input_proj.bias).for_each(|(m, b)| *m += b);
        }
        gemm(t, d, c, feat, true, &self.input_proj.weight, true, 1.0, &mut memory);
        // Queries plus the goal embedding.
        let g = [goal[0] / cfg.goal_scale, goal[1] / cfg.goal_scale];
        let mut ge = Vec::new();
        self.goal_embed.forward(&g, 1, &mut ge);
        let s = cfg.num_subgoals;
        let mut x = self.queries.clone();
        for row in x.chunks_exact_mut(d) {
            row.iter_mut().zip(&ge).for_each(|(q, e)| *q += e);
        }
        self.decoder.forward(&mut x, s, &memory, t, ds);
        let mut out = Vec::new();
        self.head.forward(&x, s, &mut out);
        let result: Vec<[f32; 2]> = out
            .chunks_exact(2)
            .map(|p| [p[0] * cfg.output_scale, p[1] * cfg.output_scale])
            .collect();
        if result.iter().flatten().any(|v| !v.is_finite()) {
            return Err(Error::invalid("weights", "the network produced a non-finite sub-goal"));
        }
        Ok(result)
    }
}
