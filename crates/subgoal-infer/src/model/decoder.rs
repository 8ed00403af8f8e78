//! `torch.nn.TransformerDecoder` (batch-first, no masks, eval mode) over the encoder tokens.

use super::config::{FfnActivation, ModelConfig};
use super::ops::{Act, Attention, AttnScratch, LayerNorm, Linear};
use super::weights::{tensor_error, Weights};
use crate::error::Result;

/// One `TransformerDecoderLayer`.
#[derive(Debug, Clone)]
struct DecoderLayer {
    self_attn: Attention,
    cross_attn: Attention,
    linear1: Linear,
    linear2: Linear,
    norm1: LayerNorm,
    norm2: LayerNorm,
    norm3: LayerNorm,
}

/// The decoder stack, with the final norm of pre-norm models.
#[derive(Debug, Clone)]
pub(crate) struct Decoder {
    layers: Vec<DecoderLayer>,
    norm: Option<LayerNorm>,
    norm_first: bool,
    act: Act,
    d: usize,
}

/// Scratch buffers of one forward pass.
#[derive(Debug, Default)]
pub(crate) struct DecoderScratch {
    attn: AttnScratch,
    k: Vec<f32>,
    v: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    h: Vec<f32>,
}

/// `nn.MultiheadAttention` at `prefix`: splits the packed `in_proj_weight` (`3d x d`).
fn attention(w: &mut Weights, prefix: &str, d: usize, heads: usize) -> Result<Attention> {
    let wname = format!("{prefix}.in_proj_weight");
    let bname = format!("{prefix}.in_proj_bias");
    let iw = w.take(&wname, &[3 * d, d])?;
    let ib = w.take(&bname, &[3 * d])?;
    let part = |i: usize| Linear {
        din: d,
        dout: d,
        weight: iw[i * d * d..(i + 1) * d * d].to_vec(),
        bias: ib[i * d..(i + 1) * d].to_vec(),
    };
    if d % heads != 0 {
        return Err(tensor_error(
            &wname,
            format!("d_model {d} is not divisible by {heads} heads"),
        ));
    }
    Ok(Attention {
        d,
        heads,
        q: part(0),
        k: part(1),
        v: part(2),
        out: w.linear(&format!("{prefix}.out_proj"), d, d)?,
    })
}

impl Decoder {
    pub(crate) fn load(cfg: &ModelConfig, w: &mut Weights) -> Result<Self> {
        let (d, ff, eps) = (cfg.d_model, cfg.dim_feedforward, cfg.layer_norm_eps);
        let mut layers = Vec::with_capacity(cfg.num_layers);
        for i in 0..cfg.num_layers {
            let p = format!("decoder.layers.{i}");
            layers.push(DecoderLayer {
                self_attn: attention(w, &format!("{p}.self_attn"), d, cfg.nhead)?,
                cross_attn: attention(w, &format!("{p}.multihead_attn"), d, cfg.nhead)?,
                linear1: w.linear(&format!("{p}.linear1"), d, ff)?,
                linear2: w.linear(&format!("{p}.linear2"), ff, d)?,
                norm1: w.layer_norm(&format!("{p}.norm1"), d, eps)?,
                norm2: w.layer_norm(&format!("{p}.norm2"), d, eps)?,
                norm3: w.layer_norm(&format!("{p}.norm3"), d, eps)?,
            });
        }
        let norm = if cfg.norm_first {
            Some(w.layer_norm("decoder.norm", d, eps)?)
        } else {
            None
        };
        let act = match cfg.activation {
            FfnActivation::Relu => Act::Relu,
            FfnActivation::Gelu => Act::Gelu,
        };
        Ok(Self {
            layers,
            norm,
            norm_first: cfg.norm_first,
            act,
            d,
        })
    }

    /// `x`: the `s x d` queries, updated in place; `memory`: `t x d` tokens.
    pub(crate) fn forward(&self, x: &mut [f32], s: usize, memory: &[f32], t: usize, sc: &mut DecoderScratch) {
        for l in &self.layers {
            // Self-attention block.
            self.block(x, &l.norm1, sc, |xin, sc, out| {
                l.self_attn.self_attend(xin, s, &mut sc.attn, out)
            });
            // Cross-attention block.
            self.block(x, &l.norm2, sc, |xin, sc, out| {
                l.cross_attn.project_kv(memory, t, &mut sc.k, &mut sc.v);
                l.cross_attn.attend(xin, s, &sc.k, &sc.v, t, &mut sc.attn, out);
            });
            // Feed-forward block.
            let act = self.act;
            self.block(x, &l.norm3, sc, |xin, sc, out| {
                l.linear1.forward(xin, s, &mut sc.h);
                act.apply(&mut sc.h);
                l.linear2.forward(&sc.h, s, out);
            });
        }
        if let Some(n) = &self.norm {
            n.forward(x);
        }
        debug_assert_eq!(x.len(), s * self.d);
    }

    /// A residual block: `x + f(norm(x))` (pre-norm) or `norm(x + f(x))` (post-norm).
    fn block(
        &self,
        x: &mut [f32],
        norm: &LayerNorm,
        sc: &mut DecoderScratch,
        f: impl FnOnce(&[f32], &mut DecoderScratch, &mut Vec<f32>),
    ) {
        let mut y = std::mem::take(&mut sc.y);
        let mut z = std::mem::take(&mut sc.z);
        if self.norm_first {
            y.clear();
            y.extend_from_slice(x);
            norm.forward(&mut y);
            f(&y, sc, &mut z);
            x.iter_mut().zip(&z).for_each(|(a, b)| *a += b);
        } else {
            f(x, sc, &mut z);
            x.iter_mut().zip(&z).for_each(|(a, b)| *a += b);
            norm.forward(x);
        }
        sc.y = y;
        sc.z = z;
    }
}
