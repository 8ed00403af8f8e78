//! Tensors by torch `state_dict` name, checked for dtype and shape, and the bookkeeping that makes
//! an unexpected (unused) tensor an error too.

use std::collections::BTreeSet;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use safetensors::{Dtype, SafeTensors};

use super::ops::{Act, Conv2d, LayerNorm, Linear};
use crate::error::{Error, Result};

/// Error naming a tensor.
pub(crate) fn tensor_error(name: &str, reason: impl Into<String>) -> Error {
    Error::invalid(format!("tensor {name:?}"), reason)
}

/// Where the tensors come from.
enum Source<'a> {
    File(SafeTensors<'a>),
    /// Seeded random values of the right shapes (benchmarks, tests).
    Random(ChaCha8Rng),
}

/// The tensors of one file; every `take` marks a name as used.
pub(crate) struct Weights<'a> {
    src: Source<'a>,
    used: BTreeSet<String>,
}

impl<'a> Weights<'a> {
    pub(crate) fn new(st: SafeTensors<'a>) -> Self {
        Self {
            src: Source::File(st),
            used: BTreeSet::new(),
        }
    }

    /// Random tensors: uniform in `+-1 / sqrt(fan_in)` (torch's default scale), batch-norm
    /// statistics near the identity.
    pub(crate) fn random(seed: u64) -> Self {
        Self {
            src: Source::Random(ChaCha8Rng::seed_from_u64(seed)),
            used: BTreeSet::new(),
        }
    }

    /// The `f32` tensor `name` of exactly `shape`, copied out (the file's bytes need not be aligned).
    pub(crate) fn take(&mut self, name: &str, shape: &[usize]) -> Result<Vec<f32>> {
        let st = match &mut self.src {
            Source::File(st) => st,
            Source::Random(rng) => {
                let n: usize = shape.iter().product();
                let fan_in: usize = shape.iter().skip(1).product::<usize>().max(1);
                let bound = 1.0 / (fan_in as f32).sqrt();
                let v = if name.ends_with("running_var")
                    || (name.contains("bn") || name.ends_with(".1.weight")) && shape.len() == 1
                {
                    (0..n).map(|_| rng.random_range(0.5..1.5)).collect()
                } else {
                    (0..n).map(|_| rng.random_range(-bound..bound)).collect()
                };
                self.used.insert(name.to_string());
                return Ok(v);
            }
        };
        let view = st
            .tensor(name)
            .map_err(|_| tensor_error(name, format!("is missing (expected shape {shape:?})")))?;
        if view.dtype() != Dtype::F32 {
            return Err(tensor_error(
                name,
                format!("has dtype {:?}, expected F32", view.dtype()),
            ));
        }
        if view.shape() != shape {
            return Err(tensor_error(
                name,
                format!("has shape {:?}, expected {shape:?}", view.shape()),
            ));
        }
        let data = view.data();
        let out: Vec<f32> = data
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        if out.len() != shape.iter().product::<usize>() {
            return Err(tensor_error(
                name,
                format!("holds {} bytes for shape {shape:?}", data.len()),
            ));
        }
        if let Some(i) = out.iter().position(|v| !v.is_finite()) {
            return Err(tensor_error(name, format!("element {i} is not finite ({})", out[i])));
        }
        self.used.insert(name.to_string());
        Ok(out)
    }

    /// `Linear(din, dout)` at `prefix.{weight,bias}`.
    pub(crate) fn linear(&mut self, prefix: &str, din: usize, dout: usize) -> Result<Linear> {
        Ok(Linear {
            din,
            dout,
            weight: self.take(&format!("{prefix}.weight"), &[dout, din])?,
            bias: self.take(&format!("{prefix}.bias"), &[dout])?,
        })
    }

    /// `LayerNorm(d)` at `prefix.{weight,bias}`.
    pub(crate) fn layer_norm(&mut self, prefix: &str, d: usize, eps: f32) -> Result<LayerNorm> {
        Ok(LayerNorm {
            weight: self.take(&format!("{prefix}.weight"), &[d])?,
            bias: self.take(&format!("{prefix}.bias"), &[d])?,
            eps,
        })
    }

    /// A `BatchNorm2d(c)` at `prefix` as the per-channel affine map `(scale, shift)` of eval mode.
    pub(crate) fn batch_norm(&mut self, prefix: &str, c: usize, eps: f32) -> Result<(Vec<f32>, Vec<f32>)> {
        let gamma = self.take(&format!("{prefix}.weight"), &[c])?;
        let beta = self.take(&format!("{prefix}.bias"), &[c])?;
        let mean = self.take(&format!("{prefix}.running_mean"), &[c])?;
        let var_name = format!("{prefix}.running_var");
        let var = self.take(&var_name, &[c])?;
        if let Some(i) = var.iter().position(|v| *v < 0.0) {
            return Err(tensor_error(&var_name, format!("element {i} is negative ({})", var[i])));
        }
        // The step counter is not needed for inference; it may be there (torch writes it).
        self.used.insert(format!("{prefix}.num_batches_tracked"));
        let scale: Vec<f32> = gamma.iter().zip(&var).map(|(g, v)| g / (v + eps).sqrt()).collect();
        let shift = beta
            .iter()
            .zip(&mean)
            .zip(&scale)
            .map(|((b, m), s)| b - m * s)
            .collect();
        Ok((scale, shift))
    }

    /// A bias-free `Conv2d(cin, cout, k, stride, padding = pad, groups)` at `conv` followed by
    /// `BatchNorm2d` at `bn`, folded into one convolution with bias. Returns `(weight, bias)` with
    /// the weight laid out `cout x (cin / groups) x k x k`.
    pub(crate) fn conv_bn(
        &mut self,
        conv: &str,
        bn: &str,
        cin_per_group: usize,
        cout: usize,
        k: usize,
        eps: f32,
    ) -> Result<(Vec<f32>, Vec<f32>)> {
        let mut w = self.take(&format!("{conv}.weight"), &[cout, cin_per_group, k, k])?;
        let (scale, shift) = self.batch_norm(bn, cout, eps)?;
        let per = cin_per_group * k * k;
        for (o, s) in scale.iter().enumerate() {
            w[o * per..(o + 1) * per].iter_mut().for_each(|v| *v *= s);
        }
        Ok((w, shift))
    }

    /// A dense conv + BN + activation, folded.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn conv2d_bn(
        &mut self,
        conv: &str,
        bn: &str,
        cin: usize,
        cout: usize,
        k: usize,
        stride: usize,
        eps: f32,
        act: Act,
    ) -> Result<Conv2d> {
        let (weight, bias) = self.conv_bn(conv, bn, cin, cout, k, eps)?;
        Ok(Conv2d {
            cin,
            cout,
            k,
            stride,
            pad: (k - 1) / 2,
            weight,
            bias,
            act,
        })
    }

    /// Names present in the file and never taken: an architecture mismatch.
    pub(crate) fn finish(self) -> Result<()> {
        let Source::File(st) = &self.src else {
            return Ok(());
        };
        let mut names = st.names();
        names.sort();
        for name in names {
            if !self.used.contains(name) {
                return Err(tensor_error(
                    name,
                    "is not part of the architecture in the metadata (unexpected tensor)",
                ));
            }
        }
        Ok(())
    }
}
