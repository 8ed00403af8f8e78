//! Evaluation of a tape: values, first derivatives by forward tangents, and weighted second
//! derivatives by second-order adjoints.
//!
//! With `z` the inputs and `y = F(z)` the outputs:
//!
//! - [`Tape::forward`] computes every node's value `v_i` and, when asked, its tangent
//!   `dv_i/dz`: `dv = phi_a da + phi_b db`, kept compact (only the entries of the inputs node `i`
//!   depends on, a sparsity pattern fixed when the tape is built), and the local partials
//!   `phi_a, phi_b, phi_aa, phi_ab, phi_bb`. The outputs' tangents are the rows of the Jacobian
//!   `dF/dz`.
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
//!   its Hessian `sum_i lambda_i d^2F_i/dz^2`. It reuses the partials of the forward sweep
//!   (no operation is differentiated twice). Both sweeps cost at most `O(nodes * n)`.
//!
//! Constants carry no tangent; terms through a constant argument are skipped (never `0 * inf`).
//! Scratch lives in a [`Workspace`] that grows to the largest tape it has seen and then
//! allocates nothing.

use crate::op::powc_value;
use crate::tape::{Node, Tape};

/// Scratch of the sweeps.
#[derive(Debug, Clone, Default)]
pub struct Workspace {
    /// Node values.
    pub val: Vec<f64>,
    /// Node tangents, compact: node `i` holds the entries of the inputs it depends on
    /// ([`Tape::tangent_columns`]), at `Tape::tangent_range(i)`.
    pub dot: Vec<f64>,
    /// The local partials of every node from the forward sweep, [`PARTIALS`] per node:
    /// `(phi_a, phi_b, phi_aa, phi_ab, phi_bb)` (a unary node uses `phi_a` and `phi_aa`).
    pub part: Vec<f64>,
    /// Node adjoints.
    pub bar: Vec<f64>,
    /// Adjoint tangents, `n` per node.
    pub bar_dot: Vec<f64>,
    /// One dense row of `n`: a node's contribution to an argument's adjoint tangent.
    pub row: Vec<f64>,
    /// The inputs `z`.
    pub z: Vec<f64>,
}

/// Partials cached per node by the forward sweep.
pub const PARTIALS: usize = 5;

fn grow(v: &mut Vec<f64>, n: usize) {
    if v.len() < n {
        v.resize(n, 0.0);
    }
}

impl Tape {
    /// Evaluates every node at `z` (`z.len() == n_inputs`); with `tangents` also every node's
    /// gradient with respect to `z` (compact, in `ws.dot`; see [`Tape::tangent_row`]) and the
    /// local partials the second-order sweep reuses.
    ///
    /// A node's tangent has entries only for the inputs it depends on (structurally), so a
    /// sparse model (a unicycle, the first stages of an integrator) sweeps short rows.
    pub fn forward(&self, z: &[f64], ws: &mut Workspace, tangents: bool) {
        let m = self.nodes.len();
        grow(&mut ws.val, m);
        if !tangents {
            let val = &mut ws.val;
            for (i, node) in self.nodes.iter().enumerate() {
                val[i] = match *node {
                    Node::Input(k) => z[k as usize],
                    Node::Const(c) => c,
                    Node::Unary(op, a) => op.value(val[a as usize]),
                    Node::Powc(a, p) => powc_value(val[a as usize], p),
                    Node::Binary(op, a, b) => op.value(val[a as usize], val[b as usize]),
                };
            }
            return;
        }
        grow(&mut ws.dot, self.cols.len());
        grow(&mut ws.part, m * PARTIALS);
        let (val, dot, part) = (&mut ws.val, &mut ws.dot, &mut ws.part);
        for (i, node) in self.nodes.iter().enumerate() {
            let (s, e) = self.tangent_range(i);
            let pi = &mut part[i * PARTIALS..][..PARTIALS];
            val[i] = match *node {
                Node::Input(k) => {
                    dot[s] = 1.0;
                    z[k as usize]
                }
                Node::Const(c) => c,
                Node::Unary(_, a) | Node::Powc(a, _) => {
                    let (v, d, dd) = match *node {
                        Node::Unary(op, _) => op.partials(val[a as usize]),
                        Node::Powc(_, p) => crate::op::powc_partials(val[a as usize], p),
                        _ => (0.0, 0.0, 0.0),
                    };
                    pi[0] = d;
                    pi[2] = dd;
                    // The argument depends on the same inputs.
                    let (sa, _) = self.tangent_range(a as usize);
                    let (lo, hi) = dot.split_at_mut(s);
                    for (o, x) in hi[..e - s].iter_mut().zip(&lo[sa..]) {
                        *o = d * x;
                    }
                    v
                }
                Node::Binary(op, a, b) => {
                    let p = op.partials(val[a as usize], val[b as usize]);
                    pi.copy_from_slice(&[p.a, p.b, p.aa, p.ab, p.bb]);
                    let (sa, ea) = self.tangent_range(a as usize);
                    let (sb, eb) = self.tangent_range(b as usize);
                    let len = e - s;
                    let (lo, hi) = dot.split_at_mut(s);
                    let out = &mut hi[..len];
                    if ea - sa == len && eb - sb == len {
                        // Both arguments depend on every input this node does.
                        for ((o, x), y) in out.iter_mut().zip(&lo[sa..ea]).zip(&lo[sb..eb]) {
                            *o = p.a * x + p.b * y;
                        }
                    } else {
                        // A constant argument has no entries and contributes nothing (never
                        // `0 * inf`).
                        let cols = &self.cols[s..e];
                        out.fill(0.0);
                        scatter(out, cols, &self.cols[sa..ea], &lo[sa..ea], p.a);
                        scatter(out, cols, &self.cols[sb..eb], &lo[sb..eb], p.b);
                    }
                    p.v
                }
            };
        }
    }

    /// Values only, written to `out` (`n_outputs` entries).
    pub fn values(&self, z: &[f64], ws: &mut Workspace, out: &mut [f64]) {
        self.forward(z, ws, false);
        for (o, &id) in out.iter_mut().zip(&self.outputs) {
            *o = ws.val[id as usize];
        }
    }

    /// Writes the gradient of `node` (after [`Tape::forward`] with tangents) as a dense row of
    /// `n_inputs` entries.
    pub fn tangent_row(&self, ws: &Workspace, node: usize, row: &mut [f64]) {
        row.fill(0.0);
        let (s, e) = self.tangent_range(node);
        for (&c, &v) in self.cols[s..e].iter().zip(&ws.dot[s..e]) {
            row[c as usize] = v;
        }
    }

    /// The second-order adjoint sweep after [`Tape::forward`] with tangents: seeds `lambda` on
    /// the outputs and calls `row(k, zbar_k, zbar_dot_k)` for every input `k` the outputs
    /// depend on (gradient entry and Hessian row of `lambda'F`; inputs not reached have zero
    /// gradient and Hessian rows and are not visited). Reuses the forward sweep's partials.
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
        grow(&mut ws.row, n);
        let (bar, bar_dot, dot, part) = (&mut ws.bar, &mut ws.bar_dot, &ws.dot, &ws.part);
        let tmp = &mut ws.row[..n];
        for i in (0..m).rev() {
            let vbar = bar[i];
            let (lo, hi) = bar_dot.split_at_mut(i * n);
            let vbar_dot = &hi[..n];
            if vbar == 0.0 && vbar_dot.iter().all(|v| *v == 0.0) {
                continue;
            }
            let pi = &part[i * PARTIALS..][..PARTIALS];
            // Each contribution is summed in `tmp` first and then added, term by term in the
            // order of the formula above, so the result does not depend on the sparsity.
            let mut push = |target: usize, first: f64, terms: [(usize, f64); 2], used: usize| {
                for (t, vd) in tmp.iter_mut().zip(vbar_dot) {
                    *t = first * vd;
                }
                for &(node, c) in &terms[..used] {
                    self.add_tangent(tmp, node, dot, c);
                }
                for (o, t) in lo[target * n..][..n].iter_mut().zip(tmp.iter()) {
                    *o += t;
                }
            };
            match self.nodes[i] {
                Node::Input(k) => row(k as usize, vbar, vbar_dot),
                Node::Const(_) => {}
                Node::Unary(_, a) | Node::Powc(a, _) => {
                    let (d, dd) = (pi[0], pi[2]);
                    let a = a as usize;
                    push(a, d, [(a, vbar * dd), (a, 0.0)], 1);
                    bar[a] += d * vbar;
                }
                Node::Binary(_, a, b) => {
                    let (pa, pb, paa, pab, pbb) = (pi[0], pi[1], pi[2], pi[3], pi[4]);
                    let (a, b) = (a as usize, b as usize);
                    // For op(a, a) both sides land on one node, each adding its own terms; a
                    // constant argument has no tangent entries and gets no adjoint.
                    if !self.is_const(a) {
                        push(a, pa, [(a, vbar * paa), (b, vbar * pab)], 2);
                    }
                    if !self.is_const(b) {
                        push(b, pb, [(b, vbar * pbb), (a, vbar * pab)], 2);
                    }
                    if !self.is_const(a) {
                        bar[a] += pa * vbar;
                    }
                    if !self.is_const(b) {
                        bar[b] += pb * vbar;
                    }
                }
            }
        }
    }

    fn is_const(&self, i: usize) -> bool {
        matches!(self.nodes[i], Node::Const(_))
    }

    /// `out += c * dv_node/dz` (dense `out`, compact tangent); nothing where `c == 0`.
    #[inline]
    fn add_tangent(&self, out: &mut [f64], node: usize, dot: &[f64], c: f64) {
        if c == 0.0 {
            return;
        }
        let (s, e) = self.tangent_range(node);
        for (&k, &v) in self.cols[s..e].iter().zip(&dot[s..e]) {
            out[k as usize] += c * v;
        }
    }
}

/// `out[cols_out == c] += f * x` for the entries `x` of an argument's compact tangent at columns
/// `cols_arg` (a subset of `cols_out`; both sorted).
#[inline]
fn scatter(out: &mut [f64], cols_out: &[u32], cols_arg: &[u32], x: &[f64], f: f64) {
    let mut j = 0;
    for (&c, &v) in cols_arg.iter().zip(x) {
        while cols_out[j] != c {
            j += 1;
        }
        out[j] += f * v;
    }
}
