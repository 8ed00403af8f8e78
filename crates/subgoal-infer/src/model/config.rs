//! The architecture, read from the JSON string under [`METADATA_KEY`] in the safetensors header
//! (written by `ddpkit.subgoal_model.export`).

use serde::Deserialize;

use crate::error::{Error, Result};

/// Key of the architecture JSON in the safetensors header metadata.
pub const METADATA_KEY: &str = "ddpkit.subgoal";
/// Value of the `format` field.
pub const FORMAT: &str = "ddpkit-subgoal";
/// The format version this crate reads.
pub const VERSION: u32 = 1;

/// The encoder family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Arch {
    /// Strided `conv-BN-ReLU` layers (`encoder.layers.{i}.{conv,bn}`).
    Cnn,
    /// torchvision's EfficientNet `features` (`encoder.features...`), one input channel.
    Efficientnet,
}

/// Activation of the decoder's feed-forward block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FfnActivation {
    /// `torch.nn.functional.relu`.
    Relu,
    /// `torch.nn.functional.gelu` (exact, erf).
    Gelu,
}

/// One layer of the small CNN.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CnnLayer {
    /// Output channels.
    pub channels: usize,
    /// Square kernel side (padding `kernel / 2`).
    pub kernel: usize,
    /// Stride.
    pub stride: usize,
}

/// One stage of MBConv blocks, as torchvision's `MBConvConfig` (channels already adjusted).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MbStage {
    /// Expansion ratio of the first 1x1 convolution.
    pub expand_ratio: f64,
    /// Depthwise kernel side.
    pub kernel: usize,
    /// Stride of the first block of the stage.
    pub stride: usize,
    /// Input channels of the first block.
    pub input_channels: usize,
    /// Output channels of every block.
    pub out_channels: usize,
    /// Number of blocks.
    pub num_layers: usize,
}

/// The EfficientNet encoder: stages and the width of the final 1x1 convolution.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EfficientNetConfig {
    /// `"b0"` for torchvision's `efficientnet_b0`, `"custom"` otherwise (informative only).
    #[serde(default)]
    pub variant: String,
    /// The MBConv stages.
    pub stages: Vec<MbStage>,
    /// Output channels of the last 1x1 convolution.
    pub last_channel: usize,
}

impl EfficientNetConfig {
    /// torchvision's `efficientnet_b0` (7 stages, 16 MBConv blocks, 1280 output channels).
    pub fn b0() -> Self {
        let rows: [(f64, usize, usize, usize, usize, usize); 7] = [
            (1.0, 3, 1, 32, 16, 1),
            (6.0, 3, 2, 16, 24, 2),
            (6.0, 5, 2, 24, 40, 2),
            (6.0, 3, 2, 40, 80, 3),
            (6.0, 5, 1, 80, 112, 3),
            (6.0, 5, 2, 112, 192, 4),
            (6.0, 3, 1, 192, 320, 1),
        ];
        Self {
            variant: "b0".into(),
            stages: rows
                .iter()
                .map(
                    |&(expand_ratio, kernel, stride, input_channels, out_channels, num_layers)| MbStage {
                        expand_ratio,
                        kernel,
                        stride,
                        input_channels,
                        out_channels,
                        num_layers,
                    },
                )
                .collect(),
            last_channel: 1280,
        }
    }
}

/// Everything needed to rebuild the network; see `py/python/ddpkit/subgoal_model.py`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct ModelConfig {
    /// Must be [`FORMAT`].
    pub format: String,
    /// Must be [`VERSION`].
    pub version: u32,
    /// The encoder family.
    pub arch: Arch,
    /// Side of the square input costmap in cells (200).
    pub in_size: usize,
    /// Costs are multiplied by this before the encoder (1 / 254).
    pub input_scale: f32,
    /// Goals in metres are divided by this before the goal embedding.
    pub goal_scale: f32,
    /// The head's outputs are multiplied by this to give metres.
    pub output_scale: f32,
    /// Width of the decoder.
    pub d_model: usize,
    /// Attention heads.
    pub nhead: usize,
    /// Decoder layers.
    pub num_layers: usize,
    /// Hidden width of the feed-forward block.
    pub dim_feedforward: usize,
    /// Activation of the feed-forward block.
    pub activation: FfnActivation,
    /// Pre-norm decoder layers (then with a final `decoder.norm`).
    pub norm_first: bool,
    /// Epsilon of the layer norms.
    pub layer_norm_eps: f32,
    /// Epsilon of the batch norms.
    pub bn_eps: f32,
    /// Number of sub-goals (learned queries).
    pub num_subgoals: usize,
    /// Layers of the small CNN (`arch = "cnn"`).
    #[serde(default)]
    pub cnn: Option<Vec<CnnLayer>>,
    /// The EfficientNet encoder (`arch = "efficientnet"`).
    #[serde(default)]
    pub efficientnet: Option<EfficientNetConfig>,
}

fn bad(field: &str, reason: impl Into<String>) -> Error {
    Error::invalid(format!("metadata {METADATA_KEY}.{field}"), reason)
}

fn in_range(field: &str, v: usize, lo: usize, hi: usize) -> Result<()> {
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(bad(field, format!("must be in [{lo}, {hi}], got {v}")))
    }
}

fn positive(field: &str, v: f32) -> Result<()> {
    ddpkit_util::check::positive(field, v)
        .map(|_| ())
        .map_err(|e| bad(field, e.reason()))
}

impl ModelConfig {
    /// Parses and validates the JSON of the header metadata.
    pub fn from_json(json: &str) -> Result<Self> {
        let c: ModelConfig =
            serde_json::from_str(json).map_err(|e| bad("", format!("is not a valid architecture: {e}")))?;
        c.validate()?;
        Ok(c)
    }

    /// Checks ranges (generous, but bounded so a hostile file cannot ask for huge buffers).
    pub fn validate(&self) -> Result<()> {
        if self.format != FORMAT {
            return Err(bad("format", format!("must be {FORMAT:?}, got {:?}", self.format)));
        }
        if self.version != VERSION {
            return Err(bad(
                "version",
                format!("this build reads version {VERSION}, got {}", self.version),
            ));
        }
        in_range("in_size", self.in_size, 8, 1024)?;
        in_range("d_model", self.d_model, 1, 4096)?;
        in_range("nhead", self.nhead, 1, 256)?;
        if self.d_model % self.nhead != 0 {
            return Err(bad(
                "nhead",
                format!("must divide d_model = {}, got {}", self.d_model, self.nhead),
            ));
        }
        in_range("num_layers", self.num_layers, 0, 64)?;
        in_range("dim_feedforward", self.dim_feedforward, 1, 65536)?;
        in_range("num_subgoals", self.num_subgoals, 1, 1024)?;
        positive("input_scale", self.input_scale)?;
        positive("goal_scale", self.goal_scale)?;
        positive("output_scale", self.output_scale)?;
        positive("layer_norm_eps", self.layer_norm_eps)?;
        positive("bn_eps", self.bn_eps)?;
        match self.arch {
            Arch::Cnn => {
                let layers = self
                    .cnn
                    .as_ref()
                    .ok_or_else(|| bad("cnn", "is required when arch is \"cnn\""))?;
                in_range("cnn (number of layers)", layers.len(), 1, 64)?;
                for (i, l) in layers.iter().enumerate() {
                    in_range(&format!("cnn[{i}].channels"), l.channels, 1, 8192)?;
                    in_range(&format!("cnn[{i}].kernel"), l.kernel, 1, 15)?;
                    in_range(&format!("cnn[{i}].stride"), l.stride, 1, 8)?;
                }
            }
            Arch::Efficientnet => {
                let e = self
                    .efficientnet
                    .as_ref()
                    .ok_or_else(|| bad("efficientnet", "is required when arch is \"efficientnet\""))?;
                in_range("efficientnet.stages (number)", e.stages.len(), 1, 64)?;
                in_range("efficientnet.last_channel", e.last_channel, 1, 8192)?;
                for (i, s) in e.stages.iter().enumerate() {
                    let f = |n: &str| format!("efficientnet.stages[{i}].{n}");
                    if !(s.expand_ratio.is_finite() && (1.0..=16.0).contains(&s.expand_ratio)) {
                        return Err(bad(
                            &f("expand_ratio"),
                            format!("must be in [1, 16], got {}", s.expand_ratio),
                        ));
                    }
                    in_range(&f("kernel"), s.kernel, 1, 15)?;
                    if s.kernel % 2 == 0 {
                        return Err(bad(&f("kernel"), format!("must be odd, got {}", s.kernel)));
                    }
                    in_range(&f("stride"), s.stride, 1, 2)?;
                    in_range(&f("input_channels"), s.input_channels, 1, 8192)?;
                    in_range(&f("out_channels"), s.out_channels, 1, 8192)?;
                    in_range(&f("num_layers"), s.num_layers, 1, 64)?;
                    if i > 0 && s.input_channels != e.stages[i - 1].out_channels {
                        return Err(bad(
                            &f("input_channels"),
                            format!(
                                "must equal the previous stage's out_channels {}, got {}",
                                e.stages[i - 1].out_channels,
                                s.input_channels
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

/// torchvision's `_make_divisible(v, 8)`: the nearest multiple of 8, at least 8, not more than
/// 10 % below `v`.
pub(crate) fn make_divisible(v: f64) -> usize {
    let divisor: f64 = 8.0;
    let mut new_v = divisor.max(((v + divisor / 2.0) as i64 / divisor as i64) as f64 * divisor);
    if new_v < 0.9 * v {
        new_v += divisor;
    }
    new_v as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn make_divisible_matches_torchvision_for_b0_widths() {
        // (input channels, expand ratio) -> expanded channels of efficientnet_b0.
        for (c, e, want) in [
            (32, 1.0, 32),
            (16, 6.0, 96),
            (24, 6.0, 144),
            (40, 6.0, 240),
            (80, 6.0, 480),
        ] {
            assert_eq!(make_divisible(c as f64 * e), want);
        }
        assert_eq!(make_divisible(4.0), 8);
        assert_eq!(make_divisible(12.0), 16);
    }
}
