//! A backend over a plain function of R^3m (tests only): the solvers' own
//! code, written over `Backend`, run on functions with known minimisers.
//! Positions are all free; the Hessian and sweep operations are refused.

use crate::backend::{Backend, Coef, EvalSlots, N_SLOTS, Points, Slot, Vector, guard_passes};
use crate::error::{Error, Result};
use crate::metric::mat3::Vec3;

/// F and its gradient at a point, `None` where infeasible.
pub type Function = dyn Fn(&[f64]) -> Option<(f64, Vec<f64>)>;

pub struct FunctionBackend<'f> {
    f: &'f Function,
    x: Vec<Vec3>,
    trial: Vec<Vec3>,
    vectors: Vec<Vec<Vec3>>,
    slots: [f64; N_SLOTS],
    /// Every point accepted as current, in order.
    pub accepted: Vec<Vec<f64>>,
}

impl<'f> FunctionBackend<'f> {
    pub fn new(f: &'f Function, x: &[f64]) -> Self {
        assert_eq!(x.len() % 3, 0, "the dimension must be a multiple of 3");
        let x: Vec<Vec3> = x.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        FunctionBackend {
            f,
            trial: x.clone(),
            x,
            vectors: Vec::new(),
            slots: [0.0; N_SLOTS],
            accepted: Vec::new(),
        }
    }

    pub fn point(&self) -> Vec<f64> {
        self.x.iter().flatten().copied().collect()
    }

    fn unsupported<T>(&self, what: &str) -> Result<T> {
        Err(Error::Unsupported(format!("{what} on a function backend")))
    }
}

impl Backend for FunctionBackend<'_> {
    fn describe(&self) -> String {
        "function (f64)".into()
    }
    fn num_free(&self) -> usize {
        self.x.len()
    }
    fn num_colors(&self) -> usize {
        0
    }
    fn vector(&mut self) -> Result<Vector> {
        self.vectors.push(vec![[0.0; 3]; self.x.len()]);
        Ok(Vector(self.vectors.len() as u32 - 1))
    }
    fn read_vector(&mut self, v: Vector) -> Result<Vec<Vec3>> {
        Ok(self.vectors[v.0 as usize].clone())
    }
    fn write_vector(&mut self, v: Vector, data: &[Vec3]) -> Result<()> {
        self.vectors[v.0 as usize].copy_from_slice(data);
        Ok(())
    }
    fn download(&mut self) -> Result<Vec<Vec3>> {
        Ok(self.x.clone())
    }
    fn evaluate(&mut self, at: Points, out: EvalSlots, gradient: Option<Vector>) -> Result<()> {
        let x = match at {
            Points::Current => &self.x,
            Points::Trial => &self.trial,
        };
        let flat: Vec<f64> = x.iter().flatten().copied().collect();
        let (f, bad) = match (self.f)(&flat) {
            Some((f, g)) => {
                if let Some(v) = gradient {
                    for (d, c) in self.vectors[v.0 as usize].iter_mut().zip(g.chunks(3)) {
                        *d = [c[0], c[1], c[2]];
                    }
                }
                (f, 0.0)
            }
            None => (f64::NAN, 1.0),
        };
        self.slots[out.value.0 as usize] = f;
        self.slots[out.infeasible.0 as usize] = bad;
        Ok(())
    }
    fn trial(&mut self, alpha: Coef, d: Vector) -> Result<()> {
        let a = alpha.eval(&self.slots);
        for ((t, x), d) in self.trial.iter_mut().zip(&self.x).zip(&self.vectors[d.0 as usize]) {
            *t = std::array::from_fn(|i| x[i] + a * d[i]);
        }
        Ok(())
    }
    fn accept_trial(&mut self) -> Result<()> {
        self.x.copy_from_slice(&self.trial);
        self.accepted.push(self.point());
        Ok(())
    }
    fn bcd_color(&mut self, _color: usize) -> Result<()> {
        self.unsupported("bcd")
    }
    fn max_move(&mut self, _out: Slot) -> Result<()> {
        self.unsupported("bcd")
    }
    fn reference_positions(&mut self, _iters: usize) -> Result<Vec<Vec3>> {
        self.unsupported("reference positions")
    }
    fn prepare_hessian(&mut self) -> Result<usize> {
        self.unsupported("a Hessian")
    }
    fn assemble(&mut self, _g: Vector) -> Result<()> {
        self.unsupported("a Hessian")
    }
    fn hess_mul(&mut self, _x: Vector, _y: Vector) -> Result<()> {
        self.unsupported("a Hessian")
    }
    fn factor_precond(&mut self) -> Result<()> {
        self.unsupported("a preconditioner")
    }
    fn precond(&mut self, _x: Vector, _y: Vector) -> Result<()> {
        self.unsupported("a preconditioner")
    }
    fn dot(&mut self, a: Vector, b: Vector, sum: Slot, max: Option<Slot>) -> Result<()> {
        let (a, b) = (&self.vectors[a.0 as usize], &self.vectors[b.0 as usize]);
        let s = a.iter().flatten().zip(b.iter().flatten()).map(|(x, y)| x * y).sum();
        let m = b
            .iter()
            .map(|v| v.iter().map(|c| c * c).sum::<f64>())
            .fold(0.0, f64::max);
        self.slots[sum.0 as usize] = s;
        if let Some(slot) = max {
            self.slots[slot.0 as usize] = m;
        }
        Ok(())
    }
    fn axpby(&mut self, a: Coef, x: Vector, b: Coef, y: Vector, guard: Option<Slot>) -> Result<()> {
        if !guard_passes(&self.slots, guard) {
            return Ok(());
        }
        let (a, b) = (a.eval(&self.slots), b.eval(&self.slots));
        let xs = self.vectors[x.0 as usize].clone();
        for (yv, xv) in self.vectors[y.0 as usize].iter_mut().zip(&xs) {
            for i in 0..3 {
                // b = 0 overwrites without reading y (which may hold NaN)
                yv[i] = if b == 0.0 { a * xv[i] } else { a * xv[i] + b * yv[i] };
            }
        }
        Ok(())
    }
    fn set_slot(&mut self, dst: Slot, value: Coef, guard: Option<Slot>) -> Result<()> {
        if guard_passes(&self.slots, guard) {
            self.slots[dst.0 as usize] = value.eval(&self.slots);
        }
        Ok(())
    }
    fn flush(&mut self) -> Result<[f64; N_SLOTS]> {
        Ok(self.slots)
    }
    fn bytes(&self) -> usize {
        24 * (2 * self.x.len() + self.vectors.len() * self.x.len())
    }
}
