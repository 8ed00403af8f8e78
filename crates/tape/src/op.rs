//! The operations of a tape and their local derivatives.
//!
//! Every operation gives its value and its first and second partial derivatives with respect to
//! its arguments; the evaluators of [`crate::eval`] chain them (forward tangents and second-order
//! adjoints), so adding an operation is one row here.

use ddp_core::models::sin_cos;

/// An operation of one argument.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Unary {
    /// `-a`
    Neg,
    /// `sin a`
    Sin,
    /// `cos a`
    Cos,
    /// `tan a`
    Tan,
    /// `exp a`
    Exp,
    /// `ln a`
    Log,
    /// `sqrt a`
    Sqrt,
    /// `tanh a`
    Tanh,
    /// `|a|` (derivative `sign a`, 0 at 0)
    Abs,
    /// `asin a`
    Asin,
    /// `acos a`
    Acos,
    /// `atan a`
    Atan,
    /// `sinh a`
    Sinh,
    /// `cosh a`
    Cosh,
    /// `asinh a`
    Asinh,
    /// `acosh a`
    Acosh,
    /// `atanh a`
    Atanh,
    /// `1 / a`
    Inv,
    /// `sign a` (-1, 0 or 1; derivative 0)
    Sign,
    /// `floor a` (derivative 0)
    Floor,
    /// `ceil a` (derivative 0)
    Ceil,
    /// `1` where `a == 0`, else `0` (derivative 0)
    Not,
}

/// An operation of two arguments.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Binary {
    /// `a + b`
    Add,
    /// `a - b`
    Sub,
    /// `a * b`
    Mul,
    /// `a / b`
    Div,
    /// `a ^ b` with both arguments variable (a constant exponent is [`crate::Node::Powc`])
    Pow,
    /// `atan2(a, b)` (`a` is the ordinate)
    Atan2,
    /// `sqrt(a^2 + b^2)`
    Hypot,
    /// `min(a, b)` (derivative of `a` where `a <= b`, as CasADi's `fmin`)
    Min,
    /// `max(a, b)` (derivative of `a` where `a >= b`, as CasADi's `fmax`)
    Max,
    /// `1` where `a < b`, else `0`
    Lt,
    /// `1` where `a <= b`, else `0`
    Le,
    /// `1` where `a == b`, else `0`
    Eq,
    /// `1` where `a != b`, else `0`
    Ne,
    /// `1` where both are non-zero, else `0`
    And,
    /// `1` where either is non-zero, else `0`
    Or,
    /// `b` where `a != 0`, else `0` (CasADi's `if_else_zero`; `np.where` is built from it)
    IfElseZero,
}

const UNARY: &[(Unary, &str)] = &[
    (Unary::Neg, "neg"),
    (Unary::Sin, "sin"),
    (Unary::Cos, "cos"),
    (Unary::Tan, "tan"),
    (Unary::Exp, "exp"),
    (Unary::Log, "log"),
    (Unary::Sqrt, "sqrt"),
    (Unary::Tanh, "tanh"),
    (Unary::Abs, "abs"),
    (Unary::Asin, "asin"),
    (Unary::Acos, "acos"),
    (Unary::Atan, "atan"),
    (Unary::Sinh, "sinh"),
    (Unary::Cosh, "cosh"),
    (Unary::Asinh, "asinh"),
    (Unary::Acosh, "acosh"),
    (Unary::Atanh, "atanh"),
    (Unary::Inv, "inv"),
    (Unary::Sign, "sign"),
    (Unary::Floor, "floor"),
    (Unary::Ceil, "ceil"),
    (Unary::Not, "not"),
];

const BINARY: &[(Binary, &str)] = &[
    (Binary::Add, "add"),
    (Binary::Sub, "sub"),
    (Binary::Mul, "mul"),
    (Binary::Div, "div"),
    (Binary::Pow, "pow"),
    (Binary::Atan2, "atan2"),
    (Binary::Hypot, "hypot"),
    (Binary::Min, "min"),
    (Binary::Max, "max"),
    (Binary::Lt, "lt"),
    (Binary::Le, "le"),
    (Binary::Eq, "eq"),
    (Binary::Ne, "ne"),
    (Binary::And, "and"),
    (Binary::Or, "or"),
    (Binary::IfElseZero, "if_else_zero"),
];

fn b2f(b: bool) -> f64 {
    if b {
        1.0
    } else {
        0.0
    }
}

impl Unary {
    /// The name in the file format.
    pub fn name(self) -> &'static str {
        UNARY.iter().find(|(o, _)| *o == self).map_or("?", |(_, n)| n)
    }
    /// The operation named `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        UNARY.iter().find(|(_, n)| *n == name).map(|(o, _)| *o)
    }
    /// The names of every unary operation.
    pub fn names() -> impl Iterator<Item = &'static str> {
        UNARY.iter().map(|(_, n)| *n)
    }

    /// The value.
    pub fn value(self, a: f64) -> f64 {
        match self {
            Unary::Neg => -a,
            // The built-in models' sine and cosine, so that a traced model computes what the
            // built-in one does (and as fast: no rounding-mode switch per call).
            Unary::Sin => sin_cos(a).0,
            Unary::Cos => sin_cos(a).1,
            Unary::Tan => a.tan(),
            Unary::Exp => a.exp(),
            Unary::Log => a.ln(),
            Unary::Sqrt => a.sqrt(),
            Unary::Tanh => a.tanh(),
            Unary::Abs => a.abs(),
            Unary::Asin => a.asin(),
            Unary::Acos => a.acos(),
            Unary::Atan => a.atan(),
            Unary::Sinh => a.sinh(),
            Unary::Cosh => a.cosh(),
            Unary::Asinh => a.asinh(),
            Unary::Acosh => a.acosh(),
            Unary::Atanh => a.atanh(),
            Unary::Inv => 1.0 / a,
            Unary::Sign => {
                if a > 0.0 {
                    1.0
                } else if a < 0.0 {
                    -1.0
                } else {
                    a * 0.0
                }
            }
            Unary::Floor => a.floor(),
            Unary::Ceil => a.ceil(),
            Unary::Not => b2f(a == 0.0),
        }
    }

    /// `(v, dv/da, d^2v/da^2)` at `a`.
    pub fn partials(self, a: f64) -> (f64, f64, f64) {
        match self {
            Unary::Neg => (-a, -1.0, 0.0),
            Unary::Sin => {
                let (s, c) = sin_cos(a);
                (s, c, -s)
            }
            Unary::Cos => {
                let (s, c) = sin_cos(a);
                (c, -s, -c)
            }
            Unary::Tan => {
                let t = a.tan();
                let d = 1.0 + t * t;
                (t, d, 2.0 * t * d)
            }
            Unary::Exp => {
                let e = a.exp();
                (e, e, e)
            }
            Unary::Log => (a.ln(), 1.0 / a, -1.0 / (a * a)),
            Unary::Sqrt => {
                let s = a.sqrt();
                (s, 0.5 / s, -0.25 / (s * a))
            }
            Unary::Tanh => {
                let t = a.tanh();
                let d = 1.0 - t * t;
                (t, d, -2.0 * t * d)
            }
            Unary::Abs => (a.abs(), Unary::Sign.value(a), 0.0),
            Unary::Asin => {
                let r = 1.0 - a * a;
                (a.asin(), 1.0 / r.sqrt(), a / (r * r.sqrt()))
            }
            Unary::Acos => {
                let r = 1.0 - a * a;
                (a.acos(), -1.0 / r.sqrt(), -a / (r * r.sqrt()))
            }
            Unary::Atan => {
                let r = 1.0 + a * a;
                (a.atan(), 1.0 / r, -2.0 * a / (r * r))
            }
            Unary::Sinh => (a.sinh(), a.cosh(), a.sinh()),
            Unary::Cosh => (a.cosh(), a.sinh(), a.cosh()),
            Unary::Asinh => {
                let r = 1.0 + a * a;
                (a.asinh(), 1.0 / r.sqrt(), -a / (r * r.sqrt()))
            }
            Unary::Acosh => {
                let r = a * a - 1.0;
                (a.acosh(), 1.0 / r.sqrt(), -a / (r * r.sqrt()))
            }
            Unary::Atanh => {
                let r = 1.0 - a * a;
                (a.atanh(), 1.0 / r, 2.0 * a / (r * r))
            }
            Unary::Inv => {
                let i = 1.0 / a;
                (i, -i * i, 2.0 * i * i * i)
            }
            Unary::Sign | Unary::Floor | Unary::Ceil | Unary::Not => (self.value(a), 0.0, 0.0),
        }
    }
}

/// `a^p` for a constant `p` (integer powers by repeated multiplication, as CasADi's `sq` and
/// `constpow` with integer exponents agree with `powi` to rounding).
pub fn powc_value(a: f64, p: f64) -> f64 {
    if p == 2.0 {
        a * a
    } else if p.fract() == 0.0 && p.abs() <= 64.0 {
        a.powi(p as i32)
    } else {
        a.powf(p)
    }
}

/// `(a^p, p a^(p-1), p (p-1) a^(p-2))`; the coefficient is 0 (not `0 * inf`) where it vanishes.
pub fn powc_partials(a: f64, p: f64) -> (f64, f64, f64) {
    let v = powc_value(a, p);
    let d = if p == 0.0 { 0.0 } else { p * powc_value(a, p - 1.0) };
    let dd = if p == 0.0 || p == 1.0 {
        0.0
    } else {
        p * (p - 1.0) * powc_value(a, p - 2.0)
    };
    (v, d, dd)
}

/// Local derivatives of a binary operation: the value and the first and second partials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BinaryPartials {
    /// The value.
    pub v: f64,
    /// `dv/da`
    pub a: f64,
    /// `dv/db`
    pub b: f64,
    /// `d^2v/da^2`
    pub aa: f64,
    /// `d^2v/dadb`
    pub ab: f64,
    /// `d^2v/db^2`
    pub bb: f64,
}

impl Binary {
    /// The name in the file format.
    pub fn name(self) -> &'static str {
        BINARY.iter().find(|(o, _)| *o == self).map_or("?", |(_, n)| n)
    }
    /// The operation named `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        BINARY.iter().find(|(_, n)| *n == name).map(|(o, _)| *o)
    }
    /// The names of every binary operation.
    pub fn names() -> impl Iterator<Item = &'static str> {
        BINARY.iter().map(|(_, n)| *n)
    }

    /// Whether `op(a, b) == op(b, a)` (the builder orders the arguments of these, so that
    /// `x * y` and `y * x` share one node).
    pub fn commutes(self) -> bool {
        matches!(
            self,
            Binary::Add | Binary::Mul | Binary::Hypot | Binary::Eq | Binary::Ne | Binary::And | Binary::Or
        )
    }

    /// The value.
    pub fn value(self, a: f64, b: f64) -> f64 {
        match self {
            Binary::Add => a + b,
            Binary::Sub => a - b,
            Binary::Mul => a * b,
            Binary::Div => a / b,
            Binary::Pow => a.powf(b),
            Binary::Atan2 => a.atan2(b),
            Binary::Hypot => a.hypot(b),
            Binary::Min => {
                if a <= b {
                    a
                } else {
                    b
                }
            }
            Binary::Max => {
                if a >= b {
                    a
                } else {
                    b
                }
            }
            Binary::Lt => b2f(a < b),
            Binary::Le => b2f(a <= b),
            Binary::Eq => b2f(a == b),
            Binary::Ne => b2f(a != b),
            Binary::And => b2f(a != 0.0 && b != 0.0),
            Binary::Or => b2f(a != 0.0 || b != 0.0),
            Binary::IfElseZero => {
                if a != 0.0 {
                    b
                } else {
                    0.0
                }
            }
        }
    }

    /// The value and the partials at `(a, b)`.
    pub fn partials(self, a: f64, b: f64) -> BinaryPartials {
        let p = |v, da, db, aa, ab, bb| BinaryPartials {
            v,
            a: da,
            b: db,
            aa,
            ab,
            bb,
        };
        match self {
            Binary::Add => p(a + b, 1.0, 1.0, 0.0, 0.0, 0.0),
            Binary::Sub => p(a - b, 1.0, -1.0, 0.0, 0.0, 0.0),
            Binary::Mul => p(a * b, b, a, 0.0, 1.0, 0.0),
            Binary::Div => {
                let i = 1.0 / b;
                let v = a / b;
                p(v, i, -v * i, 0.0, -i * i, 2.0 * v * i * i)
            }
            Binary::Pow => {
                let v = a.powf(b);
                let l = a.ln();
                let am1 = a.powf(b - 1.0);
                p(
                    v,
                    b * am1,
                    v * l,
                    b * (b - 1.0) * a.powf(b - 2.0),
                    am1 * (1.0 + b * l),
                    v * l * l,
                )
            }
            Binary::Atan2 => {
                let r = a * a + b * b;
                let r2 = r * r;
                p(
                    a.atan2(b),
                    b / r,
                    -a / r,
                    -2.0 * a * b / r2,
                    (a * a - b * b) / r2,
                    2.0 * a * b / r2,
                )
            }
            Binary::Hypot => {
                let v = a.hypot(b);
                let v3 = v * v * v;
                p(v, a / v, b / v, b * b / v3, -a * b / v3, a * a / v3)
            }
            Binary::Min => {
                let first = a <= b;
                p(self.value(a, b), b2f(first), b2f(!first), 0.0, 0.0, 0.0)
            }
            Binary::Max => {
                let first = a >= b;
                p(self.value(a, b), b2f(first), b2f(!first), 0.0, 0.0, 0.0)
            }
            Binary::IfElseZero => p(self.value(a, b), 0.0, b2f(a != 0.0), 0.0, 0.0, 0.0),
            Binary::Lt | Binary::Le | Binary::Eq | Binary::Ne | Binary::And | Binary::Or => {
                p(self.value(a, b), 0.0, 0.0, 0.0, 0.0, 0.0)
            }
        }
    }
}
