//! A [`Tape`] compiled into flat register programs: what the tape-backed models run in a solve.
//!
//! [`crate::eval`] interprets a tape node by node and is the reference; this module does the same
//! arithmetic with the bookkeeping moved to compile time, so that a traced model costs about what
//! its hand-written counterpart does:
//!
//! - **One scalar file `s`.** Inputs, constants, node values and the local partials that are not
//!   already values live in one array. The partials of `a + b`, `a - b`, `-a` are the constants
//!   `1` and `-1`, those of `a * b` are the values `b` and `a`, the derivative of `sin a` is the
//!   value `cos a`: the derivative programs read them where they already are, and only the other
//!   operations write partial slots.
//! - **`sin` and `cos` of one argument** are one `sin_cos` instruction (a rigid body's rotation
//!   uses both; the hand-written models compute them together too).
//! - **Jacobians by forward tangents as one flat list of multiply-adds**
//!   `dot[o] = s[p] dot[a] + s[q] dot[b]`, one per non-zero entry of every node's tangent (the
//!   tangent sparsity and the positions of the arguments' entries are resolved when compiling).
//!   An entry that only one argument has reads the other term as `0 * 0` from fixed zero slots,
//!   so the list has no branches and never forms `0 * inf`.
//! - **Weighted Hessians `sum_i lambda_i d^2F_i/dz^2` from one first-order reverse sweep.** With
//!   `vbar_i = d(lambda'F)/dv_i` the adjoints and `dv/dz` the tangents, the Hessian of a
//!   composition is (Griewank and Walther 2008, "Evaluating Derivatives", sec. 4.3, the
//!   second-order chain rule over the computational graph)
//!
//!   ```text
//!   d^2(lambda'F)/dz^2 = sum over nonlinear nodes i = phi(a, b) of
//!       vbar_i (phi_aa da da' + phi_ab (da db' + db da') + phi_bb db db')
//!   ```
//!
//!   so full DDP needs values, the scalar adjoints and the tangents of the arguments of the few
//!   nonlinear nodes only: no `n`-wide adjoint tangents. Every term's position in the Hessian is
//!   resolved when compiling; only the lower triangle (`row >= col`, in `z = (x, u)` order: the
//!   `xx`, `ux` and `uu` blocks a solver reads) below a row limit is formed.
//!
//! Scratch is a [`ProgramWorkspace`] that grows to the largest program it has run and then
//! allocates nothing.

use std::collections::BTreeMap;

use crate::op::{powc_partials, powc_value, Binary, Unary};
use crate::tape::{Node, Tape};

/// What an instruction computes.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Add,
    Sub,
    Mul,
    Neg,
    /// `s[dst] = sin a`, `s[b] = cos a`; partial slots `d = -sin a`, `d + 1 = -cos a`.
    SinCos,
    /// Partial slots `d = phi'`, `d + 1 = phi''`.
    Unary(Unary),
    /// Partial slots `d = a^p'`, `d + 1 = a^p''`.
    Powc(f64),
    /// Partial slots `d .. d + 5`: `phi_a, phi_b, phi_aa, phi_ab, phi_bb`.
    Binary(Binary),
}

/// One instruction: `s[dst] = kind(s[a], s[b])`, partials from `d` on.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Instr {
    kind: Kind,
    a: u32,
    b: u32,
    dst: u32,
    d: u32,
}

/// `dot[out] = s[p] * dot[a] + s[q] * dot[b]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Fma {
    out: u32,
    p: u32,
    a: u32,
    q: u32,
    b: u32,
}

/// `bar[arg] += s[p] * bar[r]` (the reverse sweep, in reverse order).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Adjoint {
    r: u32,
    arg: u32,
    p: u32,
}

/// The curvature of one nonlinear node in one pair of arguments: `c = bar[r] * s[k]`, then
/// `hess[h] += c * dot[u] * dot[w]` for its terms.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Curvature {
    r: u32,
    k: u32,
    terms: (u32, u32),
}

/// Slots of the fixed constants in `s`, right after the inputs.
const ZERO: u32 = 0;
const ONE: u32 = 1;
const MINUS_ONE: u32 = 2;
/// The zero slot of `dot`.
const DOT_ZERO: u32 = 0;
/// While compiling: "no partial" (then read as the constant zero).
const NONE: u32 = u32::MAX;

/// A tape compiled for evaluation (see the module docs). Immutable and `Send + Sync`; built once
/// per model.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    n_inputs: usize,
    /// The constants `0, 1, -1` and the tape's, copied to `s[n_inputs..]` before every run.
    consts: Vec<f64>,
    n_slots: usize,
    instrs: Vec<Instr>,
    outputs: Vec<u32>,
    n_dot: usize,
    /// Every node's tangent.
    jacobian: Vec<Fma>,
    /// `(output, input, dot slot)` for every structurally non-zero Jacobian entry.
    jacobian_entries: Vec<(u32, u32, u32)>,
    /// The tangents the curvature terms read, and what they depend on.
    hess_tangents: Vec<Fma>,
    adjoints: Vec<Adjoint>,
    /// Slots whose adjoint the reverse sweep accumulates (cleared before it).
    bar_slots: Vec<u32>,
    curvature: Vec<Curvature>,
    /// `(h, u, w)`: `hess[h] += c * dot[u] * dot[w]`.
    terms: Vec<(u32, u32, u32)>,
    /// `(row, col)` of `hess[h]`, `row >= col`, sorted.
    pattern: Vec<(u32, u32)>,
}

/// Scratch of [`Program`] runs.
#[derive(Debug, Clone, Default)]
pub struct ProgramWorkspace {
    /// Inputs, constants, values and partial slots.
    pub s: Vec<f64>,
    /// Tangent entries.
    pub dot: Vec<f64>,
    /// Adjoints, one per slot of `s` (the inputs' are the gradient after
    /// [`Program::second_order`]).
    pub bar: Vec<f64>,
    /// The lower-triangle Hessian entries at [`Program::hessian_pattern`].
    pub hess: Vec<f64>,
}

fn grow(v: &mut Vec<f64>, n: usize) {
    if v.len() < n {
        v.resize(n, 0.0);
    }
}

/// Which second partials of an operation can be non-zero: `(aa, ab, bb)`.
fn curvature_kinds(node: &Node) -> (bool, bool, bool) {
    match *node {
        Node::Unary(op, _) => {
            let linear = matches!(
                op,
                Unary::Neg | Unary::Abs | Unary::Sign | Unary::Floor | Unary::Ceil | Unary::Not
            );
            (!linear, false, false)
        }
        Node::Powc(_, p) => (p != 0.0 && p != 1.0, false, false),
        Node::Binary(op, _, _) => match op {
            Binary::Mul => (false, true, false),
            Binary::Div => (false, true, true),
            Binary::Pow | Binary::Atan2 | Binary::Hypot => (true, true, true),
            _ => (false, false, false),
        },
        Node::Input(_) | Node::Const(_) => (false, false, false),
    }
}

impl Program {
    /// Compiles `tape`, forming Hessian entries `(row, col)` with `row >= col` and
    /// `row < hessian_rows` (the inputs' count for everything; the state size where only the
    /// `xx` block is read). Allocates the program; running it allocates nothing once the
    /// workspace has grown.
    pub fn new(tape: &Tape, hessian_rows: usize) -> Self {
        let n = tape.n_inputs();
        let nodes = tape.nodes();
        let mut consts = vec![0.0, 1.0, -1.0];
        // Slot of every node's value.
        let mut slot = vec![u32::MAX; nodes.len()];
        for (i, node) in nodes.iter().enumerate() {
            match *node {
                Node::Input(k) => slot[i] = k,
                Node::Const(v) => {
                    slot[i] = (n + consts.len()) as u32;
                    consts.push(v);
                }
                _ => {}
            }
        }
        // sin and cos of one argument, for fusion.
        let mut sin_of = BTreeMap::new();
        let mut cos_of = BTreeMap::new();
        for (i, node) in nodes.iter().enumerate() {
            match *node {
                Node::Unary(Unary::Sin, a) => {
                    sin_of.insert(a, i);
                }
                Node::Unary(Unary::Cos, a) => {
                    cos_of.insert(a, i);
                }
                _ => {}
            }
        }
        let mut next = (n + consts.len()) as u32;
        // Value slots of the operations in node order; then partial slots after them.
        let mut order: Vec<usize> = Vec::new(); // nodes owning an instruction
        for (i, node) in nodes.iter().enumerate() {
            if matches!(node, Node::Input(_) | Node::Const(_)) || slot[i] != u32::MAX {
                continue;
            }
            let pair = match *node {
                Node::Unary(Unary::Sin | Unary::Cos, a) => sin_of.get(&a).zip(cos_of.get(&a)),
                _ => None,
            };
            if let Some((&si, &ci)) = pair {
                slot[si] = next;
                slot[ci] = next + 1;
                next += 2;
            } else {
                slot[i] = next;
                next += 1;
            }
            order.push(i);
        }
        let mut instrs = Vec::with_capacity(order.len());
        // Where each value slot's partials are: (d/da, d/db) slot and the second-partial slots
        // (aa, ab, bb), by value slot.
        let n_values = next as usize;
        let mut first: Vec<(u32, u32)> = vec![(NONE, NONE); n_values];
        let mut second: Vec<(u32, u32, u32)> = vec![(NONE, NONE, NONE); n_values];
        let mut args: Vec<(Option<u32>, Option<u32>)> = vec![(None, None); n_values];
        let off = |k: u32| n as u32 + k;
        for &i in &order {
            let node = nodes[i];
            let (a, b) = node.args();
            let (a, b) = (a.map(|x| slot[x as usize]), b.map(|x| slot[x as usize]));
            let dst = slot[i];
            let d = next;
            let (kind, width) = match node {
                Node::Unary(Unary::Sin | Unary::Cos, x) if sin_of.contains_key(&x) && cos_of.contains_key(&x) => {
                    let (s, c) = (slot[sin_of[&x]], slot[cos_of[&x]]);
                    // d sin = cos (a value), d cos = -sin (slot d); sin'' = -sin, cos'' = -cos.
                    first[s as usize] = (c, NONE);
                    first[c as usize] = (d, NONE);
                    second[s as usize] = (d, NONE, NONE);
                    second[c as usize] = (d + 1, NONE, NONE);
                    args[s as usize] = (a, None);
                    args[c as usize] = (a, None);
                    instrs.push(Instr {
                        kind: Kind::SinCos,
                        a: a.unwrap_or(0),
                        b: c,
                        dst: s,
                        d,
                    });
                    next += 2;
                    continue;
                }
                Node::Unary(Unary::Neg, _) => {
                    first[dst as usize] = (off(MINUS_ONE), NONE);
                    (Kind::Neg, 0)
                }
                Node::Unary(op, _) => {
                    first[dst as usize] = (d, NONE);
                    second[dst as usize] = (d + 1, NONE, NONE);
                    (Kind::Unary(op), 2)
                }
                Node::Powc(_, p) => {
                    first[dst as usize] = (d, NONE);
                    second[dst as usize] = (d + 1, NONE, NONE);
                    (Kind::Powc(p), 2)
                }
                Node::Binary(Binary::Add, ..) => {
                    first[dst as usize] = (off(ONE), off(ONE));
                    (Kind::Add, 0)
                }
                Node::Binary(Binary::Sub, ..) => {
                    first[dst as usize] = (off(ONE), off(MINUS_ONE));
                    (Kind::Sub, 0)
                }
                Node::Binary(Binary::Mul, ..) => {
                    let (sa, sb) = (a.unwrap_or(0), b.unwrap_or(0));
                    first[dst as usize] = (sb, sa);
                    second[dst as usize] = (NONE, off(ONE), NONE);
                    (Kind::Mul, 0)
                }
                Node::Binary(op, ..) => {
                    first[dst as usize] = (d, d + 1);
                    second[dst as usize] = (d + 2, d + 3, d + 4);
                    (Kind::Binary(op), 5)
                }
                Node::Input(_) | Node::Const(_) => unreachable!("only operations own instructions"),
            };
            args[dst as usize] = (a, b);
            instrs.push(Instr {
                kind,
                a: a.unwrap_or(0),
                b: b.unwrap_or(0),
                dst,
                d,
            });
            next += width;
        }
        let fix = |x: u32| if x == NONE { off(ZERO) } else { x };
        for f in first.iter_mut() {
            *f = (fix(f.0), fix(f.1));
        }
        let n_slots = next as usize;

        // Tangent sparsity by value slot: inputs, constants (none), operations (the tape's).
        let inputs: Vec<Vec<u32>> = (0..n as u32).map(|k| vec![k]).collect();
        let mut cols: Vec<&[u32]> = vec![&[]; n_values];
        let tc = tape.tangent_columns();
        for (i, node) in nodes.iter().enumerate() {
            let (s, e) = tape.tangent_range(i);
            if !matches!(node, Node::Const(_)) {
                cols[slot[i] as usize] = &tc[s..e];
            }
        }
        for k in 0..n {
            cols[k] = &inputs[k];
        }
        // dot[0] = 0, dot[1 + k] = 1 (input k); operations after.
        let mut dot_off = vec![0u32; n_values];
        let mut n_dot = 1 + n as u32;
        for k in 0..n {
            dot_off[k] = 1 + k as u32;
        }
        for v in n + consts.len()..n_values {
            dot_off[v] = n_dot;
            n_dot += cols[v].len() as u32;
        }
        let fma_of = |v: usize, out: &mut Vec<Fma>| {
            let (pa, pb) = first[v];
            let (a, b) = args[v];
            let find = |arg: Option<u32>, c: u32| {
                let arg = arg? as usize;
                let j = cols[arg].binary_search(&c).ok()?;
                Some(dot_off[arg] + j as u32)
            };
            for (j, &c) in cols[v].iter().enumerate() {
                let o = dot_off[v] + j as u32;
                let f = match (find(a, c), find(b, c)) {
                    (Some(x), Some(y)) => Fma {
                        out: o,
                        p: pa,
                        a: x,
                        q: pb,
                        b: y,
                    },
                    (Some(x), None) => Fma {
                        out: o,
                        p: pa,
                        a: x,
                        q: off(ZERO),
                        b: DOT_ZERO,
                    },
                    (None, Some(y)) => Fma {
                        out: o,
                        p: pb,
                        a: y,
                        q: off(ZERO),
                        b: DOT_ZERO,
                    },
                    (None, None) => Fma {
                        out: o,
                        p: off(ZERO),
                        a: DOT_ZERO,
                        q: off(ZERO),
                        b: DOT_ZERO,
                    },
                };
                out.push(f);
            }
        };
        let op_slots = n + consts.len()..n_values;
        let mut jacobian = Vec::new();
        for v in op_slots.clone() {
            fma_of(v, &mut jacobian);
        }
        let mut jacobian_entries = Vec::new();
        for (i, &o) in tape.outputs().iter().enumerate() {
            let v = slot[o as usize] as usize;
            for (j, &c) in cols[v].iter().enumerate() {
                jacobian_entries.push((i as u32, c, dot_off[v] + j as u32));
            }
        }

        // Curvature terms: for every nonlinear node, the pairs of argument tangent entries in
        // the kept part of the Hessian.
        let has_tangent = |x: Option<u32>| x.is_some_and(|x| !cols[x as usize].is_empty());
        let mut raw: Vec<(u32, u32, Vec<(u32, u32, u32, u32)>)> = Vec::new(); // (r, k, [(row, col, u, w)])
        let mut curved = vec![false; n_values];
        for (i, node) in nodes.iter().enumerate() {
            let (aa, ab, bb) = curvature_kinds(node);
            let v = slot[i] as usize;
            if v >= n_values || !(aa || ab || bb) {
                continue;
            }
            let (a, b) = args[v];
            let (kaa, kab, kbb) = second[v];
            let mut kinds = Vec::new();
            if aa && has_tangent(a) {
                kinds.push((fix(kaa), vec![(a, a)]));
            }
            if ab && has_tangent(a) && has_tangent(b) {
                kinds.push((fix(kab), vec![(a, b), (b, a)]));
            }
            if bb && has_tangent(b) {
                kinds.push((fix(kbb), vec![(b, b)]));
            }
            for (k, pairs) in kinds {
                let mut t = Vec::new();
                for (u, w) in pairs {
                    let (u, w) = (u.unwrap_or(0) as usize, w.unwrap_or(0) as usize);
                    for (p, &cu) in cols[u].iter().enumerate() {
                        for (q, &cw) in cols[w].iter().enumerate() {
                            if cu >= cw && (cu as usize) < hessian_rows {
                                t.push((cu, cw, dot_off[u] + p as u32, dot_off[w] + q as u32));
                            }
                        }
                    }
                }
                if !t.is_empty() {
                    curved[v] = true;
                    raw.push((v as u32, k, t));
                }
            }
        }
        let mut pattern: Vec<(u32, u32)> = raw
            .iter()
            .flat_map(|(_, _, t)| t.iter().map(|&(r, c, _, _)| (r, c)))
            .collect();
        pattern.sort_unstable();
        pattern.dedup();
        let mut curvature = Vec::with_capacity(raw.len());
        let mut terms = Vec::new();
        for (r, k, t) in raw {
            let start = terms.len() as u32;
            for (row, col, u, w) in t {
                let h = pattern.binary_search(&(row, col)).unwrap_or(0) as u32;
                terms.push((h, u, w));
            }
            curvature.push(Curvature {
                r,
                k,
                terms: (start, terms.len() as u32),
            });
        }
        // Tangents the curvature terms read, and everything they depend on.
        let mut need_tangent = vec![false; n_values];
        for c in &curvature {
            let (a, b) = args[c.r as usize];
            for x in [a, b].into_iter().flatten() {
                need_tangent[x as usize] = true;
            }
        }
        for v in op_slots.clone().rev() {
            if need_tangent[v] {
                let (a, b) = args[v];
                for x in [a, b].into_iter().flatten() {
                    need_tangent[x as usize] = true;
                }
            }
        }
        let mut hess_tangents = Vec::new();
        for v in op_slots.clone() {
            if need_tangent[v] {
                fma_of(v, &mut hess_tangents);
            }
        }
        // Adjoints are needed at curved nodes, at the inputs (the gradient) and on every path
        // between them.
        let mut need_bar = vec![false; n_values];
        for k in 0..n {
            need_bar[k] = true;
        }
        for v in op_slots.clone() {
            let (a, b) = args[v];
            need_bar[v] = curved[v] || [a, b].into_iter().flatten().any(|x| need_bar[x as usize]);
        }
        let mut adjoints = Vec::new();
        for v in op_slots.clone().rev() {
            if !need_bar[v] {
                continue;
            }
            let (a, b) = args[v];
            let (pa, pb) = first[v];
            for (x, p) in [(a, pa), (b, pb)] {
                if let Some(x) = x {
                    if need_bar[x as usize] {
                        adjoints.push(Adjoint { r: v as u32, arg: x, p });
                    }
                }
            }
        }
        let bar_slots = (0..n_values as u32).filter(|&v| need_bar[v as usize]).collect();
        Program {
            n_inputs: n,
            consts,
            n_slots,
            instrs,
            outputs: tape.outputs().iter().map(|&o| slot[o as usize]).collect(),
            n_dot: n_dot as usize,
            jacobian,
            jacobian_entries,
            hess_tangents,
            adjoints,
            bar_slots,
            curvature,
            terms,
            pattern,
        }
    }

    /// Number of inputs.
    pub fn n_inputs(&self) -> usize {
        self.n_inputs
    }

    /// Loads `z = (x, u)` (`x.len() + u.len() == n_inputs`) and the constants, then runs the
    /// instructions: values, with the first partials (`ORDER >= 1`) and second partials
    /// (`ORDER == 2`).
    fn run<const ORDER: u8>(&self, ws: &mut ProgramWorkspace, x: &[f64], u: &[f64]) {
        grow(&mut ws.s, self.n_slots);
        let n = self.n_inputs;
        let s = &mut ws.s[..self.n_slots];
        s[..x.len()].copy_from_slice(x);
        s[x.len()..n].copy_from_slice(u);
        s[n..n + self.consts.len()].copy_from_slice(&self.consts);
        for ins in &self.instrs {
            let (a, b, d) = (ins.a as usize, ins.b as usize, ins.d as usize);
            let v = match ins.kind {
                Kind::Add => s[a] + s[b],
                Kind::Sub => s[a] - s[b],
                Kind::Mul => s[a] * s[b],
                Kind::Neg => -s[a],
                Kind::SinCos => {
                    let (sn, cs) = s[a].sin_cos();
                    s[b] = cs;
                    if ORDER >= 1 {
                        s[d] = -sn;
                    }
                    if ORDER == 2 {
                        s[d + 1] = -cs;
                    }
                    sn
                }
                Kind::Unary(op) => {
                    if ORDER == 0 {
                        op.value(s[a])
                    } else {
                        let (v, p, pp) = op.partials(s[a]);
                        s[d] = p;
                        if ORDER == 2 {
                            s[d + 1] = pp;
                        }
                        v
                    }
                }
                Kind::Powc(p) => {
                    if ORDER == 0 {
                        powc_value(s[a], p)
                    } else {
                        let (v, dp, dpp) = powc_partials(s[a], p);
                        s[d] = dp;
                        if ORDER == 2 {
                            s[d + 1] = dpp;
                        }
                        v
                    }
                }
                Kind::Binary(op) => {
                    if ORDER == 0 {
                        op.value(s[a], s[b])
                    } else {
                        let p = op.partials(s[a], s[b]);
                        s[d] = p.a;
                        s[d + 1] = p.b;
                        if ORDER == 2 {
                            s[d + 2] = p.aa;
                            s[d + 3] = p.ab;
                            s[d + 4] = p.bb;
                        }
                        p.v
                    }
                }
            };
            s[ins.dst as usize] = v;
        }
    }

    fn tangents(&self, ws: &mut ProgramWorkspace, list: &[Fma]) {
        grow(&mut ws.dot, self.n_dot);
        let (s, dot) = (&ws.s, &mut ws.dot[..self.n_dot]);
        dot[0] = 0.0;
        dot[1..=self.n_inputs].fill(1.0);
        for f in list {
            dot[f.out as usize] = s[f.p as usize] * dot[f.a as usize] + s[f.q as usize] * dot[f.b as usize];
        }
    }

    /// The value of output `i` after a run.
    #[inline]
    pub fn output(&self, ws: &ProgramWorkspace, i: usize) -> f64 {
        ws.s[self.outputs[i] as usize]
    }

    /// Writes the outputs at `z = (x, u)` to `out`.
    pub fn values(&self, ws: &mut ProgramWorkspace, x: &[f64], u: &[f64], out: &mut [f64]) {
        self.run::<0>(ws, x, u);
        for (o, &v) in out.iter_mut().zip(&self.outputs) {
            *o = ws.s[v as usize];
        }
    }

    /// Values and Jacobian at `z = (x, u)`: afterwards [`Program::output`] gives the values and
    /// `ws.dot[slot]` the entry of every [`Program::jacobian_entries`] item.
    pub fn jacobian(&self, ws: &mut ProgramWorkspace, x: &[f64], u: &[f64]) {
        self.run::<1>(ws, x, u);
        self.tangents(ws, &self.jacobian);
    }

    /// `(output, input, dot slot)` of every structurally non-zero Jacobian entry.
    pub fn jacobian_entries(&self) -> &[(u32, u32, u32)] {
        &self.jacobian_entries
    }

    /// The weighted second derivatives at `z = (x, u)`: afterwards `ws.bar[k]` (`k <
    /// n_inputs`) is the gradient of `lambda'F` and `ws.hess[h]` its Hessian entry at
    /// [`Program::hessian_pattern`]`[h]`; [`Program::output`] gives the values.
    pub fn second_order(&self, ws: &mut ProgramWorkspace, x: &[f64], u: &[f64], lambda: &[f64]) {
        self.run::<2>(ws, x, u);
        self.tangents(ws, &self.hess_tangents);
        grow(&mut ws.bar, self.n_slots);
        let (s, dot, bar) = (&ws.s, &ws.dot, &mut ws.bar);
        for &v in &self.bar_slots {
            bar[v as usize] = 0.0;
        }
        for (&o, &l) in self.outputs.iter().zip(lambda) {
            bar[o as usize] += l;
        }
        for a in &self.adjoints {
            let b = bar[a.r as usize];
            // A zero adjoint adds nothing (never `0 * inf` from a partial).
            if b != 0.0 {
                bar[a.arg as usize] += s[a.p as usize] * b;
            }
        }
        grow(&mut ws.hess, self.pattern.len());
        let hess = &mut ws.hess[..self.pattern.len()];
        hess.fill(0.0);
        for c in &self.curvature {
            // A node without adjoint, or without curvature here, adds nothing (never
            // `0 * inf`).
            let (b, k) = (bar[c.r as usize], s[c.k as usize]);
            if b == 0.0 || k == 0.0 {
                continue;
            }
            let coef = b * k;
            for &(h, u, w) in &self.terms[c.terms.0 as usize..c.terms.1 as usize] {
                hess[h as usize] += coef * dot[u as usize] * dot[w as usize];
            }
        }
    }

    /// `(row, col)` of every Hessian entry [`Program::second_order`] forms (`row >= col`).
    pub fn hessian_pattern(&self) -> &[(u32, u32)] {
        &self.pattern
    }
}
