//! The tape: a list of nodes in evaluation order, each referring only to earlier nodes, and the
//! nodes that are the outputs. [`TapeBuilder`] makes one: common subexpressions share a node
//! (hash-consing), constant subexpressions are folded, and nodes that no output needs are dropped.

use std::collections::HashMap;

use ddp_core::{Error, Result};

use crate::op::{powc_value, Binary, Unary};

/// One node of a tape. Arguments are indices of earlier nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Node {
    /// Input `z_k` (`z = (x, u)` for a model with controls).
    Input(u32),
    /// A finite constant.
    Const(f64),
    /// `op(a)`
    Unary(Unary, u32),
    /// `op(a, b)`
    Binary(Binary, u32, u32),
    /// `a^p` for a constant `p`.
    Powc(u32, f64),
}

impl Node {
    /// The node's arguments.
    pub fn args(&self) -> (Option<u32>, Option<u32>) {
        match *self {
            Node::Input(_) | Node::Const(_) => (None, None),
            Node::Unary(_, a) | Node::Powc(a, _) => (Some(a), None),
            Node::Binary(_, a, b) => (Some(a), Some(b)),
        }
    }
}

/// Largest number of nodes a tape may have (a guard against corrupt files; traced robot models
/// have hundreds to a few thousand).
pub const MAX_NODES: usize = 10_000_000;

/// An expression tape with `n_inputs` inputs and `outputs.len()` outputs. Immutable,
/// `Send + Sync`; evaluation scratch lives in an [`crate::eval::Workspace`].
#[derive(Debug, Clone, PartialEq)]
pub struct Tape {
    pub(crate) n_inputs: usize,
    pub(crate) nodes: Vec<Node>,
    pub(crate) outputs: Vec<u32>,
    /// Tangent sparsity: node `i` depends on the inputs `cols[off[i]..off[i + 1]]` (sorted),
    /// derived from `nodes`.
    pub(crate) off: Vec<u32>,
    pub(crate) cols: Vec<u32>,
}

/// The tangent sparsity of `nodes`: `(off, cols)` with node `i` depending on the inputs
/// `cols[off[i]..off[i + 1]]`, sorted (an input on itself, a constant on none, an operation on
/// the union of its arguments').
fn tangent_pattern(nodes: &[Node]) -> (Vec<u32>, Vec<u32>) {
    let mut off = Vec::with_capacity(nodes.len() + 1);
    off.push(0u32);
    let mut cols: Vec<u32> = Vec::new();
    let mut merged: Vec<u32> = Vec::new();
    for node in nodes {
        let range = |i: u32, off: &[u32]| off[i as usize] as usize..off[i as usize + 1] as usize;
        match *node {
            Node::Input(k) => cols.push(k),
            Node::Const(_) => {}
            Node::Unary(_, a) | Node::Powc(a, _) => cols.extend_from_within(range(a, &off)),
            Node::Binary(_, a, b) => {
                let (x, y) = (&cols[range(a, &off)], &cols[range(b, &off)]);
                merged.clear();
                let (mut i, mut j) = (0, 0);
                while i < x.len() || j < y.len() {
                    let next = match (x.get(i), y.get(j)) {
                        (Some(&p), Some(&q)) if p == q => {
                            i += 1;
                            j += 1;
                            p
                        }
                        (Some(&p), Some(&q)) if p < q => {
                            i += 1;
                            p
                        }
                        (Some(_), Some(&q)) | (None, Some(&q)) => {
                            j += 1;
                            q
                        }
                        (Some(&p), None) => {
                            i += 1;
                            p
                        }
                        (None, None) => break,
                    };
                    merged.push(next);
                }
                cols.extend_from_slice(&merged);
            }
        }
        off.push(cols.len() as u32);
    }
    (off, cols)
}

impl Tape {
    /// Number of inputs.
    pub fn n_inputs(&self) -> usize {
        self.n_inputs
    }
    /// The range of node `i`'s compact tangent in [`crate::eval::Workspace::dot`] (and of its
    /// columns in [`Tape::tangent_columns`]).
    #[inline]
    pub fn tangent_range(&self, i: usize) -> (usize, usize) {
        (self.off[i] as usize, self.off[i + 1] as usize)
    }
    /// The inputs every node depends on, node after node (see [`Tape::tangent_range`]).
    pub fn tangent_columns(&self) -> &[u32] {
        &self.cols
    }
    /// Number of outputs.
    pub fn n_outputs(&self) -> usize {
        self.outputs.len()
    }
    /// The nodes in evaluation order.
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }
    /// The output nodes.
    pub fn outputs(&self) -> &[u32] {
        &self.outputs
    }
    /// Whether some output depends on input `k` through the expression (structurally: a term
    /// multiplied by a constant zero was already removed by the builder).
    pub fn uses_input(&self, k: usize) -> bool {
        self.nodes
            .iter()
            .any(|n| matches!(n, Node::Input(i) if *i as usize == k))
    }

    /// Whether every output is a polynomial of degree at most 2 in the inputs: built from
    /// inputs and constants by `-a`, `+`, `-`, `*`, division by a constant and the constant
    /// powers 0, 1 and 2 (any other operation on a non-constant argument counts as
    /// non-polynomial). Its gradient is then affine and its Hessian the same at every point.
    pub fn is_at_most_quadratic(&self) -> bool {
        /// Degree of a non-polynomial node.
        const ANY: u32 = u32::MAX;
        let mut deg: Vec<u32> = Vec::with_capacity(self.nodes.len());
        for node in &self.nodes {
            let d = |a: u32| deg[a as usize];
            let v = match *node {
                Node::Input(_) => 1,
                Node::Const(_) => 0,
                Node::Unary(Unary::Neg, a) => d(a),
                Node::Binary(Binary::Add | Binary::Sub, a, b) => d(a).max(d(b)),
                Node::Binary(Binary::Mul, a, b) => d(a).saturating_add(d(b)),
                Node::Binary(Binary::Div, a, b) if d(b) == 0 => d(a),
                Node::Powc(a, p) if p == 0.0 || p == 1.0 || p == 2.0 => d(a).saturating_mul(p as u32),
                Node::Unary(_, a) | Node::Powc(a, _) => {
                    if d(a) == 0 {
                        0
                    } else {
                        ANY
                    }
                }
                Node::Binary(_, a, b) => {
                    if d(a).max(d(b)) == 0 {
                        0
                    } else {
                        ANY
                    }
                }
            };
            deg.push(v);
        }
        self.outputs.iter().all(|&o| deg[o as usize] <= 2)
    }

    /// A tape with the same outputs, rebuilt through a [`TapeBuilder`] (sharing, folding and
    /// dead-node removal applied), checking every reference: the way tapes from outside
    /// (files, Python, CasADi) enter. `nodes` must be in evaluation order.
    pub fn from_nodes(n_inputs: usize, nodes: &[Node], outputs: &[u32], field: &str) -> Result<Self> {
        if nodes.len() > MAX_NODES {
            return Err(Error::invalid(
                format!("{field}.nodes"),
                format!("{} nodes exceed the limit of {MAX_NODES}", nodes.len()),
            ));
        }
        let mut b = TapeBuilder::new(n_inputs);
        let mut map: Vec<u32> = Vec::with_capacity(nodes.len());
        for (i, n) in nodes.iter().enumerate() {
            let f = || format!("{field}.nodes[{i}]");
            let arg = |a: u32| -> Result<u32> {
                map.get(a as usize).copied().ok_or_else(|| {
                    Error::invalid(
                        f(),
                        format!("argument {a} does not refer to an earlier node (this is node {i})"),
                    )
                })
            };
            let id = match *n {
                Node::Input(k) => b.input(k as usize).map_err(|e| rename(e, &f()))?,
                Node::Const(v) => b.constant(v).map_err(|e| rename(e, &f()))?,
                Node::Unary(op, a) => b.unary(op, arg(a)?).map_err(|e| rename(e, &f()))?,
                Node::Powc(a, p) => b.powc(arg(a)?, p).map_err(|e| rename(e, &f()))?,
                Node::Binary(op, a, c) => b.binary(op, arg(a)?, arg(c)?).map_err(|e| rename(e, &f()))?,
            };
            map.push(id);
        }
        let mut outs = Vec::with_capacity(outputs.len());
        for (j, &o) in outputs.iter().enumerate() {
            let id = map.get(o as usize).copied().ok_or_else(|| {
                Error::invalid(
                    format!("{field}.outputs[{j}]"),
                    format!("node {o} does not exist ({} nodes)", nodes.len()),
                )
            })?;
            outs.push(id);
        }
        b.finish(&outs)
    }
}

fn rename(e: Error, field: &str) -> Error {
    match e {
        Error::Invalid { reason, .. } => Error::invalid(field, reason),
        Error::NotFinite { value, .. } => Error::invalid(field, format!("constant {value} is not finite")),
        other => other,
    }
}

/// Hash key of a node (constants by their bits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Key {
    Input(u32),
    Const(u64),
    Unary(Unary, u32),
    Binary(Binary, u32, u32),
    Powc(u32, u64),
}

/// Builds a [`Tape`]: every call returns the id of a node equal to the requested expression,
/// reusing an existing one where the same expression was built before.
#[derive(Debug, Clone)]
pub struct TapeBuilder {
    n_inputs: usize,
    nodes: Vec<Node>,
    seen: HashMap<Key, u32>,
}

impl TapeBuilder {
    /// A builder for a tape of `n_inputs` inputs.
    pub fn new(n_inputs: usize) -> Self {
        Self {
            n_inputs,
            nodes: Vec::new(),
            seen: HashMap::new(),
        }
    }

    fn push(&mut self, key: Key, node: Node) -> Result<u32> {
        if let Some(&id) = self.seen.get(&key) {
            return Ok(id);
        }
        if self.nodes.len() >= MAX_NODES {
            return Err(Error::invalid("nodes", format!("more than {MAX_NODES} nodes")));
        }
        let id = self.nodes.len() as u32;
        self.nodes.push(node);
        self.seen.insert(key, id);
        Ok(id)
    }

    fn const_of(&self, id: u32) -> Option<f64> {
        match self.nodes.get(id as usize) {
            Some(Node::Const(v)) => Some(*v),
            _ => None,
        }
    }

    fn check(&self, id: u32) -> Result<()> {
        if (id as usize) < self.nodes.len() {
            Ok(())
        } else {
            Err(Error::invalid("node", format!("argument {id} does not exist")))
        }
    }

    /// Input `z_k`.
    pub fn input(&mut self, k: usize) -> Result<u32> {
        if k >= self.n_inputs {
            return Err(Error::invalid(
                "input",
                format!("input index {k} out of range ({} inputs)", self.n_inputs),
            ));
        }
        self.push(Key::Input(k as u32), Node::Input(k as u32))
    }

    /// A constant (must be finite).
    pub fn constant(&mut self, v: f64) -> Result<u32> {
        if !v.is_finite() {
            return Err(Error::NotFinite {
                field: "constant".into(),
                index: 0,
                value: v,
            });
        }
        // -0.0 and 0.0 are one constant.
        let v = if v == 0.0 { 0.0 } else { v };
        self.push(Key::Const(v.to_bits()), Node::Const(v))
    }

    fn folded(&mut self, v: f64, what: &str) -> Result<u32> {
        if !v.is_finite() {
            return Err(Error::invalid(
                "constant",
                format!("the constant expression {what} evaluates to {v}"),
            ));
        }
        self.constant(v)
    }

    /// `op(a)`.
    pub fn unary(&mut self, op: Unary, a: u32) -> Result<u32> {
        self.check(a)?;
        if let Some(va) = self.const_of(a) {
            return self.folded(op.value(va), &format!("{}({va})", op.name()));
        }
        self.push(Key::Unary(op, a), Node::Unary(op, a))
    }

    /// `a^p` for a constant `p` (must be finite).
    pub fn powc(&mut self, a: u32, p: f64) -> Result<u32> {
        self.check(a)?;
        if !p.is_finite() {
            return Err(Error::invalid(
                "exponent",
                format!("constant exponent {p} is not finite"),
            ));
        }
        if let Some(va) = self.const_of(a) {
            return self.folded(powc_value(va, p), &format!("{va}^{p}"));
        }
        if p == 1.0 {
            return Ok(a);
        }
        if p == 0.0 {
            return self.constant(1.0);
        }
        self.push(Key::Powc(a, p.to_bits()), Node::Powc(a, p))
    }

    /// `op(a, b)`, with constant folding and the identities `a + 0`, `a * 1`, `a * 0 = 0`
    /// (as CasADi's SX simplifies; a term times a constant zero then no longer depends on its
    /// inputs), `a - 0`, `a / 1`, and `a ^ c` turned into [`Node::Powc`].
    pub fn binary(&mut self, op: Binary, a: u32, b: u32) -> Result<u32> {
        self.check(a)?;
        self.check(b)?;
        let (ca, cb) = (self.const_of(a), self.const_of(b));
        if let (Some(va), Some(vb)) = (ca, cb) {
            return self.folded(op.value(va, vb), &format!("{}({va}, {vb})", op.name()));
        }
        match (op, ca, cb) {
            // Float patterns compare with `==`, so `-0.0` matches too.
            (Binary::Add, Some(0.0), _) => return Ok(b),
            (Binary::Add | Binary::Sub, _, Some(0.0)) => return Ok(a),
            (Binary::Mul, Some(0.0), _) | (Binary::Mul, _, Some(0.0)) => return self.constant(0.0),
            (Binary::Mul, Some(1.0), _) => return Ok(b),
            (Binary::Mul | Binary::Div, _, Some(1.0)) => return Ok(a),
            (Binary::Sub, Some(0.0), _) => return self.unary(Unary::Neg, b),
            (Binary::Pow, _, Some(p)) => return self.powc(a, p),
            (Binary::IfElseZero, _, Some(0.0)) => return self.constant(0.0),
            _ => {}
        }
        let (a, b) = if op.commutes() && b < a { (b, a) } else { (a, b) };
        self.push(Key::Binary(op, a, b), Node::Binary(op, a, b))
    }

    /// The tape computing `outputs`, with the nodes no output needs removed.
    pub fn finish(self, outputs: &[u32]) -> Result<Tape> {
        for &o in outputs {
            self.check(o)?;
        }
        let n = self.nodes.len();
        let mut live = vec![false; n];
        for &o in outputs {
            live[o as usize] = true;
        }
        for i in (0..n).rev() {
            if live[i] {
                let (a, b) = self.nodes[i].args();
                for x in [a, b].into_iter().flatten() {
                    live[x as usize] = true;
                }
            }
        }
        let mut new_id = vec![u32::MAX; n];
        let mut nodes = Vec::with_capacity(live.iter().filter(|l| **l).count());
        for i in 0..n {
            if !live[i] {
                continue;
            }
            let m = |x: u32| new_id[x as usize];
            let node = match self.nodes[i] {
                Node::Unary(op, a) => Node::Unary(op, m(a)),
                Node::Powc(a, p) => Node::Powc(m(a), p),
                Node::Binary(op, a, b) => Node::Binary(op, m(a), m(b)),
                other => other,
            };
            new_id[i] = nodes.len() as u32;
            nodes.push(node);
        }
        let (off, cols) = tangent_pattern(&nodes);
        Ok(Tape {
            n_inputs: self.n_inputs,
            nodes,
            outputs: outputs.iter().map(|&o| new_id[o as usize]).collect(),
            off,
            cols,
        })
    }

    /// Copies `tape` into this builder with its inputs replaced by the nodes `args` (one per
    /// input of `tape`) and returns the ids of its outputs: composition of expressions, used to
    /// integrate an ODE (the right-hand side is inlined once per stage).
    pub fn inline(&mut self, tape: &Tape, args: &[u32]) -> Result<Vec<u32>> {
        if args.len() != tape.n_inputs {
            return Err(Error::invalid(
                "inline",
                format!("{} arguments for a tape of {} inputs", args.len(), tape.n_inputs),
            ));
        }
        let mut map = Vec::with_capacity(tape.nodes.len());
        for node in &tape.nodes {
            let m = |x: u32| map[x as usize];
            let id = match *node {
                Node::Input(k) => args[k as usize],
                Node::Const(v) => self.constant(v)?,
                Node::Unary(op, a) => self.unary(op, m(a))?,
                Node::Powc(a, p) => self.powc(m(a), p)?,
                Node::Binary(op, a, b) => self.binary(op, m(a), m(b))?,
            };
            map.push(id);
        }
        Ok(tape.outputs.iter().map(|&o| map[o as usize]).collect())
    }
}

/// How a continuous model `xdot = F(x, u)` becomes a discrete step over `dt` (control held).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Integrator {
    /// `x + dt F(x, u)`
    Euler,
    /// The classical fourth-order Runge-Kutta step.
    Rk4,
}

impl Integrator {
    /// `"euler"` or `"rk4"`.
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "euler" => Ok(Integrator::Euler),
            "rk4" => Ok(Integrator::Rk4),
            other => Err(Error::invalid(
                "integrator",
                format!("must be 'euler' or 'rk4', got '{other}'"),
            )),
        }
    }
}

/// The discrete step `x_{k+1} = x_k + dt * Phi(x_k, u_k)` of the ODE tape `ode` (inputs
/// `(x, u)`, `nx` outputs) by `integrator`, as one tape with the right-hand side inlined per
/// stage (so derivatives are exact derivatives of the discrete map).
pub fn discretize(ode: &Tape, nx: usize, nu: usize, dt: f64, integrator: Integrator) -> Result<Tape> {
    ddpkit_util::check::positive("dt", dt).map_err(Error::from)?;
    if ode.n_inputs != nx + nu || ode.outputs.len() != nx {
        return Err(Error::Shape {
            field: "ode".into(),
            got: format!("{} inputs, {} outputs", ode.n_inputs, ode.outputs.len()),
            expected: format!("{} inputs (nx + nu), {nx} outputs", nx + nu),
        });
    }
    let mut b = TapeBuilder::new(nx + nu);
    let z: Vec<u32> = (0..nx + nu).map(|k| b.input(k)).collect::<Result<_>>()?;
    let (x, u) = z.split_at(nx);
    // x + h * k, element-wise.
    let axpy = |b: &mut TapeBuilder, h: f64, k: &[u32]| -> Result<Vec<u32>> {
        let hc = b.constant(h)?;
        let mut out = Vec::with_capacity(nx);
        for i in 0..nx {
            let t = b.binary(Binary::Mul, hc, k[i])?;
            out.push(b.binary(Binary::Add, x[i], t)?);
        }
        Ok(out)
    };
    let stage = |b: &mut TapeBuilder, xs: &[u32]| -> Result<Vec<u32>> {
        let args: Vec<u32> = xs.iter().chain(u).copied().collect();
        b.inline(ode, &args)
    };
    let out = match integrator {
        Integrator::Euler => {
            let k1 = stage(&mut b, x)?;
            axpy(&mut b, dt, &k1)?
        }
        Integrator::Rk4 => {
            let k1 = stage(&mut b, x)?;
            let x2 = axpy(&mut b, 0.5 * dt, &k1)?;
            let k2 = stage(&mut b, &x2)?;
            let x3 = axpy(&mut b, 0.5 * dt, &k2)?;
            let k3 = stage(&mut b, &x3)?;
            let x4 = axpy(&mut b, dt, &k3)?;
            let k4 = stage(&mut b, &x4)?;
            // (k1 + 2 k2 + 2 k3 + k4) / 6
            let two = b.constant(2.0)?;
            let mut sum = Vec::with_capacity(nx);
            for i in 0..nx {
                let t2 = b.binary(Binary::Mul, two, k2[i])?;
                let t3 = b.binary(Binary::Mul, two, k3[i])?;
                let s = b.binary(Binary::Add, k1[i], t2)?;
                let s = b.binary(Binary::Add, s, t3)?;
                sum.push(b.binary(Binary::Add, s, k4[i])?);
            }
            axpy(&mut b, dt / 6.0, &sum)?
        }
    };
    b.finish(&out)
}
