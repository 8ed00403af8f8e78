//! The tape file: one JSON document per model.
//!
//! ```text
//! {
//!   "format": "ddpkit-tape",        always this string
//!   "version": 1,                   this file format's version
//!   "kind": "dynamics",             "dynamics" | "cost" | "terminal_cost" | "constraint"
//!   "nx": 4,                        state size
//!   "nu": 1,                        control size (absent or null for "terminal_cost", and for
//!                                   a "constraint" of x alone)
//!   "nodes": [                      evaluation order; arguments are indices of earlier nodes
//!     ["input", 0],                 z_k, z = (x, u) (or x)
//!     ["const", 9.81],              a finite constant
//!     ["sin", 0],                   unary: neg sin cos tan exp log sqrt tanh abs asin acos atan
//!                                   sinh cosh asinh acosh atanh inv sign floor ceil not
//!     ["mul", 1, 2],                binary: add sub mul div pow atan2 hypot min max lt le eq ne
//!                                   and or if_else_zero
//!     ["powc", 3, 2.0]              a^p for a constant p
//!   ],
//!   "outputs": [4, 5, 6, 7],        the output nodes: nx for dynamics, 1 for costs, >= 1 rows
//!                                   for constraints
//!   "source": "..."                 optional free text (where the model came from)
//! }
//! ```
//!
//! Loading checks everything (format, version, kind, sizes, every node's operation, argument
//! references and constants, the outputs) and reports the first problem as an error naming the
//! field, e.g. `nodes[12] is invalid: argument 40 does not refer to an earlier node`. Nothing in
//! a file, however malformed, makes the loader panic. Loaded tapes are rebuilt (common
//! subexpressions shared, constants folded), so a saved file evaluates exactly as the model it
//! came from.

use std::path::Path;

use ddp_core::{Error, Result};
use serde_json::{json, Value};

use crate::models::{TapeConstraint, TapeCost, TapeDynamics, TapeTerminal};
use crate::op::{Binary, Unary};
use crate::tape::{Node, Tape};

/// The `format` string.
pub const FORMAT: &str = "ddpkit-tape";
/// The file format version this crate writes and reads.
pub const VERSION: u64 = 1;

/// A tape-backed model of any kind, as a file holds it.
#[derive(Debug, Clone, PartialEq)]
pub enum TapeModel {
    /// `x+ = F(x, u)`
    Dynamics(TapeDynamics),
    /// `l(x, u)`
    Cost(TapeCost),
    /// `l_N(x)`
    Terminal(TapeTerminal),
    /// `g(x, u) <= 0`
    Constraint(TapeConstraint),
}

impl TapeModel {
    /// `"dynamics"`, `"cost"`, `"terminal_cost"` or `"constraint"`.
    pub fn kind(&self) -> &'static str {
        match self {
            TapeModel::Dynamics(_) => "dynamics",
            TapeModel::Cost(_) => "cost",
            TapeModel::Terminal(_) => "terminal_cost",
            TapeModel::Constraint(_) => "constraint",
        }
    }

    /// The tape.
    pub fn tape(&self) -> &Tape {
        match self {
            TapeModel::Dynamics(m) => m.tape(),
            TapeModel::Cost(m) => m.tape(),
            TapeModel::Terminal(m) => m.tape(),
            TapeModel::Constraint(m) => m.tape(),
        }
    }

    /// `(nx, nu)`; `nu` is `None` for a terminal cost and a constraint of `x` alone.
    pub fn dims(&self) -> (usize, Option<usize>) {
        match self {
            TapeModel::Dynamics(m) => (m.dims().0, Some(m.dims().1)),
            TapeModel::Cost(m) => (m.dims().0, Some(m.dims().1)),
            TapeModel::Terminal(m) => (m.nx(), None),
            TapeModel::Constraint(m) => m.dims(),
        }
    }

    /// Builds the model of `kind` from a tape (the checks of each model's `new`).
    pub fn new(kind: &str, tape: Tape, nx: usize, nu: Option<usize>) -> Result<Self> {
        let need_nu = |nu: Option<usize>| nu.ok_or_else(|| Error::invalid("nu", format!("a {kind} needs nu")));
        Ok(match kind {
            "dynamics" => TapeModel::Dynamics(TapeDynamics::new(tape, nx, need_nu(nu)?)?),
            "cost" => TapeModel::Cost(TapeCost::new(tape, nx, need_nu(nu)?)?),
            "terminal_cost" => {
                if nu.is_some() {
                    return Err(Error::invalid(
                        "nu",
                        "a terminal_cost takes no control (nu must be null)",
                    ));
                }
                TapeModel::Terminal(TapeTerminal::new(tape, nx)?)
            }
            "constraint" => TapeModel::Constraint(TapeConstraint::new(tape, nx, nu)?),
            other => {
                return Err(Error::invalid(
                    "kind",
                    format!("must be 'dynamics', 'cost', 'terminal_cost' or 'constraint', got '{other}'"),
                ))
            }
        })
    }

    /// The JSON document (see the [module docs](self)); `source` is stored as given.
    pub fn to_json(&self, source: Option<&str>) -> String {
        let tape = self.tape();
        let nodes: Vec<Value> = tape
            .nodes()
            .iter()
            .map(|n| match *n {
                Node::Input(k) => json!(["input", k]),
                Node::Const(v) => json!(["const", v]),
                Node::Unary(op, a) => json!([op.name(), a]),
                Node::Powc(a, p) => json!(["powc", a, p]),
                Node::Binary(op, a, b) => json!([op.name(), a, b]),
            })
            .collect();
        let (nx, nu) = self.dims();
        let mut doc = json!({
            "format": FORMAT,
            "version": VERSION,
            "kind": self.kind(),
            "nx": nx,
            "nu": nu,
            "nodes": nodes,
            "outputs": tape.outputs(),
        });
        if let (Some(s), Some(obj)) = (source, doc.as_object_mut()) {
            obj.insert("source".into(), json!(s));
        }
        doc.to_string()
    }

    /// Parses and checks a JSON document (see the [module docs](self)).
    pub fn from_json(text: &str) -> Result<Self> {
        let doc: Value = serde_json::from_str(text).map_err(|e| Error::invalid("tape", format!("not JSON: {e}")))?;
        let obj = doc
            .as_object()
            .ok_or_else(|| Error::invalid("tape", "must be a JSON object"))?;
        match obj.get("format").and_then(Value::as_str) {
            Some(FORMAT) => {}
            other => {
                return Err(Error::invalid(
                    "format",
                    format!(
                        "must be \"{FORMAT}\", got {}",
                        other.map_or("nothing".into(), |s| format!("\"{s}\""))
                    ),
                ))
            }
        }
        match obj.get("version").and_then(Value::as_u64) {
            Some(VERSION) => {}
            other => {
                return Err(Error::invalid(
                    "version",
                    format!(
                        "this ddpkit reads version {VERSION}, got {}",
                        other.map_or("nothing".into(), |v| v.to_string())
                    ),
                ))
            }
        }
        let kind = obj
            .get("kind")
            .and_then(Value::as_str)
            .ok_or_else(|| Error::invalid("kind", "missing or not a string"))?;
        let size = |f: &str| -> Result<Option<usize>> {
            match obj.get(f) {
                None | Some(Value::Null) => Ok(None),
                Some(v) => v
                    .as_u64()
                    .and_then(|n| usize::try_from(n).ok())
                    .map(Some)
                    .ok_or_else(|| Error::invalid(f, format!("must be a non-negative integer, got {v}"))),
            }
        };
        let nx = size("nx")?.ok_or_else(|| Error::invalid("nx", "missing"))?;
        let nu = size("nu")?;
        let n_inputs = nx
            .checked_add(nu.unwrap_or(0))
            .ok_or_else(|| Error::invalid("nu", "too large"))?;
        let raw = obj
            .get("nodes")
            .and_then(Value::as_array)
            .ok_or_else(|| Error::invalid("nodes", "missing or not a list"))?;
        if raw.len() > crate::tape::MAX_NODES {
            return Err(Error::invalid(
                "nodes",
                format!("{} nodes exceed the limit of {}", raw.len(), crate::tape::MAX_NODES),
            ));
        }
        let nodes = raw
            .iter()
            .enumerate()
            .map(|(i, v)| parse_node(v, &format!("nodes[{i}]")))
            .collect::<Result<Vec<_>>>()?;
        let outputs = obj
            .get("outputs")
            .and_then(Value::as_array)
            .ok_or_else(|| Error::invalid("outputs", "missing or not a list"))?
            .iter()
            .enumerate()
            .map(|(j, v)| index(v, &format!("outputs[{j}]")))
            .collect::<Result<Vec<_>>>()?;
        let tape = Tape::from_nodes(n_inputs, &nodes, &outputs, "tape").map_err(|e| strip(e, "tape."))?;
        Self::new(kind, tape, nx, nu)
    }

    /// Writes the JSON document to `path` atomically (whole or not at all).
    pub fn save(&self, path: impl AsRef<Path>, source: Option<&str>) -> Result<()> {
        let path = path.as_ref();
        ddpkit_util::fs::write_atomic(path, self.to_json(source))
            .map_err(|e| Error::invalid("path", format!("cannot write {}: {e}", path.display())))
    }

    /// Reads and checks a file written by [`TapeModel::save`] (or by `ddpkit` in Python).
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::invalid("path", format!("cannot read {}: {e}", path.display())))?;
        Self::from_json(&text)
    }
}

fn strip(e: Error, prefix: &str) -> Error {
    match e {
        Error::Invalid { field, reason } => Error::Invalid {
            field: field.strip_prefix(prefix).map_or(field.clone(), str::to_string),
            reason,
        },
        other => other,
    }
}

fn index(v: &Value, field: &str) -> Result<u32> {
    v.as_u64()
        .and_then(|n| u32::try_from(n).ok())
        .ok_or_else(|| Error::invalid(field, format!("must be a node index, got {v}")))
}

fn number(v: &Value, field: &str) -> Result<f64> {
    let x = v
        .as_f64()
        .ok_or_else(|| Error::invalid(field, format!("must be a number, got {v}")))?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(Error::invalid(field, format!("must be finite, got {x}")))
    }
}

/// One node `[op, args...]`.
pub(crate) fn parse_node(v: &Value, field: &str) -> Result<Node> {
    let items = v
        .as_array()
        .ok_or_else(|| Error::invalid(field, format!("must be a list [op, args...], got {v}")))?;
    let op = items
        .first()
        .and_then(Value::as_str)
        .ok_or_else(|| Error::invalid(field, "must start with the operation's name"))?;
    let want = |n: usize| -> Result<()> {
        if items.len() == n + 1 {
            Ok(())
        } else {
            Err(Error::invalid(
                field,
                format!("'{op}' takes {n} argument(s), got {}", items.len() - 1),
            ))
        }
    };
    let arg = |i: usize| index(&items[i], &format!("{field}[{i}]"));
    Ok(match op {
        "input" => {
            want(1)?;
            Node::Input(arg(1)?)
        }
        "const" => {
            want(1)?;
            Node::Const(number(&items[1], &format!("{field}[1]"))?)
        }
        "powc" => {
            want(2)?;
            Node::Powc(arg(1)?, number(&items[2], &format!("{field}[2]"))?)
        }
        name => {
            if let Some(u) = Unary::from_name(name) {
                want(1)?;
                Node::Unary(u, arg(1)?)
            } else if let Some(b) = Binary::from_name(name) {
                want(2)?;
                Node::Binary(b, arg(1)?, arg(2)?)
            } else {
                return Err(Error::invalid(field, format!("unknown operation '{name}'")));
            }
        }
    })
}
