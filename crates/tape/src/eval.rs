//! Evaluation of a tape: values, first derivatives by forward tangents, and weighted second
//! derivatives by second-order adjoints.
//!
//! With `z` the inputs and `y = F(z)` the outputs:
//!
//! - [`Tape::forward`] computes every node's value `v_i` and, when asked, its tangent
//!   `dv_i/dz` (a row of `n` entries): `dv = phi_a da + phi_b db`. The outputs' tangents are the
//!   rows of the Jacobian `dF/dz`.
//! - [`Tape::second_order`] then runs the second-order adjoint sweep (forward-over-reverse; Griewank and
//!   Walther 2008, "Evaluating Derivatives", ch. 5): seeded with weights `lambda` on the outputs
//!   it propagates the adjoints `vbar_i = d(lambda'F)/dv_i` and their tangents
//!   `vbar_dot_i = d vbar_i / dz`,
//!
//!   ```text
//!   abar     += phi_a vbar
//!   abar_dot += phi_a vbar_dot + vbar (phi_aa da + phi_ab db)
//!   ```
//!
//!   so that at input `k`, `zbar_k` is the gradient of `lambda'F` and `zbar_dot_k` is row `k` of
//!   its Hessian `sum_i lambda_i d^2F_i/dz^2`. Both sweeps cost `O(nodes * n)`.
//!
//! Constants carry no tangent; terms through a constant argument are skipped (never `0 * inf`).
//! Scratch lives in a [`Workspace`] that grows to the largest tape it has seen and then
//! allocates nothing.

use crate::tape::{Node, Tape};

/// Scratch of the sweeps.
#[derive(Debug, Clone, Default)]
pub struct Workspace {
    /// Node values.
    pub val: Vec<f64>,
    /// Node tangents, `n` per node (row-major).
    pub dot: Vec<f64>,
    /// Node adjoints.
    pub bar: Vec<f64>,
    /// Adjoint tangents, `n` per node.
    pub bar_dot: Vec<f64>,
    /// The inputs `z`.
    pub z: Vec<f64>,
}

fn grow(v: &mut Vec<f64>, n: usize) {
    if v.len() < n {
        v.resize(n, 0.0);
    }
}

impl Tape {
    fn is_const(&self, i: u32) -> bool {
        matches!(self.nodes[i as usize], Node::Const(_))
    }

    /// Evaluates every node at `z` (`z.len() == n_inputs`); with `tangents` also every node's
    /// gradient with respect to `z` (in `ws.dot`, `n_inputs` per node).
    pub fn forward(&self, z: &[f64], ws: &mut Workspace, tangents: bool) {
        let n = self.n_inputs;
        let m = self.nodes.len();
        grow(&mut ws.val, m);
        if tangents {
            grow(&mut ws.dot, m * n);
        }
        for (i, node) in self.nodes.iter().enumerate() {
            let val = &mut ws.val;
            let v = match *node {
                Node::Input(k) => {
                    if tangents {
                        let d = &mut ws.dot[i * n..(i + 1) * n];
                        d.fill(0.0);
                        d[k as usize] = 1.0;
                    }
                    z[k as usize]
                }
                Node::Const(c) => c,
                Node::Unary(op, a) => {
                    let (v, d, _) = op.partials(val[a as usize]);
                    if tangents {
                        scale_row(&mut ws.dot, n, i, a as usize, d);
                    }
                    v
                }
                Node::Powc(a, p) => {
                    let (v, d, _) = crate::op::powc_partials(val[a as usize], p);
                    if tangents {
                        scale_row(&mut ws.dot, n, i, a as usize, d);
                    }
                    v
                }
                Node::Binary(op, a, b) => {
                    let p = op.partials(val[a as usize], val[b as usize]);
                    if tangents {
                        match (self.is_const(a), self.is_const(b)) {
                            (false, false) => {
                                let (lo, hi) = ws.dot.split_at_mut(i * n);
                                let (ra, rb) = (&lo[a as usize * n..][..n], &lo[b as usize * n..][..n]);
                                for ((o, x), y) in hi[..n].iter_mut().zip(ra).zip(rb) {
                                    *o = p.a * x + p.b * y;
                                }
                            }
                            (false, true) => scale_row(&mut ws.dot, n, i, a as usize, p.a),
                            (true, false) => scale_row(&mut ws.dot, n, i, b as usize, p.b),
                            // Folded by the builder; a zero row keeps the sweep total.
                            (true, true) => ws.dot[i * n..(i + 1) * n].fill(0.0),
                        }
                    }
                    p.v
                }
            };
            ws.val[i] = v;
        }
    }

    /// Values only, written to `out` (`n_outputs` entries).
    pub fn values(&self, z: &[f64], ws: &mut Workspace, out: &mut [f64]) {
        self.forward(z, ws, false);
        for (o, &id) in out.iter_mut().zip(&self.outputs) {
            *o = ws.val[id as usize];
        }
    }

    /// The second-order adjoint sweep after [`Tape::forward`] with tangents: seeds `lambda` on
    /// the outputs and calls `row(k, zbar_k, zbar_dot_k)` for every input `k` the outputs
    /// depend on (gradient entry and Hessian row of `lambda'F`; inputs not reached have zero
    /// gradient and Hessian rows and are not visited).
    pub fn second_order(&self, lambda: &[f64], ws: &mut Workspace, mut row: impl FnMut(usize, f64, &[f64])) {
        let n = self.n_inputs;
        let m = self.nodes.len();
        grow(&mut ws.bar, m);
        grow(&mut ws.bar_dot, m * n);
        ws.bar[..m].fill(0.0);
        ws.bar_dot[..m * n].fill(0.0);
        for (&o, &l) in self.outputs.iter().zip(lambda) {
            ws.bar[o as usize] += l;
        }
        for i in (0..m).rev() {
            let vbar = ws.bar[i];
            let (lo, hi) = ws.bar_dot.split_at_mut(i * n);
            let vbar_dot = &hi[..n];
            if vbar == 0.0 && vbar_dot.iter().all(|v| *v == 0.0) {
                continue;
            }
            match self.nodes[i] {
                Node::Input(k) => row(k as usize, vbar, vbar_dot),
                Node::Const(_) => {}
                Node::Unary(_, a) | Node::Powc(a, _) => {
                    let va = ws.val[a as usize];
                    let (_, d, dd) = match self.nodes[i] {
                        Node::Unary(op, _) => op.partials(va),
                        Node::Powc(_, p) => crate::op::powc_partials(va, p),
                        _ => (0.0, 0.0, 0.0),
                    };
                    ws.bar[a as usize] += d * vbar;
                    let da = &ws.dot[a as usize * n..][..n];
                    let c = vbar * dd;
                    for ((o, vd), x) in lo[a as usize * n..][..n].iter_mut().zip(vbar_dot).zip(da) {
                        *o += d * vd + c * x;
                    }
                }
                Node::Binary(op, a, b) => {
                    let p = op.partials(ws.val[a as usize], ws.val[b as usize]);
                    let (ca, cb) = (self.is_const(a), self.is_const(b));
                    // Tangent rows of the arguments, zero for a constant.
                    let da = (!ca).then(|| &ws.dot[a as usize * n..][..n]);
                    let db = (!cb).then(|| &ws.dot[b as usize * n..][..n]);
                    let mut acc = |target: usize,
                                   first: f64,
                                   own: f64,
                                   cross: f64,
                                   own_d: Option<&[f64]>,
                                   cross_d: Option<&[f64]>| {
                        let out = &mut lo[target * n..][..n];
                        for j in 0..n {
                            let mut s = first * vbar_dot[j];
                            if let Some(d) = own_d {
                                s += vbar * own * d[j];
                            }
                            if let Some(d) = cross_d {
                                s += vbar * cross * d[j];
                            }
                            out[j] += s;
                        }
                    };
                    if !ca {
                        acc(a as usize, p.a, p.aa, p.ab, da, db);
                    }
                    // For op(a, a) both sides land on one node, each adding its own terms.
                    if !cb {
                        acc(b as usize, p.b, p.bb, p.ab, db, da);
                    }
                    if !ca {
                        ws.bar[a as usize] += p.a * vbar;
                    }
                    if !cb {
                        ws.bar[b as usize] += p.b * vbar;
                    }
                }
            }
        }
    }
}

/// `dot[i] = d * dot[a]` (`a < i`).
#[inline]
fn scale_row(dot: &mut [f64], n: usize, i: usize, a: usize, d: f64) {
    let (lo, hi) = dot.split_at_mut(i * n);
    for (o, x) in hi[..n].iter_mut().zip(&lo[a * n..][..n]) {
        *o = d * x;
    }
}
