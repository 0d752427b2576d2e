//! The frame the optimisation runs in: coordinates relative to the centre of
//! the bounding box, in units of a power of two near its size. Solvers then
//! see numbers of order one whatever the file's units or position (a mesh at
//! 1e9 metres from the origin keeps its digits in f32 on a GPU), and scaling
//! by a power of two is exact, so nothing but the coordinates' own rounding
//! separates a mesh from its scaled copy.

use crate::metric::mat3::Vec3;

/// Coordinates relative to a centre, in units of a power of two: the frame solvers run in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// The centre of the bounding box.
    pub center: Vec3,
    /// A power of two.
    pub scale: f64,
}

/// The smallest and largest coordinates of `points`.
pub fn bounding_box(points: &[Vec3]) -> (Vec3, Vec3) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// (lo + hi) / 2, halves first so that it cannot overflow; exact for a
/// coordinate that is the same everywhere.
pub fn box_center(lo: &Vec3, hi: &Vec3) -> Vec3 {
    std::array::from_fn(|k| lo[k] / 2.0 + hi[k] / 2.0)
}

impl Frame {
    /// The frame of `points`: bounding-box centre ((min + max) / 2, exact for
    /// a coordinate that is the same everywhere) and the power of two nearest
    /// the largest extent.
    pub fn of(points: &[Vec3]) -> Frame {
        let (lo, hi) = bounding_box(points);
        if points.is_empty() {
            return Frame {
                center: [0.0; 3],
                scale: 1.0,
            };
        }
        let center = box_center(&lo, &hi);
        let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let scale = if extent > 0.0 && extent.is_finite() {
            2f64.powi(extent.log2().round() as i32)
        } else {
            1.0
        };
        Frame { center, scale }
    }

    /// `p` in this frame: (p - center) / scale.
    pub fn to_local(&self, p: &Vec3) -> Vec3 {
        std::array::from_fn(|k| (p[k] - self.center[k]) / self.scale)
    }

    /// Back from this frame: center + q * scale.
    pub fn to_global(&self, q: &Vec3) -> Vec3 {
        std::array::from_fn(|k| self.center[k] + q[k] * self.scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scaled_and_shifted_copy_has_the_same_local_coordinates() {
        let pts: Vec<Vec3> = (0..50)
            .map(|i| [(i % 7) as f64 / 64.0, (i % 5) as f64 / 8.0, (i / 7) as f64 / 16.0])
            .collect();
        let a = Frame::of(&pts);
        let shifted: Vec<Vec3> = pts.iter().map(|p| p.map(|c| c + 1e9)).collect();
        let b = Frame::of(&shifted);
        assert_eq!(a.scale, b.scale);
        for (p, q) in pts.iter().zip(&shifted) {
            // the shifted copy is exact (multiples of 1/64 below 2^30), so is the local one
            assert_eq!(a.to_local(p), b.to_local(q));
        }
        let doubled: Vec<Vec3> = pts.iter().map(|p| p.map(|c| c * 1024.0)).collect();
        let c = Frame::of(&doubled);
        assert_eq!(c.scale, 1024.0 * a.scale);
        for (p, q) in pts.iter().zip(&doubled) {
            assert_eq!(a.to_local(p), c.to_local(q));
            assert_eq!(c.to_global(&c.to_local(q)), *q);
        }
        // a constant coordinate maps to exactly 0 and back to itself
        let flat: Vec<Vec3> = pts.iter().map(|p| [p[0], p[1], 0.1]).collect();
        let f = Frame::of(&flat);
        assert!(
            flat.iter()
                .all(|p| f.to_local(p)[2] == 0.0 && f.to_global(&f.to_local(p))[2] == 0.1)
        );
    }
}
