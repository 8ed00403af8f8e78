//! Linear time-invariant dynamics `x+ = A x + B u + c`: the LQ reference problems and a building
//! block for user models, at any size.

use crate::dims::{check_size, Alloc, DefaultAllocator, Dim, MatrixN, VectorN, MAX_CONTROLS, MAX_STATES};
use crate::error::{check_finite, Error, Result};
use crate::kernels::mul_vec_add;
use crate::Dynamics;

/// `x_{k+1} = A x_k + B u_k + c`.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearDynamics<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    a: MatrixN<NX, NX>,
    b: MatrixN<NX, NU>,
    c: VectorN<NX>,
}

impl<NX: Dim, NU: Dim> LinearDynamics<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Rejects non-finite entries and shapes that disagree, naming `a`, `b` or `c`.
    pub fn new(a: MatrixN<NX, NX>, b: MatrixN<NX, NU>, c: VectorN<NX>) -> Result<Self> {
        let nx = a.nrows();
        if a.ncols() != nx {
            return Err(Error::Shape {
                field: "a".into(),
                got: format!("({}, {})", nx, a.ncols()),
                expected: "a square matrix".into(),
            });
        }
        check_size("a.shape[0]", nx, NX::try_to_usize(), MAX_STATES)?;
        check_size("b.shape[1]", b.ncols(), NU::try_to_usize(), MAX_CONTROLS)?;
        if b.nrows() != nx {
            return Err(Error::Shape {
                field: "b".into(),
                got: format!("({}, {})", b.nrows(), b.ncols()),
                expected: format!("({nx}, nu) (as many rows as a)"),
            });
        }
        if c.len() != nx {
            return Err(Error::Shape {
                field: "c".into(),
                got: format!("({},)", c.len()),
                expected: format!("({nx},)"),
            });
        }
        check_finite("a", a.iter())?;
        check_finite("b", b.iter())?;
        check_finite("c", c.iter())?;
        Ok(Self { a, b, c })
    }
    /// `A`
    pub fn a(&self) -> &MatrixN<NX, NX> {
        &self.a
    }
    /// `B`
    pub fn b(&self) -> &MatrixN<NX, NU> {
        &self.b
    }
}

impl<NX: Dim, NU: Dim> Dynamics<NX, NU> for LinearDynamics<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn step(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> VectorN<NX> {
        let mut out = self.c.clone();
        self.step_into(x, u, &mut out);
        out
    }
    fn step_into(&self, x: &VectorN<NX>, u: &VectorN<NU>, out: &mut VectorN<NX>) {
        // A x + B u + c, without temporaries.
        mul_vec_add(out, Some(&self.c), &self.b, u);
        out.gemv(1.0, &self.a, x, 1.0);
    }
    fn jacobians(&self, _x: &VectorN<NX>, _u: &VectorN<NU>, fx: &mut MatrixN<NX, NX>, fu: &mut MatrixN<NX, NU>) {
        fx.copy_from(&self.a);
        fu.copy_from(&self.b);
    }
    fn has_second_order(&self) -> bool {
        true
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (Some(self.a.nrows()), Some(self.b.ncols()))
    }
}
