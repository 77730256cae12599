//! The scalar type of a BSDF evaluation ([`Real`]: f32 or f64) and a 3-vector of it ([`V3`]),
//! so that one piece of code evaluates every model in both precisions: f64 for reference
//! quadrature and the golden-value tests ([`crate::Bsdf::eval`]), f32 for the renderer
//! ([`crate::Bsdf::eval_f32`]; sixteen SIMD lanes per 512-bit register instead of eight, and
//! f32 division and square root are far cheaper than f64).
//!
//! Invariant: [`V3`]'s operations are glam's `DVec3`/`Vec3` expressions written out in the same
//! order (`dot` adds x, y, then z; `normalize` multiplies by 1/√(v·v)), so the f64 evaluation
//! has the bits of the glam expressions, and each operation rounds once per component,
//! the same on every instruction set (Rust forms no fused multiply-add).

use glam::{DVec3, Vec3};
use num_traits::Float;
use std::fmt::Debug;
use std::ops::{Add, Div, Mul};

/// f32 or f64, with exact conversions from the f32 parameters the models store.
pub trait Real: Float + Debug {
    /// The f64 constant `x` rounded to this type.
    fn c(x: f64) -> Self;
    /// An f32 parameter (exact in both types).
    fn of(x: f32) -> Self;
}

/// `Real` for each type: both conversions are `as` casts (the identity where the types agree).
macro_rules! real {
    ($($t:ty),*) => {$(
        impl Real for $t {
            #[inline(always)]
            fn c(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn of(x: f32) -> Self {
                x as $t
            }
        }
    )*};
}

real!(f32, f64);

/// A 3-vector of [`Real`]: a direction in the shading frame or an RGB value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3<T> {
    pub x: T,
    pub y: T,
    pub z: T,
}

impl<T: Real> V3<T> {
    #[inline(always)]
    pub fn new(x: T, y: T, z: T) -> Self {
        Self { x, y, z }
    }

    #[inline(always)]
    pub fn splat(a: T) -> Self {
        Self::new(a, a, a)
    }

    #[inline(always)]
    pub fn zero() -> Self {
        Self::splat(T::zero())
    }

    /// An RGB parameter as stored (f32), exactly.
    #[inline(always)]
    pub fn rgb(c: [f32; 3]) -> Self {
        Self::new(T::of(c[0]), T::of(c[1]), T::of(c[2]))
    }

    /// x·x' + y·y' + z·z', added left to right (glam's order).
    #[inline(always)]
    pub fn dot(self, o: Self) -> T {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// 1/√(v·v) (glam's `length_recip`).
    #[inline(always)]
    pub fn length_recip(self) -> T {
        T::one() / self.dot(self).sqrt()
    }

    /// v·(1/√(v·v)) (glam's `normalize`, without its debug assertion).
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self * self.length_recip()
    }

    #[inline(always)]
    pub fn map(self, f: impl Fn(T) -> T) -> Self {
        Self::new(f(self.x), f(self.y), f(self.z))
    }
}

impl<T: Real> Add for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl<T: Real> Mul for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}

impl<T: Real> Mul<T> for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: T) -> Self {
        Self::new(self.x * s, self.y * s, self.z * s)
    }
}

impl<T: Real> Div<T> for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn div(self, s: T) -> Self {
        Self::new(self.x / s, self.y / s, self.z / s)
    }
}

impl From<DVec3> for V3<f64> {
    #[inline(always)]
    fn from(v: DVec3) -> Self {
        Self::new(v.x, v.y, v.z)
    }
}

impl From<V3<f64>> for DVec3 {
    #[inline(always)]
    fn from(v: V3<f64>) -> Self {
        DVec3::new(v.x, v.y, v.z)
    }
}

impl From<Vec3> for V3<f32> {
    #[inline(always)]
    fn from(v: Vec3) -> Self {
        Self::new(v.x, v.y, v.z)
    }
}

impl From<V3<f32>> for Vec3 {
    #[inline(always)]
    fn from(v: V3<f32>) -> Self {
        Vec3::new(v.x, v.y, v.z)
    }
}
