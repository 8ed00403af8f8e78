//! Linear time-invariant dynamics `x+ = A x + B u + c`: the LQ reference problems and a building
//! block for user models.

use crate::error::{check_finite, Result};
use crate::{Dynamics, Matrix, Vector};

/// `x_{k+1} = A x_k + B u_k + c`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearDynamics<const NX: usize, const NU: usize> {
    a: Matrix<NX, NX>,
    b: Matrix<NX, NU>,
    c: Vector<NX>,
}

impl<const NX: usize, const NU: usize> LinearDynamics<NX, NU> {
    /// Rejects non-finite entries, naming `a`, `b` or `c`.
    pub fn new(a: Matrix<NX, NX>, b: Matrix<NX, NU>, c: Vector<NX>) -> Result<Self> {
        check_finite("a", a.iter())?;
        check_finite("b", b.iter())?;
        check_finite("c", c.iter())?;
        Ok(Self { a, b, c })
    }
    /// `A`
    pub fn a(&self) -> &Matrix<NX, NX> {
        &self.a
    }
    /// `B`
    pub fn b(&self) -> &Matrix<NX, NU> {
        &self.b
    }
}

impl<const NX: usize, const NU: usize> Dynamics<NX, NU> for LinearDynamics<NX, NU> {
    fn step(&self, x: &Vector<NX>, u: &Vector<NU>) -> Vector<NX> {
        self.a * x + self.b * u + self.c
    }
    fn jacobians(&self, _x: &Vector<NX>, _u: &Vector<NU>, fx: &mut Matrix<NX, NX>, fu: &mut Matrix<NX, NU>) {
        *fx = self.a;
        *fu = self.b;
    }
    fn has_second_order(&self) -> bool {
        true
    }
}
