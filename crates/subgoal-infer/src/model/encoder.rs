//! The two costmap encoders: the small strided CNN and torchvision's EfficientNet `features`.
//! Batch norms are folded into the preceding convolutions at load time.

use super::config::{make_divisible, EfficientNetConfig, ModelConfig};
use super::ops::{conv_out, Act, Conv2d, DepthwiseConv};
use super::weights::Weights;
use crate::error::Result;

/// Squeeze-excitation: global average, `fc1` (1x1 conv with bias), SiLU, `fc2`, sigmoid, scale.
#[derive(Debug, Clone)]
struct SqueezeExcite {
    channels: usize,
    squeeze: usize,
    /// `squeeze x channels`.
    w1: Vec<f32>,
    b1: Vec<f32>,
    /// `channels x squeeze`.
    w2: Vec<f32>,
    b2: Vec<f32>,
}

impl SqueezeExcite {
    fn forward(&self, x: &mut [f32], hw: usize) {
        let mean: Vec<f32> = x.chunks_exact(hw).map(|p| p.iter().sum::<f32>() / hw as f32).collect();
        let mut s: Vec<f32> = self.b1.clone();
        for (j, sj) in s.iter_mut().enumerate() {
            *sj += self.w1[j * self.channels..][..self.channels]
                .iter()
                .zip(&mean)
                .map(|(a, b)| a * b)
                .sum::<f32>();
        }
        Act::Silu.apply(&mut s);
        for (c, plane) in x.chunks_exact_mut(hw).enumerate() {
            let z = self.b2[c]
                + self.w2[c * self.squeeze..][..self.squeeze]
                    .iter()
                    .zip(&s)
                    .map(|(a, b)| a * b)
                    .sum::<f32>();
            let g = super::ops::sigmoid(z);
            plane.iter_mut().for_each(|v| *v *= g);
        }
    }
}

/// torchvision's `MBConv` in eval mode (stochastic depth is the identity).
#[derive(Debug, Clone)]
struct MbConv {
    expand: Option<Conv2d>,
    depthwise: DepthwiseConv,
    se: SqueezeExcite,
    project: Conv2d,
    residual: bool,
}

#[derive(Debug, Clone)]
enum Stage {
    Conv(Conv2d),
    MbConv(Box<MbConv>),
}

/// A costmap encoder: `1 x in x in` image to `channels x h x w` features.
#[derive(Debug, Clone)]
pub(crate) struct Encoder {
    stages: Vec<Stage>,
    /// Output channels.
    pub channels: usize,
    /// Output side (square).
    pub side: usize,
}

/// Scratch buffers of one forward pass.
#[derive(Debug, Default)]
pub(crate) struct EncoderScratch {
    a: Vec<f32>,
    b: Vec<f32>,
    c: Vec<f32>,
    col: Vec<f32>,
}

impl Encoder {
    /// The small CNN: `encoder.layers.{i}.conv` (no bias) + `encoder.layers.{i}.bn`, ReLU.
    pub(crate) fn cnn(cfg: &ModelConfig, w: &mut Weights) -> Result<Self> {
        let layers = cfg.cnn.as_deref().unwrap_or_default();
        let (mut cin, mut side) = (1, cfg.in_size);
        let mut stages = Vec::with_capacity(layers.len());
        for (i, l) in layers.iter().enumerate() {
            let p = format!("encoder.layers.{i}");
            let conv = w.conv2d_bn(
                &format!("{p}.conv"),
                &format!("{p}.bn"),
                cin,
                l.channels,
                l.kernel,
                l.stride,
                cfg.bn_eps,
                Act::Relu,
            )?;
            side = conv_out(side, l.kernel, l.stride, conv.pad);
            cin = l.channels;
            stages.push(Stage::Conv(conv));
        }
        Ok(Self {
            stages,
            channels: cin,
            side,
        })
    }

    /// torchvision's EfficientNet `features` with a one-channel stem:
    /// `encoder.features.0` (3x3/2 conv-BN-SiLU), `encoder.features.{1..=n}` (MBConv stages),
    /// `encoder.features.{n+1}` (1x1 conv-BN-SiLU to `last_channel`).
    pub(crate) fn efficientnet(cfg: &ModelConfig, e: &EfficientNetConfig, w: &mut Weights) -> Result<Self> {
        let eps = cfg.bn_eps;
        let stem_out = e.stages[0].input_channels;
        let stem = w.conv2d_bn(
            "encoder.features.0.0",
            "encoder.features.0.1",
            1,
            stem_out,
            3,
            2,
            eps,
            Act::Silu,
        )?;
        let mut side = conv_out(cfg.in_size, 3, 2, 1);
        let mut stages = vec![Stage::Conv(stem)];
        for (si, st) in e.stages.iter().enumerate() {
            for li in 0..st.num_layers {
                let (cin, stride) = if li == 0 {
                    (st.input_channels, st.stride)
                } else {
                    (st.out_channels, 1)
                };
                let p = format!("encoder.features.{}.{li}.block", si + 1);
                let expanded = make_divisible(cin as f64 * st.expand_ratio);
                let mut j = 0;
                let expand = if expanded != cin {
                    let c = w.conv2d_bn(
                        &format!("{p}.0.0"),
                        &format!("{p}.0.1"),
                        cin,
                        expanded,
                        1,
                        1,
                        eps,
                        Act::Silu,
                    )?;
                    j += 1;
                    Some(c)
                } else {
                    None
                };
                let k = st.kernel;
                let (dw_w, dw_b) = w.conv_bn(&format!("{p}.{j}.0"), &format!("{p}.{j}.1"), 1, expanded, k, eps)?;
                let depthwise = DepthwiseConv {
                    channels: expanded,
                    k,
                    stride,
                    pad: (k - 1) / 2,
                    weight: dw_w,
                    bias: dw_b,
                    act: Act::Silu,
                };
                j += 1;
                let squeeze = (cin / 4).max(1);
                let se = SqueezeExcite {
                    channels: expanded,
                    squeeze,
                    w1: w.take(&format!("{p}.{j}.fc1.weight"), &[squeeze, expanded, 1, 1])?,
                    b1: w.take(&format!("{p}.{j}.fc1.bias"), &[squeeze])?,
                    w2: w.take(&format!("{p}.{j}.fc2.weight"), &[expanded, squeeze, 1, 1])?,
                    b2: w.take(&format!("{p}.{j}.fc2.bias"), &[expanded])?,
                };
                j += 1;
                let project = w.conv2d_bn(
                    &format!("{p}.{j}.0"),
                    &format!("{p}.{j}.1"),
                    expanded,
                    st.out_channels,
                    1,
                    1,
                    eps,
                    Act::None,
                )?;
                side = conv_out(side, k, stride, (k - 1) / 2);
                stages.push(Stage::MbConv(Box::new(MbConv {
                    expand,
                    depthwise,
                    se,
                    project,
                    residual: stride == 1 && cin == st.out_channels,
                })));
            }
        }
        let n = e.stages.len() + 1;
        let last_in = e.stages[e.stages.len() - 1].out_channels;
        let last = w.conv2d_bn(
            &format!("encoder.features.{n}.0"),
            &format!("encoder.features.{n}.1"),
            last_in,
            e.last_channel,
            1,
            1,
            eps,
            Act::Silu,
        )?;
        stages.push(Stage::Conv(last));
        Ok(Self {
            stages,
            channels: e.last_channel,
            side,
        })
    }

    /// `cells`: the `in x in` costmap, scaled by `scale` into the one input channel; returns the
    /// `channels x side x side` features (in `s.a`).
    pub(crate) fn forward<'s>(&self, cells: &[u8], scale: f32, in_size: usize, s: &'s mut EncoderScratch) -> &'s [f32] {
        s.a.clear();
        s.a.extend(cells.iter().map(|c| *c as f32 * scale));
        let (mut h, mut w) = (in_size, in_size);
        for stage in &self.stages {
            match stage {
                Stage::Conv(c) => {
                    (h, w) = c.forward(&s.a, h, w, &mut s.b, &mut s.col);
                    std::mem::swap(&mut s.a, &mut s.b);
                }
                Stage::MbConv(m) => {
                    // s.a: block input; s.b: expanded; s.c: depthwise output; result back in s.a.
                    let src: &[f32] = if let Some(e) = &m.expand {
                        e.forward(&s.a, h, w, &mut s.b, &mut s.col);
                        &s.b
                    } else {
                        &s.a
                    };
                    let (ho, wo) = m.depthwise.forward(src, h, w, &mut s.c, &mut s.col);
                    m.se.forward(&mut s.c, ho * wo);
                    m.project.forward(&s.c, ho, wo, &mut s.b, &mut s.col);
                    if m.residual {
                        s.b.iter_mut().zip(&s.a).for_each(|(o, x)| *o += x);
                    }
                    std::mem::swap(&mut s.a, &mut s.b);
                    (h, w) = (ho, wo);
                }
            }
        }
        debug_assert_eq!((h, w), (self.side, self.side));
        &s.a
    }
}
