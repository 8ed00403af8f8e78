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
//! - **One forward sweep per point for full DDP** ([`Needs::one_sweep`]). The solver linearises
//!   once and then runs a backward pass per regularisation it tries, each with new weights
//!   `lambda = V_x'` at the same `z`. Values, partials and tangents do not depend on `lambda`, so
//!   [`Program::jacobian_keep`] leaves them in the knot's data and
//!   [`Program::second_order_kept`] runs only the reverse sweep and the curvature terms.
//!
//! - **Instructions in runs of one kind.** The sweeps are bound by the dispatch on each
//!   instruction's kind (an indirect jump whose target changes from one instruction to the next,
//!   which the branch predictor misses often) rather than by the arithmetic. Compiling reorders
//!   the instructions (each still after those whose slots it reads; every slot is written once)
//!   so that additions, products and the fused `a + c b` follow each other, and the sweeps
//!   dispatch once per run: the planar quadrotor's RK4 step takes 0.26 instead of 0.45 us, the
//!   same bits.
//!
//! - **No bounds checks in the loops.** `s`, `dot` and `bar` are padded to a power of two (the
//!   program's width) and the loops index them as fixed-size arrays through a mask, which
//!   changes no index (every slot is below the width) and lets the compiler prove each access in
//!   bounds; a program wider than the largest fixed size runs the same loops with checks.
//!
//! Scratch is a [`ProgramWorkspace`] that grows to the largest program it has run and then
//! allocates nothing.

use std::collections::BTreeMap;

use ddp_core::models::sin_cos;

use crate::op::{powc_partials, powc_value, Binary, Unary};
use crate::tape::{Node, Tape};

/// What an instruction computes.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Add,
    Sub,
    Mul,
    Neg,
    /// `s[a] + s[d] * s[b]` and `s[a] - s[d] * s[b]` (`s[d]` a constant): `x + dt f` of an
    /// integrator in one instruction, in values-only runs.
    AddScaled,
    SubScaled,
    /// `s[dst] = sin a`, `s[b] = cos a`; partial slots `d = -sin a`, `d + 1 = -cos a`.
    SinCos,
    /// Partial slots `d = phi'`, `d + 1 = phi''`.
    Unary(Unary),
    /// Partial slots `d = a^p'`, `d + 1 = a^p''`.
    Powc(f64),
    /// Partial slots `d .. d + 5`: `phi_a, phi_b, phi_aa, phi_ab, phi_bb`.
    Binary(Binary),
}

/// A topological order of `deps.len()` items (`deps[i]`: the items that must precede item `i`)
/// that keeps items of one kind together: Kahn's sort, staying with the kind just emitted while
/// one of it is ready, else taking the lowest-index ready item. O(n log n).
fn grouped_order(mut deps: Vec<Vec<usize>>, key: impl Fn(usize) -> u32) -> Vec<usize> {
    use std::collections::BTreeSet;
    let n = deps.len();
    let mut after: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut waiting = vec![0usize; n];
    for (i, d) in deps.iter_mut().enumerate() {
        d.sort_unstable();
        d.dedup();
        waiting[i] = d.len();
        for &j in d.iter() {
            after[j].push(i);
        }
    }
    // The ready items, all and by kind.
    let mut ready: BTreeSet<usize> = BTreeSet::new();
    let mut ready_of: BTreeMap<u32, BTreeSet<usize>> = BTreeMap::new();
    let push = |i: usize, ready: &mut BTreeSet<usize>, ready_of: &mut BTreeMap<u32, BTreeSet<usize>>| {
        ready.insert(i);
        ready_of.entry(key(i)).or_default().insert(i);
    };
    for i in (0..n).filter(|&i| waiting[i] == 0) {
        push(i, &mut ready, &mut ready_of);
    }
    let mut order = Vec::with_capacity(n);
    let mut current: Option<u32> = None;
    while let Some(&first) = ready.first() {
        let pick = current
            .and_then(|k| ready_of.get(&k).and_then(|r| r.first().copied()))
            .unwrap_or(first);
        let k = key(pick);
        ready.remove(&pick);
        if let Some(r) = ready_of.get_mut(&k) {
            r.remove(&pick);
        }
        current = Some(k);
        order.push(pick);
        for &j in &after[pick] {
            waiting[j] -= 1;
            if waiting[j] == 0 {
                push(j, &mut ready, &mut ready_of);
            }
        }
    }
    order
}

/// Instructions in runs of one kind (see [`Instrs::new`]).
#[derive(Debug, Clone, PartialEq, Default)]
struct Instrs {
    list: Vec<Instr>,
    /// Lengths of the runs of `list`.
    runs: Vec<u32>,
}

impl Instrs {
    /// Reorders `list` (each instruction still after those whose slots it reads; every slot is
    /// written once) so that instructions of one kind follow each other ([`grouped_order`]).
    /// The values are those of the original order, bit for bit.
    fn new(list: Vec<Instr>) -> Self {
        let key = |k: &Kind| -> u32 {
            match *k {
                Kind::Add => 0,
                Kind::Sub => 1,
                Kind::Mul => 2,
                Kind::Neg => 3,
                Kind::AddScaled => 4,
                Kind::SubScaled => 5,
                Kind::SinCos => 6,
                Kind::Powc(_) => 7,
                Kind::Unary(op) => 100 + op as u32,
                Kind::Binary(op) => 200 + op as u32,
            }
        };
        let reads = |i: &Instr| -> [Option<u32>; 2] {
            match i.kind {
                Kind::Add | Kind::Sub | Kind::Mul | Kind::Binary(_) | Kind::AddScaled | Kind::SubScaled => {
                    [Some(i.a), Some(i.b)]
                }
                _ => [Some(i.a), None],
            }
        };
        let mut writer: BTreeMap<u32, usize> = BTreeMap::new();
        for (n, i) in list.iter().enumerate() {
            writer.insert(i.dst, n);
            if i.kind == Kind::SinCos {
                writer.insert(i.b, n);
            }
        }
        let deps = list
            .iter()
            .map(|i| {
                reads(i)
                    .into_iter()
                    .flatten()
                    .filter_map(|x| writer.get(&x).copied())
                    .collect()
            })
            .collect();
        let order = grouped_order(deps, |n| key(&list[n].kind));
        let (mut out, mut runs): (Vec<Instr>, Vec<u32>) = (Vec::with_capacity(list.len()), Vec::new());
        let mut current: Option<u32> = None;
        for n in order {
            let k = key(&list[n].kind);
            match runs.last_mut() {
                Some(last) if current == Some(k) => *last += 1,
                _ => runs.push(1),
            }
            current = Some(k);
            out.push(list[n]);
        }
        Instrs { list: out, runs }
    }
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
/// `hess[h] += c * dot[u] * dot[w]` for its terms and `hess[h] += c * (dot[u] * dot[w] +
/// dot[u2] * dot[w2])` for its pairs (two terms of one entry, as the mixed partial of a product
/// `a b` gives `da db' + db da'`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Curvature {
    r: u32,
    k: u32,
    terms: (u32, u32),
    pairs: (u32, u32),
}

/// Two curvature terms of one Hessian entry `h`: `(h, u, w, u2, w2)`.
type Pair = (u32, u32, u32, u32, u32);

/// Slots of the fixed constants in `s`, right after the inputs.
const ZERO: u32 = 0;
const ONE: u32 = 1;
const MINUS_ONE: u32 = 2;
/// Hessians of at most this many entries (22 inputs) are formed in a fixed-size array.
const SMALL_HESSIAN: usize = 256;
/// The zero slot of `dot`.
const DOT_ZERO: u32 = 0;
/// The slot of `dot` holding 1 (every input's tangent entry).
const DOT_ONE: u32 = 1;
/// While compiling: "no partial" (then read as the constant zero).
const NONE: u32 = u32::MAX;
/// While compiling: tag of a tangent entry computed at run time (they are placed after the
/// constant entries when the program is finished).
const RUNTIME: u32 = 1 << 31;
/// Largest number of terms a linear combination of tangents keeps symbolic; a longer one is
/// materialised (bounds the work of materialising it).
const MAX_TERMS: usize = 8;

static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

/// Identifies a compiled program, so that a workspace loads its constants once for a run of
/// evaluations of one model (every knot of a solve) rather than at every call. Equal for
/// comparison: two compilations of one tape are equal programs.
#[derive(Debug, Clone, Copy)]
struct ProgramId(u64);

impl PartialEq for ProgramId {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// A tape compiled for evaluation (see the module docs). Immutable and `Send + Sync`; built once
/// per model.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    id: ProgramId,
    n_inputs: usize,
    /// [`Needs::one_sweep`].
    one_sweep: bool,
    /// The constants `0, 1, -1` and the tape's, at `s[n_inputs..n_inputs + n_consts]`.
    n_consts: usize,
    /// Values and partials end at `n_slots`; the constant coefficients of tangent combinations
    /// follow.
    n_slots: usize,
    /// The power of two at least `s_template.len()` and `n_dot`: the length of `s`, `dot` and
    /// `bar` in the derivative loops (see [`Slots`]).
    width: usize,
    /// `s` with the constants and coefficients in place (the rest is written by every run).
    s_template: Vec<f64>,
    instrs: Instrs,
    /// The instructions [`Program::jacobian`] and [`Program::second_order`] run: those whose
    /// values or partials their sweeps read.
    jacobian_instrs: Instrs,
    hessian_instrs: Instrs,
    outputs: Vec<u32>,
    /// The constant tangent entries (`0`, `1`, and the entries of linear combinations of the
    /// inputs); run-time entries follow, up to `n_dot`.
    dot_template: Vec<f64>,
    n_dot: usize,
    /// Every node's tangent.
    jacobian: Tangents,
    /// `(output, input, dot slot)` for every structurally non-zero Jacobian entry.
    jacobian_entries: Vec<(u32, u32, u32)>,
    /// The tangents the curvature terms read, and what they depend on.
    hess_tangents: Tangents,
    adjoints: Vec<Adjoint>,
    /// One past the last slot whose adjoint the reverse sweep accumulates: `bar[..bar_len]` is
    /// cleared before it (one contiguous fill, cheaper than clearing only those slots).
    bar_len: usize,
    curvature: Vec<Curvature>,
    /// `(h, u, w)`: `hess[h] += c * dot[u] * dot[w]`.
    terms: Vec<(u32, u32, u32)>,
    pairs: Vec<Pair>,
    /// `(row, col)` of `hess[h]`, `row >= col`, sorted.
    pattern: Vec<(u32, u32)>,
}

/// What a model reads from a [`Program`]'s runs; what it does not read is not computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Needs {
    /// Hessian entries `(row, col)` kept: `row >= col` and `row < hessian_rows`.
    pub hessian_rows: usize,
    /// Whether [`Program::jacobian`] also computes the outputs' values.
    pub jacobian_values: bool,
    /// Whether [`Program::second_order`] computes the gradient and the outputs' values (a cost
    /// reads both; dynamics and constraints only the Hessian).
    pub gradient: bool,
    /// Whether [`Program::jacobian`] and [`Program::jacobian_keep`] also leave everything the
    /// reverse sweep of [`Program::second_order_kept`] reads (second partials and the
    /// curvature's tangents), so that full DDP sweeps forward once per knot and linearisation.
    pub one_sweep: bool,
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
    /// The program whose constants are loaded (0: none).
    loaded: u64,
}

/// `dst.copy_from_slice(src)` (equal lengths), inlined for the small sizes of robot states and
/// controls: a `memcpy` call costs more than the copy.
#[inline]
fn copy_small(dst: &mut [f64], src: &[f64]) {
    macro_rules! fixed {
        ($($k:literal)*) => {
            match src.len() {
                $($k => dst[..$k].copy_from_slice(&src[..$k]),)*
                _ => dst.copy_from_slice(src),
            }
        };
    }
    fixed!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16)
}

fn grow(v: &mut Vec<f64>, n: usize) {
    if v.len() < n {
        v.resize(n, 0.0);
    }
}

/// Scalars indexed by a program's `u32` slots. A fixed-size array of power-of-two length (the
/// program's `width`, above every slot) is indexed through a mask, which changes no index and
/// lets the compiler drop the bounds checks of the derivative loops; any other slice is indexed
/// as usual.
trait Slots {
    fn at(&self, i: u32) -> f64;
    fn at_mut(&mut self, i: u32) -> &mut f64;
    /// Sets the first `n` entries to zero.
    fn clear(&mut self, n: usize);
}

impl<const N: usize> Slots for [f64; N] {
    #[inline(always)]
    fn at(&self, i: u32) -> f64 {
        self[i as usize & (N - 1)]
    }
    #[inline(always)]
    fn at_mut(&mut self, i: u32) -> &mut f64 {
        &mut self[i as usize & (N - 1)]
    }
    #[inline(always)]
    fn clear(&mut self, n: usize) {
        self[..n].fill(0.0);
    }
}

impl Slots for [f64] {
    #[inline(always)]
    fn at(&self, i: u32) -> f64 {
        self[i as usize]
    }
    #[inline(always)]
    fn at_mut(&mut self, i: u32) -> &mut f64 {
        &mut self[i as usize]
    }
    #[inline(always)]
    fn clear(&mut self, n: usize) {
        self[..n].fill(0.0);
    }
}

/// `dot[out] = s[p] dot[a]`: a tangent entry that only one argument's tangent has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Scale {
    out: u32,
    p: u32,
    a: u32,
}

/// A list of [`Fma`] records with the one-term ones (`s[q] dot[b]` the constant `0 * 0`) as
/// [`Scale`]s, which skip the second product: `runs` alternates a count of `two` records and a
/// count of `one` records. The records are reordered (each still after every record whose entry
/// it reads or overwrites, and before every one that overwrites an entry it reads) so that the
/// runs are long.
#[derive(Debug, Clone, PartialEq, Default)]
struct Tangents {
    two: Vec<Fma>,
    one: Vec<Scale>,
    runs: Vec<(u32, u32)>,
}

impl Tangents {
    /// `zero`: the slot of the constant 0 in `s`.
    fn new(list: &[Fma], zero: u32) -> Self {
        let single = |f: &Fma| f.q == zero && f.b == DOT_ZERO;
        // Dependencies: read after write, write after write, write after read.
        let len = list
            .iter()
            .map(|f| f.out.max(f.a).max(f.b) as usize + 1)
            .max()
            .unwrap_or(0);
        let mut writer: Vec<Option<usize>> = vec![None; len];
        let mut readers: Vec<Vec<usize>> = vec![Vec::new(); len];
        let mut deps: Vec<Vec<usize>> = Vec::with_capacity(list.len());
        for (i, f) in list.iter().enumerate() {
            deps.push(
                [f.a, f.b, f.out]
                    .iter()
                    .filter_map(|&x| writer[x as usize])
                    .chain(readers[f.out as usize].iter().copied())
                    .filter(|&j| j != i)
                    .collect(),
            );
            for x in [f.a, f.b] {
                readers[x as usize].push(i);
            }
            writer[f.out as usize] = Some(i);
            readers[f.out as usize].clear();
        }
        let order = grouped_order(deps, |i| single(&list[i]) as u32);
        let mut t = Tangents::default();
        for f in order.iter().map(|&i| &list[i]) {
            let single = single(f);
            match t.runs.last_mut() {
                Some((_, k)) if single => *k += 1,
                Some((n, 0)) if !single => *n += 1,
                _ => t.runs.push(if single { (0, 1) } else { (1, 0) }),
            }
            if single {
                t.one.push(Scale {
                    out: f.out,
                    p: f.p,
                    a: f.a,
                });
            } else {
                t.two.push(*f);
            }
        }
        t
    }
}

/// Runs `list` in order: `dot[out] = s[p] dot[a] + s[q] dot[b]` for its two-term records and
/// `dot[out] = s[p] dot[a]` for its one-term ones.
#[inline(always)]
fn tangent_kernel<A: Slots + ?Sized>(list: &Tangents, s: &A, dot: &mut A) {
    let (mut two, mut one) = (&list.two[..], &list.one[..]);
    for &(n2, n1) in &list.runs {
        let (run, rest) = two.split_at(n2 as usize);
        two = rest;
        for f in run {
            *dot.at_mut(f.out) = s.at(f.p) * dot.at(f.a) + s.at(f.q) * dot.at(f.b);
        }
        let (run, rest) = one.split_at(n1 as usize);
        one = rest;
        for f in run {
            *dot.at_mut(f.out) = s.at(f.p) * dot.at(f.a);
        }
    }
}

/// The instructions on `s` (see [`Program::run`]), run by run: every run (`runs`, lengths)
/// holds instructions of one kind, so the common kinds dispatch once per run.
#[inline(always)]
fn sweep_kernel<const ORDER: u8, A: Slots + ?Sized>(instrs: &[Instr], runs: &[u32], s: &mut A) {
    let mut rest = instrs;
    for &n in runs {
        let (run, tail) = rest.split_at(n as usize);
        rest = tail;
        match run[0].kind {
            Kind::Add => {
                for i in run {
                    *s.at_mut(i.dst) = s.at(i.a) + s.at(i.b);
                }
            }
            Kind::Sub => {
                for i in run {
                    *s.at_mut(i.dst) = s.at(i.a) - s.at(i.b);
                }
            }
            Kind::Mul => {
                for i in run {
                    *s.at_mut(i.dst) = s.at(i.a) * s.at(i.b);
                }
            }
            Kind::AddScaled => {
                for i in run {
                    *s.at_mut(i.dst) = s.at(i.a) + s.at(i.d) * s.at(i.b);
                }
            }
            Kind::SubScaled => {
                for i in run {
                    *s.at_mut(i.dst) = s.at(i.a) - s.at(i.d) * s.at(i.b);
                }
            }
            _ => sweep_each::<ORDER, A>(run, s),
        }
    }
}

/// The instructions on `s` one at a time.
#[inline(always)]
fn sweep_each<const ORDER: u8, A: Slots + ?Sized>(instrs: &[Instr], s: &mut A) {
    for ins in instrs {
        let (a, b, d) = (ins.a, ins.b, ins.d);
        let v = match ins.kind {
            Kind::Add => s.at(a) + s.at(b),
            Kind::Sub => s.at(a) - s.at(b),
            Kind::Mul => s.at(a) * s.at(b),
            Kind::Neg => -s.at(a),
            Kind::AddScaled => s.at(a) + s.at(d) * s.at(b),
            Kind::SubScaled => s.at(a) - s.at(d) * s.at(b),
            Kind::SinCos => {
                let (sn, cs) = sin_cos(s.at(a));
                *s.at_mut(b) = cs;
                if ORDER >= 1 {
                    *s.at_mut(d) = -sn;
                }
                if ORDER == 2 {
                    *s.at_mut(d + 1) = -cs;
                }
                sn
            }
            Kind::Unary(op) => {
                if ORDER == 0 {
                    op.value(s.at(a))
                } else {
                    let (v, p, pp) = op.partials(s.at(a));
                    *s.at_mut(d) = p;
                    if ORDER == 2 {
                        *s.at_mut(d + 1) = pp;
                    }
                    v
                }
            }
            Kind::Powc(p) => {
                if ORDER == 0 {
                    powc_value(s.at(a), p)
                } else {
                    let (v, dp, dpp) = powc_partials(s.at(a), p);
                    *s.at_mut(d) = dp;
                    if ORDER == 2 {
                        *s.at_mut(d + 1) = dpp;
                    }
                    v
                }
            }
            Kind::Binary(op) => {
                if ORDER == 0 {
                    op.value(s.at(a), s.at(b))
                } else {
                    let p = op.partials(s.at(a), s.at(b));
                    *s.at_mut(d) = p.a;
                    *s.at_mut(d + 1) = p.b;
                    if ORDER == 2 {
                        *s.at_mut(d + 2) = p.aa;
                        *s.at_mut(d + 3) = p.ab;
                        *s.at_mut(d + 4) = p.bb;
                    }
                    p.v
                }
            }
        };
        *s.at_mut(ins.dst) = v;
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
        Self::with_needs(
            tape,
            Needs {
                hessian_rows,
                jacobian_values: true,
                gradient: true,
                one_sweep: false,
            },
        )
    }

    /// Compiles `tape` for a model that reads what `needs` says (the rest is not computed).
    pub fn with_needs(tape: &Tape, needs: Needs) -> Self {
        let hessian_rows = needs.hessian_rows;
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
        let mut widths: Vec<u32> = Vec::with_capacity(order.len());
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
                    widths.push(2);
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
            widths.push(width);
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
        // Linear operations with constant coefficients: `(arg, coefficient)` pairs.
        let const_value = |x: u32| {
            let k = x as usize;
            (k >= n && k < n + consts.len()).then(|| consts[k - n])
        };
        let mut linear: Vec<Option<Vec<(u32, f64)>>> = vec![None; n_values];
        for ins in &instrs {
            let (a, b, v) = (ins.a, ins.b, ins.dst as usize);
            linear[v] = match ins.kind {
                Kind::Add => Some(vec![(a, 1.0), (b, 1.0)]),
                Kind::Sub => Some(vec![(a, 1.0), (b, -1.0)]),
                Kind::Neg => Some(vec![(a, -1.0)]),
                Kind::Mul => match (const_value(a), const_value(b)) {
                    (Some(c), None) => Some(vec![(b, c)]),
                    (None, Some(c)) => Some(vec![(a, c)]),
                    _ => None,
                },
                Kind::Binary(Binary::Div) => const_value(b).map(|c| vec![(a, 1.0 / c)]),
                _ => None,
            };
            // Constant arguments carry no tangent.
            if let Some(l) = &mut linear[v] {
                l.retain(|&(x, _)| const_value(x).is_none());
            }
        }
        let mut tc = TangentCompiler {
            n_values,
            coef_base: n_slots as u32,
            coefs: Vec::new(),
            coef_of: BTreeMap::new(),
            template: vec![0.0, 1.0],
            records: Vec::new(),
            n_runtime: 0,
        };
        let op_slots = n + consts.len()..n_values;
        let ctx = Ctx {
            n,
            zero: off(ZERO),
            cols: &cols,
            first: &first,
            args: &args,
            linear: &linear,
        };
        let all: Vec<bool> = vec![true; n_values];
        let outputs: Vec<u32> = tape.outputs().iter().map(|&o| slot[o as usize]).collect();

        // Curvature terms: for every nonlinear node, the pairs of argument tangent entries in
        // the kept part of the Hessian, as (row, col, node u, entry p, node w, entry q).
        let has_tangent = |x: Option<u32>| x.is_some_and(|x| !cols[x as usize].is_empty());
        type Raw = (u32, u32, Vec<(u32, u32, u32, u32, u32, u32)>);
        let mut raw: Vec<Raw> = Vec::new();
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
                    let (u, w) = (u.unwrap_or(0), w.unwrap_or(0));
                    for (p, &cu) in cols[u as usize].iter().enumerate() {
                        for (q, &cw) in cols[w as usize].iter().enumerate() {
                            if cu >= cw && (cu as usize) < hessian_rows {
                                t.push((cu, cw, u, p as u32, w, q as u32));
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
        // Tangents the curvature terms read, and what they depend on.
        let mut relevant = vec![false; n_values];
        let mut required = Vec::new();
        for (r, _, _) in &raw {
            let (a, b) = args[*r as usize];
            for x in [a, b].into_iter().flatten() {
                relevant[x as usize] = true;
                required.push(x);
            }
        }
        for v in op_slots.clone().rev() {
            if relevant[v] {
                let (a, b) = args[v];
                for x in [a, b].into_iter().flatten() {
                    relevant[x as usize] = true;
                }
            }
        }
        required.sort_unstable();
        required.dedup();
        // With one sweep, the Jacobian's tangents also materialise the ones the curvature
        // reads. The arguments of nonlinear nodes are materialised where those nodes are
        // compiled either way, but a linear combination the Jacobian materialises may enter an
        // argument's tangent as one term where two sweeps sum its parts: the Hessians agree to
        // rounding (a random tape found a 1-ulp difference), each program with itself bit for bit.
        let mut jac_required = outputs.clone();
        if needs.one_sweep {
            jac_required.extend(&required);
        }
        let jac_state = tc.compile(&ctx, &all, &jac_required);
        let jacobian = std::mem::take(&mut tc.records);
        let mut jacobian_entries = Vec::new();
        for (i, &v) in outputs.iter().enumerate() {
            for (j, &c) in cols[v as usize].iter().enumerate() {
                jacobian_entries.push((
                    i as u32,
                    c,
                    jac_state.mat[v as usize].as_ref().map_or(DOT_ZERO, |m| m[j]),
                ));
            }
        }
        let jac_runtime = tc.n_runtime;
        tc.n_runtime = 0;
        let own_hess_state;
        let (hess_state, hess_tangents, hess_runtime) = if needs.one_sweep {
            (&jac_state, jacobian.clone(), 0)
        } else {
            own_hess_state = tc.compile(&ctx, &relevant, &required);
            (&own_hess_state, std::mem::take(&mut tc.records), tc.n_runtime)
        };
        let entry = |v: u32, j: u32| hess_state.mat[v as usize].as_ref().map_or(DOT_ZERO, |m| m[j as usize]);

        let mut pattern: Vec<(u32, u32)> = raw
            .iter()
            .flat_map(|(_, _, t)| t.iter().map(|&(r, c, ..)| (r, c)))
            .collect();
        pattern.sort_unstable();
        pattern.dedup();
        let mut curvature = Vec::with_capacity(raw.len());
        let mut terms = Vec::new();
        for (r, k, t) in raw {
            let start = terms.len() as u32;
            for (row, col, u, p, w, q) in t {
                let h = pattern.binary_search(&(row, col)).unwrap_or(0) as u32;
                terms.push((h, entry(u, p), entry(w, q)));
            }
            curvature.push(Curvature {
                r,
                k,
                terms: (start, terms.len() as u32),
                pairs: (0, 0),
            });
        }
        // Adjoints are needed at curved nodes, at the inputs (the gradient) and on every path
        // between them.
        let mut need_bar = vec![false; n_values];
        for k in 0..n {
            need_bar[k] = needs.gradient;
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
        let bar_len = need_bar.iter().rposition(|&b| b).map_or(0, |v| v + 1);
        // Runtime tangent entries follow the template.
        let base = tc.template.len() as u32;
        let fix_dot = |x: u32| if x & RUNTIME != 0 { base + (x & !RUNTIME) } else { x };
        let fix_fma = |f: &Fma| Fma {
            out: fix_dot(f.out),
            p: f.p,
            a: fix_dot(f.a),
            q: f.q,
            b: fix_dot(f.b),
        };
        let jacobian: Vec<Fma> = jacobian.iter().map(fix_fma).collect();
        let hess_tangents: Vec<Fma> = hess_tangents.iter().map(fix_fma).collect();
        for e in &mut jacobian_entries {
            e.2 = fix_dot(e.2);
        }
        for t in &mut terms {
            *t = (t.0, fix_dot(t.1), fix_dot(t.2));
        }
        // Terms of one node and one entry, two at a time.
        let mut singles = Vec::with_capacity(terms.len());
        let mut pairs: Vec<Pair> = Vec::new();
        for c in &mut curvature {
            let mut own: Vec<(u32, u32, u32)> = terms[c.terms.0 as usize..c.terms.1 as usize].to_vec();
            own.sort_by_key(|t| t.0);
            let start = (singles.len() as u32, pairs.len() as u32);
            let mut i = 0;
            while i < own.len() {
                let (h, u, w) = own[i];
                match own.get(i + 1) {
                    Some(&(h2, u2, w2)) if h2 == h => {
                        pairs.push((h, u, w, u2, w2));
                        i += 2;
                    }
                    _ => {
                        singles.push((h, u, w));
                        i += 1;
                    }
                }
            }
            c.terms = (start.0, singles.len() as u32);
            c.pairs = (start.1, pairs.len() as u32);
        }
        let terms = singles;
        // The instructions each sweep needs: owners of the slots it reads, and their arguments.
        let mut owner = vec![u32::MAX; n_slots];
        for (i, ins) in instrs.iter().enumerate() {
            owner[ins.dst as usize] = i as u32;
            if ins.kind == Kind::SinCos {
                owner[ins.b as usize] = i as u32;
            }
            for k in ins.d..ins.d + widths[i] {
                owner[k as usize] = i as u32;
            }
        }
        let needed = |reads: Vec<u32>| -> Vec<Instr> {
            let mut mark = vec![false; instrs.len()];
            let mut stack = reads;
            while let Some(x) = stack.pop() {
                let Some(&i) = owner.get(x as usize) else { continue };
                if i == u32::MAX || mark[i as usize] {
                    continue;
                }
                mark[i as usize] = true;
                let ins = &instrs[i as usize];
                stack.push(ins.a);
                if matches!(ins.kind, Kind::Add | Kind::Sub | Kind::Mul | Kind::Binary(_)) {
                    stack.push(ins.b);
                }
            }
            instrs.iter().zip(&mark).filter(|(_, m)| **m).map(|(i, _)| *i).collect()
        };
        let out_reads = |on: bool| if on { outputs.clone() } else { Vec::new() };
        let mut reads = out_reads(needs.jacobian_values);
        reads.extend(jacobian.iter().flat_map(|f: &Fma| [f.p, f.q]));
        let mut jacobian_instrs = needed(reads);
        let mut reads = out_reads(needs.gradient);
        reads.extend(hess_tangents.iter().flat_map(|f: &Fma| [f.p, f.q]));
        reads.extend(adjoints.iter().map(|a| a.p));
        reads.extend(curvature.iter().map(|c| c.k));
        let hessian_instrs = needed(reads);
        if needs.one_sweep {
            // The one sweep also leaves what the reverse sweep reads.
            let mut reads = out_reads(needs.jacobian_values || needs.gradient);
            reads.extend(jacobian.iter().flat_map(|f: &Fma| [f.p, f.q]));
            reads.extend(adjoints.iter().map(|a| a.p));
            reads.extend(curvature.iter().map(|c| c.k));
            jacobian_instrs = needed(reads);
        }
        let mut s_template = vec![0.0; n_slots + tc.coefs.len()];
        s_template[n..n + consts.len()].copy_from_slice(&consts);
        s_template[n_slots..].copy_from_slice(&tc.coefs);
        let n_dot = (base + jac_runtime.max(hess_runtime)) as usize;
        let width = s_template.len().max(n_dot).next_power_of_two();
        Program {
            id: ProgramId(NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed)),
            n_inputs: n,
            one_sweep: needs.one_sweep,
            n_consts: consts.len(),
            s_template,
            n_slots,
            instrs: Instrs::new(fuse_scaled(instrs, &outputs, |x| const_value(x).is_some())),
            jacobian_instrs: Instrs::new(jacobian_instrs),
            hessian_instrs: Instrs::new(hessian_instrs),
            outputs,
            dot_template: tc.template,
            n_dot,
            width,
            jacobian: Tangents::new(&jacobian, off(ZERO)),
            jacobian_entries,
            hess_tangents: Tangents::new(&hess_tangents, off(ZERO)),
            adjoints,
            bar_len,
            curvature,
            terms,
            pairs,
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
    fn run<const ORDER: u8>(&self, instrs: &Instrs, ws: &mut ProgramWorkspace, x: &[f64], u: &[f64]) {
        if ws.loaded != self.id.0 {
            grow(&mut ws.s, self.width);
            grow(&mut ws.dot, self.width);
            self.load(&mut ws.s, &mut ws.dot);
            ws.loaded = self.id.0;
        }
        self.sweep::<ORDER>(instrs, &mut ws.s[..self.width], x, u);
    }

    /// Writes the constants, coefficients and constant tangent entries (nothing else writes
    /// there) into `s` and `dot`.
    fn load(&self, s: &mut [f64], dot: &mut [f64]) {
        let (n, t) = (self.n_inputs, &self.s_template);
        s[n..n + self.n_consts].copy_from_slice(&t[n..n + self.n_consts]);
        s[self.n_slots..t.len()].copy_from_slice(&t[self.n_slots..]);
        dot[..self.dot_template.len()].copy_from_slice(&self.dot_template);
    }

    /// [`Program::run`] on a loaded `s` (`width` entries).
    #[inline(always)]
    fn sweep<const ORDER: u8>(&self, instrs: &Instrs, s: &mut [f64], x: &[f64], u: &[f64]) {
        let n = self.n_inputs;
        copy_small(&mut s[..x.len()], x);
        copy_small(&mut s[x.len()..n], u);
        macro_rules! fixed {
            ($($w:literal)*) => {
                match self.width {
                    $($w => {
                        if let Ok(s) = <&mut [f64; $w]>::try_from(&mut *s) {
                            return sweep_kernel::<ORDER, _>(&instrs.list, &instrs.runs, s);
                        }
                    })*
                    _ => {}
                }
            };
        }
        fixed!(8 16 32 64 128 256 512 1024 2048 4096 8192);
        sweep_kernel::<ORDER, _>(&instrs.list, &instrs.runs, s)
    }

    fn tangents(&self, ws: &mut ProgramWorkspace, list: &Tangents) {
        self.tangents_in(list, &ws.s[..self.width], &mut ws.dot[..self.width]);
    }

    /// The multiply-adds `list` on `s` and `dot` (`width` entries each).
    fn tangents_in(&self, list: &Tangents, s: &[f64], dot: &mut [f64]) {
        macro_rules! fixed {
            ($($w:literal)*) => {
                match self.width {
                    $($w => {
                        if let (Ok(s), Ok(dot)) = (<&[f64; $w]>::try_from(s), <&mut [f64; $w]>::try_from(&mut *dot)) {
                            return tangent_kernel(list, s, dot);
                        }
                    })*
                    _ => {}
                }
            };
        }
        fixed!(8 16 32 64 128 256 512 1024 2048 4096 8192);
        tangent_kernel(list, s, dot)
    }

    /// The value of output `i` after a run.
    #[inline]
    pub fn output(&self, ws: &ProgramWorkspace, i: usize) -> f64 {
        ws.s[self.outputs[i] as usize]
    }

    /// Writes the outputs at `z = (x, u)` to `out`.
    pub fn values(&self, ws: &mut ProgramWorkspace, x: &[f64], u: &[f64], out: &mut [f64]) {
        self.run::<0>(&self.instrs, ws, x, u);
        for (o, &v) in out.iter_mut().zip(&self.outputs) {
            *o = ws.s[v as usize];
        }
    }

    /// The Jacobian at `z = (x, u)`: afterwards `ws.dot[slot]` is the entry of every
    /// [`Program::jacobian_entries`] item, and [`Program::output`] gives the values where
    /// [`Needs::jacobian_values`].
    pub fn jacobian(&self, ws: &mut ProgramWorkspace, x: &[f64], u: &[f64]) {
        if self.one_sweep {
            self.run::<2>(&self.jacobian_instrs, ws, x, u);
        } else {
            self.run::<1>(&self.jacobian_instrs, ws, x, u);
        }
        self.tangents(ws, &self.jacobian);
    }

    /// `(output, input, dot slot)` of every structurally non-zero Jacobian entry.
    pub fn jacobian_entries(&self) -> &[(u32, u32, u32)] {
        &self.jacobian_entries
    }

    /// The weighted second derivatives at `z = (x, u)`: afterwards `ws.hess[h]` is the Hessian
    /// entry of `lambda'F` at [`Program::hessian_pattern`]`[h]`; where [`Needs::gradient`],
    /// `ws.bar[k]` (`k < n_inputs`) is its gradient and [`Program::output`] gives the values.
    pub fn second_order(&self, ws: &mut ProgramWorkspace, x: &[f64], u: &[f64], lambda: &[f64]) {
        self.run::<2>(&self.hessian_instrs, ws, x, u);
        self.tangents(ws, &self.hess_tangents);
        let ProgramWorkspace { s, dot, bar, hess, .. } = ws;
        self.reverse(&s[..self.width], &dot[..self.width], bar, hess, lambda);
    }

    /// The layout of a kept sweep ([`Program::jacobian_keep`]): the program's id, then `s`
    /// (which begins with the point `z`, never overwritten) and `dot`, `width` entries each.
    fn kept_len(&self) -> usize {
        1 + 2 * self.width
    }

    /// [`Program::jacobian`] into `data` instead of a workspace, keeping the sweep and the
    /// point for [`Program::second_order_kept`] (with [`Needs::one_sweep`] that is all the
    /// reverse sweep reads). `data` is resized and loaded once for this program (its first use,
    /// or after another program's); afterwards [`Program::kept_dot`] gives the tangent entries.
    pub fn jacobian_keep(&self, data: &mut Vec<f64>, x: &[f64], u: &[f64]) {
        let (len, s_len) = (self.kept_len(), self.width);
        if data.len() != len || data[0].to_bits() != self.id.0 {
            data.clear();
            data.resize(len, 0.0);
            data[0] = f64::from_bits(self.id.0);
            let (s, dot) = data[1..].split_at_mut(s_len);
            self.load(s, dot);
        }
        let (s, dot) = data[1..].split_at_mut(s_len);
        if self.one_sweep {
            self.sweep::<2>(&self.jacobian_instrs, s, x, u);
        } else {
            self.sweep::<1>(&self.jacobian_instrs, s, x, u);
        }
        self.tangents_in(&self.jacobian, s, dot);
    }

    /// The tangent entries of a sweep [`Program::jacobian_keep`] kept (indexed like
    /// [`ProgramWorkspace::dot`]).
    pub fn kept_dot<'a>(&self, data: &'a [f64]) -> &'a [f64] {
        &data[1 + self.width..]
    }

    /// [`Program::second_order`] from the sweep [`Program::jacobian_keep`] kept in `data`,
    /// without sweeping forward again; `false` (and nothing computed) unless `data` holds this
    /// program's sweep ([`Needs::one_sweep`]) at exactly `z = (x, u)` (bitwise).
    pub fn second_order_kept(
        &self,
        ws: &mut ProgramWorkspace,
        data: &[f64],
        x: &[f64],
        u: &[f64],
        lambda: &[f64],
    ) -> bool {
        let n = self.n_inputs;
        if !self.one_sweep || data.len() != self.kept_len() || data[0].to_bits() != self.id.0 {
            return false;
        }
        let (s, dot) = data[1..].split_at(self.width);
        let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(p, q)| p.to_bits() == q.to_bits());
        if x.len() + u.len() != n || !same(&s[..x.len()], x) || !same(&s[x.len()..n], u) {
            return false;
        }
        let ProgramWorkspace { bar, hess, .. } = ws;
        self.reverse(s, dot, bar, hess, lambda);
        true
    }

    /// The reverse sweep and the curvature terms of [`Program::second_order`] after its
    /// forward sweep left `s` and `dot` (`width` entries each).
    fn reverse(&self, s: &[f64], dot: &[f64], bar: &mut Vec<f64>, hess: &mut Vec<f64>, lambda: &[f64]) {
        grow(bar, self.width);
        let len = self.pattern.len();
        grow(hess, len.max(SMALL_HESSIAN));
        hess[..len].fill(0.0);
        let bar = &mut bar[..self.width];
        macro_rules! fixed {
            ($($w:literal)*) => {
                match self.width {
                    $($w => {
                        if let (Ok(s), Ok(dot), Ok(bar)) = (
                            <&[f64; $w]>::try_from(s),
                            <&[f64; $w]>::try_from(dot),
                            <&mut [f64; $w]>::try_from(&mut *bar),
                        ) {
                            return self.reverse_kernel(s, dot, bar, hess, lambda);
                        }
                    })*
                    _ => {}
                }
            };
        }
        fixed!(8 16 32 64 128 256 512 1024 2048 4096 8192);
        self.reverse_kernel(s, dot, bar, hess, lambda)
    }

    #[inline(always)]
    fn reverse_kernel<A: Slots + ?Sized>(&self, s: &A, dot: &A, bar: &mut A, hess: &mut [f64], lambda: &[f64]) {
        bar.clear(self.bar_len);
        for (&o, &l) in self.outputs.iter().zip(lambda) {
            *bar.at_mut(o) += l;
        }
        for a in &self.adjoints {
            let b = bar.at(a.r);
            // A zero adjoint adds nothing (never `0 * inf` from a partial).
            if b != 0.0 {
                *bar.at_mut(a.arg) += s.at(a.p) * b;
            }
        }
        let len = self.pattern.len();
        macro_rules! curvature {
            ($hess:expr, $at:expr) => {
                for c in &self.curvature {
                    // A node without adjoint, or without curvature here, adds nothing (never
                    // `0 * inf`).
                    let (b, k) = (bar.at(c.r), s.at(c.k));
                    if b == 0.0 || k == 0.0 {
                        continue;
                    }
                    let coef = b * k;
                    for &(h, u, w) in &self.terms[c.terms.0 as usize..c.terms.1 as usize] {
                        $hess[$at(h)] += coef * dot.at(u) * dot.at(w);
                    }
                    for &(h, u, w, u2, w2) in &self.pairs[c.pairs.0 as usize..c.pairs.1 as usize] {
                        $hess[$at(h)] += coef * (dot.at(u) * dot.at(w) + dot.at(u2) * dot.at(w2));
                    }
                }
            };
        }
        match <&mut [f64; SMALL_HESSIAN]>::try_from(&mut hess[..SMALL_HESSIAN]) {
            // Every `h < len <= 256` fits a `u8`: indexing a 256-array by one needs no bounds
            // check in the innermost loop.
            Ok(small) if len <= SMALL_HESSIAN => curvature!(small, |h: u32| h as u8 as usize),
            _ => curvature!(hess, |h: u32| h as usize),
        }
    }

    /// `(row, col)` of every Hessian entry [`Program::second_order`] forms (`row >= col`).
    pub fn hessian_pattern(&self) -> &[(u32, u32)] {
        &self.pattern
    }
}

/// What the tangent compiler reads about the values.
struct Ctx<'a> {
    n: usize,
    /// The slot of the constant 0 in `s`.
    zero: u32,
    cols: &'a [&'a [u32]],
    first: &'a [(u32, u32)],
    args: &'a [(Option<u32>, Option<u32>)],
    linear: &'a [Option<Vec<(u32, f64)>>],
}

/// Where values' tangents are after one compilation: `mat[v]` the entries of a materialised
/// value (one `dot` index per column), or `lin[v]` a linear combination of materialised values'
/// tangents with constant coefficients.
struct TangentState {
    mat: Vec<Option<Vec<u32>>>,
    lin: Vec<Option<BTreeMap<u32, f64>>>,
}

impl TangentState {
    fn entry(&self, ctx: &Ctx, x: u32, c: u32) -> Option<u32> {
        let j = ctx.cols[x as usize].binary_search(&c).ok()?;
        self.mat[x as usize].as_ref().map(|m| m[j])
    }
}

/// Compiles forward tangents into multiply-add records. A linear operation with constant
/// coefficients (`a + b`, `a - b`, `-a`, `c a`, `a / c`) is not swept at all: its tangent stays
/// a combination of earlier tangents, materialised only where an output or a nonlinear operation
/// reads it, and entries that are combinations of the inputs alone are constants (so the
/// `x + dt f` of an integrator costs one multiply-add per entry of `f`, and an entry `1` of
/// `x` nothing).
struct TangentCompiler {
    n_values: usize,
    coef_base: u32,
    coefs: Vec<f64>,
    coef_of: BTreeMap<u64, u32>,
    template: Vec<f64>,
    records: Vec<Fma>,
    n_runtime: u32,
}

impl TangentCompiler {
    /// The `s` slot of the coefficient `c`.
    fn coef(&mut self, c: f64) -> u32 {
        if let Some(&k) = self.coef_of.get(&c.to_bits()) {
            return k;
        }
        let k = self.coef_base + self.coefs.len() as u32;
        self.coefs.push(c);
        self.coef_of.insert(c.to_bits(), k);
        k
    }

    fn constant_entry(&mut self, c: f64) -> u32 {
        if c == 0.0 {
            DOT_ZERO
        } else if c == 1.0 {
            DOT_ONE
        } else {
            self.template.push(c);
            (self.template.len() - 1) as u32
        }
    }

    fn runtime(&mut self) -> u32 {
        let r = RUNTIME | self.n_runtime;
        self.n_runtime += 1;
        r
    }

    /// Tangents of the `relevant` values, materialising the `required` ones.
    fn compile(&mut self, ctx: &Ctx, relevant: &[bool], required: &[u32]) -> TangentState {
        let mut st = TangentState {
            mat: vec![None; self.n_values],
            lin: vec![None; self.n_values],
        };
        for k in 0..ctx.n {
            st.mat[k] = Some(vec![DOT_ONE]);
        }
        for v in ctx.n..self.n_values {
            if !relevant[v] || ctx.cols[v].is_empty() {
                continue;
            }
            if let Some(l) = &ctx.linear[v] {
                let mut m: BTreeMap<u32, f64> = BTreeMap::new();
                for &(x, c) in l {
                    match &st.lin[x as usize] {
                        Some(lx) => {
                            for (&a, &w) in lx {
                                *m.entry(a).or_insert(0.0) += c * w;
                            }
                        }
                        None => *m.entry(x).or_insert(0.0) += c,
                    }
                }
                st.lin[v] = Some(m);
                if st.lin[v].as_ref().is_some_and(|m| m.len() > MAX_TERMS) {
                    self.materialise(ctx, &mut st, v as u32);
                }
                continue;
            }
            let (a, b) = ctx.args[v];
            for x in [a, b].into_iter().flatten() {
                if st.mat[x as usize].is_none() && st.lin[x as usize].is_some() {
                    self.materialise(ctx, &mut st, x);
                }
            }
            let (pa, pb) = ctx.first[v];
            let mut entries = Vec::with_capacity(ctx.cols[v].len());
            for &c in ctx.cols[v] {
                let ea = a.and_then(|x| st.entry(ctx, x, c));
                let eb = b.and_then(|x| st.entry(ctx, x, c));
                let out = self.runtime();
                let (p, x, q, y) = match (ea, eb) {
                    (Some(x), Some(y)) => (pa, x, pb, y),
                    (Some(x), None) => (pa, x, ctx.zero, DOT_ZERO),
                    (None, Some(y)) => (pb, y, ctx.zero, DOT_ZERO),
                    (None, None) => (ctx.zero, DOT_ZERO, ctx.zero, DOT_ZERO),
                };
                self.records.push(Fma { out, p, a: x, q, b: y });
                entries.push(out);
            }
            st.mat[v] = Some(entries);
        }
        for &v in required {
            if st.mat[v as usize].is_none() && st.lin[v as usize].is_some() {
                self.materialise(ctx, &mut st, v);
            }
        }
        st
    }

    /// Turns the combination `lin[v]` into entries: constants where only inputs contribute,
    /// the entry itself where one tangent contributes with coefficient 1, else a chain of
    /// multiply-adds.
    fn materialise(&mut self, ctx: &Ctx, st: &mut TangentState, v: u32) {
        let Some(m) = st.lin[v as usize].take() else {
            return;
        };
        let mut entries = Vec::with_capacity(ctx.cols[v as usize].len());
        for &c in ctx.cols[v as usize] {
            let mut constant = 0.0;
            let mut terms: Vec<(f64, u32)> = Vec::new();
            for (&x, &w) in &m {
                if let Some(e) = st.entry(ctx, x, c) {
                    if e & RUNTIME == 0 {
                        constant += w * self.template[e as usize];
                    } else {
                        terms.push((w, e));
                    }
                }
            }
            let e = match terms.as_slice() {
                [] => self.constant_entry(constant),
                [(w, e)] if *w == 1.0 && constant == 0.0 => *e,
                _ => {
                    let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(terms.len() + 1);
                    if constant != 0.0 {
                        pairs.push((self.coef(constant), DOT_ONE));
                    }
                    for &(w, e) in &terms {
                        pairs.push((self.coef(w), e));
                    }
                    let out = self.runtime();
                    let (p, a) = pairs[0];
                    let (q, b) = pairs.get(1).copied().unwrap_or((ctx.zero, DOT_ZERO));
                    self.records.push(Fma { out, p, a, q, b });
                    let one = self.coef(1.0);
                    for &(q, b) in pairs.iter().skip(2) {
                        self.records.push(Fma {
                            out,
                            p: one,
                            a: out,
                            q,
                            b,
                        });
                    }
                    out
                }
            };
            entries.push(e);
        }
        st.mat[v as usize] = Some(entries);
    }
}

/// The values-only instruction list with `a +- c * b` (`c` a constant) fused into one instruction
/// where the product has no other use: the same operations in the same order, so the same bits.
fn fuse_scaled(instrs: Vec<Instr>, outputs: &[u32], is_const: impl Fn(u32) -> bool) -> Vec<Instr> {
    let mut uses: BTreeMap<u32, usize> = BTreeMap::new();
    for ins in &instrs {
        *uses.entry(ins.a).or_default() += 1;
        if matches!(ins.kind, Kind::Add | Kind::Sub | Kind::Mul | Kind::Binary(_)) {
            *uses.entry(ins.b).or_default() += 1;
        }
    }
    for &o in outputs {
        *uses.entry(o).or_default() += 1;
    }
    // Products of a variable and a constant: slot -> (variable, constant).
    let scaled: BTreeMap<u32, (u32, u32)> = instrs
        .iter()
        .filter(|i| i.kind == Kind::Mul && uses.get(&i.dst) == Some(&1))
        .filter_map(|i| match (is_const(i.a), is_const(i.b)) {
            (true, false) => Some((i.dst, (i.b, i.a))),
            (false, true) => Some((i.dst, (i.a, i.b))),
            _ => None,
        })
        .collect();
    let mut fused = std::collections::BTreeSet::new();
    let mut out: Vec<Instr> = instrs
        .iter()
        .map(|&ins| {
            let pick = match ins.kind {
                // x + c y (either order) and x - c y.
                Kind::Add => scaled
                    .get(&ins.b)
                    .map(|&p| (ins.a, ins.b, p))
                    .or_else(|| scaled.get(&ins.a).map(|&p| (ins.b, ins.a, p))),
                Kind::Sub => scaled.get(&ins.b).map(|&p| (ins.a, ins.b, p)),
                _ => None,
            };
            match pick {
                Some((x, product, (y, c))) if !fused.contains(&product) => {
                    fused.insert(product);
                    let kind = if ins.kind == Kind::Add {
                        Kind::AddScaled
                    } else {
                        Kind::SubScaled
                    };
                    Instr {
                        kind,
                        a: x,
                        b: y,
                        dst: ins.dst,
                        d: c,
                    }
                }
                _ => ins,
            }
        })
        .collect();
    out.retain(|i| !(i.kind == Kind::Mul && fused.contains(&i.dst)));
    out
}
