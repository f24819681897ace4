//! Many legs of one model at once, as a simulator's environments times legs give them: drag,
//! lift and hip torque only, written into the caller's slices, in `f64` or `f32`.
//!
//! [`LegKernel::forces`] evaluates what [`ForceModel::predict_moving`] gives for each leg
//! (equal to rounding: to about 1e-15 of the largest element's force in `f64`), without
//! building a [`super::Prediction`] per leg, [`LANES`] legs at a time in the processor's vector
//! registers, in the batch's type. The legs that cannot reach the medium are zero without a
//! sum; the others are packed into the lanes. The Terzaghi models (one medium, or a fitting
//! width per leg) evaluate their equations in the lanes; RFT of a profile (a C-leg) with the
//! fitted coefficients sums each lane's leg's elements in order; RFT of a flat plate, or with a
//! law in depth, integrates each leg's elements sixteen at once. Every other model (sinkage,
//! bodies, RFT's measured grid or speed law) goes through [`ForceModel::predict_moving`] leg
//! by leg.

mod vmath;

use super::rft::{N_CM3_TO_N_M3, RftParts};
use super::terzaghi::MediumConstants;
use super::{FittingWidth, ForceModel, HipMotion, ModelError, TerzaghiModel, wrap_beta_rad};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A number a batch is given in: `f64` or `f32`.
pub trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Send
    + Sync
    + 'static
{
    /// Zero.
    const ZERO: Self;
    /// The largest speed scale (m/s, `|omega| reach + |v_hip|`) whose squares do not overflow.
    const MAX_SPEED_SCALE: f64;
    /// The smallest non-zero speed scale whose squares (after cancellation) do not underflow.
    const MIN_SPEED_SCALE: f64;
    /// `x` rounded to this type.
    fn of(x: f64) -> Self;
    /// As `f64`.
    fn to_f64(self) -> f64;
    /// `1 / sqrt(self)` where positive, else 0.
    fn inv_sqrt_or_zero(self) -> Self;
    /// The profile's elements in this type.
    fn elements(e: &Elements) -> &Soa<Self>;
    /// `self a + b`, rounded once (only where the processor fuses it: else libm's is slow).
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// The largest `|x|` of [`Real::exp_lanes`].
    const EXP_REACH: f64;
    /// Whether this is a number (not infinite, not NaN).
    fn finite(self) -> bool;
    /// `sin` and `cos` of every lane in this type (`|x| < 2^16`; the kernel's own, within two
    /// units in the last place).
    fn sin_cos_lanes(x: &[Self; LANES]) -> ([Self; LANES], [Self; LANES]);
    /// `exp` of every lane in this type (`|x| <=` [`Real::EXP_REACH`]).
    fn exp_lanes(x: &[Self; LANES]) -> [Self; LANES];
    /// Stores the lanes of `src` that `bits` marks, in order, at the front of `dst` (the rest
    /// of `dst` is overwritten).
    ///
    /// # Safety
    /// The processor has AVX-512F.
    #[cfg(target_arch = "x86_64")]
    unsafe fn compress_avx512(bits: u16, src: &[Self; LANES], dst: &mut [Self; LANES]);
    /// The lanes that `bits` marks from `src`'s front, in order; the others zero (the inverse
    /// of [`Real::compress_avx512`]).
    ///
    /// # Safety
    /// The processor has AVX-512F.
    #[cfg(target_arch = "x86_64")]
    unsafe fn expand_avx512(bits: u16, src: &[Self; LANES]) -> [Self; LANES];
    /// [`Real::inv_sqrt_or_zero`] of every lane, by the processor's reciprocal square root
    /// estimate and Newton's steps to the type's precision (a few units in the last place).
    ///
    /// # Safety
    /// The processor has AVX-512F.
    #[cfg(target_arch = "x86_64")]
    unsafe fn inv_sqrt_avx512(v2: &[Self; LANES]) -> [Self; LANES];
}

macro_rules! real {
    ($t:ty, $max:expr, $min:expr, $field:ident, $inv:ident, $sin_cos:path, $exp:path, $reach:expr, $compress:ident, $expand:ident) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const MAX_SPEED_SCALE: f64 = $max;
            const MIN_SPEED_SCALE: f64 = $min;
            const EXP_REACH: f64 = $reach;
            #[inline(always)]
            fn finite(self) -> bool {
                self.is_finite()
            }
            #[inline(always)]
            fn sin_cos_lanes(x: &[Self; LANES]) -> ([Self; LANES], [Self; LANES]) {
                $sin_cos(x)
            }
            #[inline(always)]
            fn exp_lanes(x: &[Self; LANES]) -> [Self; LANES] {
                $exp(x)
            }
            #[cfg(target_arch = "x86_64")]
            #[inline(always)]
            unsafe fn compress_avx512(bits: u16, src: &[Self; LANES], dst: &mut [Self; LANES]) {
                // SAFETY: the caller's promise.
                unsafe { $compress(bits, src, dst) }
            }
            #[cfg(target_arch = "x86_64")]
            #[inline(always)]
            unsafe fn expand_avx512(bits: u16, src: &[Self; LANES]) -> [Self; LANES] {
                // SAFETY: the caller's promise.
                unsafe { $expand(bits, src) }
            }
            #[inline(always)]
            fn of(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn inv_sqrt_or_zero(self) -> Self {
                if self > 0.0 { 1.0 / self.sqrt() } else { 0.0 }
            }
            #[inline(always)]
            fn elements(e: &Elements) -> &Soa<Self> {
                &e.$field
            }
            #[inline(always)]
            fn mul_add(self, a: Self, b: Self) -> Self {
                <$t>::mul_add(self, a, b)
            }
            #[cfg(target_arch = "x86_64")]
            #[inline(always)]
            unsafe fn inv_sqrt_avx512(v2: &[Self; LANES]) -> [Self; LANES] {
                // SAFETY: the caller's promise.
                unsafe { $inv(v2) }
            }
        }
    };
}
real!(
    f64,
    1e100,
    1e-100,
    f64s,
    inv_sqrt_f64_avx512,
    vmath::sin_cos,
    vmath::exp,
    700.0,
    compress_f64_avx512,
    expand_f64_avx512
);
real!(
    f32,
    1e15,
    1e-8,
    f32s,
    inv_sqrt_f32_avx512,
    vmath::sin_cos_f32,
    vmath::exp_f32,
    80.0,
    compress_f32_avx512,
    expand_f32_avx512
);

/// [`Real::compress_avx512`] of `f64`: two registers of eight.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn compress_f64_avx512(bits: u16, src: &[f64; LANES], dst: &mut [f64; LANES]) {
    use std::arch::x86_64::*;
    let (lo, hi) = (bits as u8, (bits >> 8) as u8);
    let mid = lo.count_ones() as usize;
    // SAFETY: 8 lanes read from each half of `src`; 8 stored from 0 and from `mid <= 8`: each
    // store ends within `dst`. Compressed in registers and stored whole (a compressing store
    // to memory is slow); the second store overwrites the first's zeros past `mid`.
    unsafe {
        let d = dst.as_mut_ptr();
        let a = _mm512_maskz_compress_pd(lo, _mm512_loadu_pd(src.as_ptr()));
        let b = _mm512_maskz_compress_pd(hi, _mm512_loadu_pd(src.as_ptr().add(8)));
        _mm512_storeu_pd(d, a);
        _mm512_storeu_pd(d.add(mid), b);
    }
}

/// [`Real::expand_avx512`] of `f64`: two registers of eight.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn expand_f64_avx512(bits: u16, src: &[f64; LANES]) -> [f64; LANES] {
    use std::arch::x86_64::*;
    let (lo, hi) = (bits as u8, (bits >> 8) as u8);
    let mid = lo.count_ones() as usize;
    let mut out = [0.0; LANES];
    // SAFETY: 8 read from 0 and from `mid <= 8` of `src`'s 16, 8 stored into each half of
    // `out`.
    unsafe {
        let s = src.as_ptr();
        let a = _mm512_maskz_expand_pd(lo, _mm512_loadu_pd(s));
        let b = _mm512_maskz_expand_pd(hi, _mm512_loadu_pd(s.add(mid)));
        _mm512_storeu_pd(out.as_mut_ptr(), a);
        _mm512_storeu_pd(out.as_mut_ptr().add(8), b);
    }
    out
}

/// [`Real::compress_avx512`] of `f32`: one register of sixteen.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn compress_f32_avx512(bits: u16, src: &[f32; LANES], dst: &mut [f32; LANES]) {
    use std::arch::x86_64::*;
    // SAFETY: 16 lanes read from `src`, 16 stored into `dst`.
    unsafe {
        let a = _mm512_maskz_compress_ps(bits, _mm512_loadu_ps(src.as_ptr()));
        _mm512_storeu_ps(dst.as_mut_ptr(), a);
    }
}

/// [`Real::expand_avx512`] of `f32`: one register of sixteen.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn expand_f32_avx512(bits: u16, src: &[f32; LANES]) -> [f32; LANES] {
    use std::arch::x86_64::*;
    let mut out = [0.0; LANES];
    // SAFETY: 16 lanes read from `src`, 16 stored into `out`.
    unsafe {
        let a = _mm512_maskz_expand_ps(bits, _mm512_loadu_ps(src.as_ptr()));
        _mm512_storeu_ps(out.as_mut_ptr(), a);
    }
    out
}

/// [`Real::inv_sqrt_avx512`] of `f64`: `vrsqrt14pd` (14 bits) and two Newton steps.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn inv_sqrt_f64_avx512(v2: &[f64; LANES]) -> [f64; LANES] {
    use std::arch::x86_64::*;
    let mut out = [0.0; LANES];
    let (half, three_halves) = (_mm512_set1_pd(0.5), _mm512_set1_pd(1.5));
    let min_normal = _mm512_set1_pd(f64::MIN_POSITIVE);
    let mut tiny = 0u8;
    for k in 0..LANES / 8 {
        // SAFETY: 8 values from a slice of 8.
        let x = unsafe { _mm512_loadu_pd(v2[8 * k..8 * k + 8].as_ptr()) };
        let hx = _mm512_mul_pd(half, x);
        let mut y = _mm512_rsqrt14_pd(x);
        for _ in 0..2 {
            let yy = _mm512_mul_pd(y, y);
            y = _mm512_mul_pd(y, _mm512_fnmadd_pd(hx, yy, three_halves));
        }
        // Zero (no motion) and what is not positive give 0, as `inv_sqrt_or_zero`.
        let positive = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(x, _mm512_setzero_pd());
        let y = _mm512_maskz_mov_pd(positive, y);
        tiny |= _mm512_mask_cmp_pd_mask::<_CMP_LT_OQ>(positive, x, min_normal);
        // SAFETY: 8 values into a slice of 8.
        unsafe { _mm512_storeu_pd(out[8 * k..8 * k + 8].as_mut_ptr(), y) };
    }
    if tiny != 0 {
        subnormal_inv_sqrt(v2, &mut out);
    }
    out
}

/// Every lane of `v2` by division, where one is below the smallest normal number (a speed that
/// cancels to about 1e-154 m/s, or 1e-19 in `f32`): the estimate reads it as zero, and Newton's
/// steps make its infinity NaN.
#[cold]
#[inline(never)]
fn subnormal_inv_sqrt<T: Real>(v2: &[T; LANES], out: &mut [T; LANES]) {
    for (o, &x) in out.iter_mut().zip(v2) {
        *o = x.inv_sqrt_or_zero();
    }
}

/// [`Real::inv_sqrt_avx512`] of `f32`: `vrsqrt14ps` and one Newton step.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn inv_sqrt_f32_avx512(v2: &[f32; LANES]) -> [f32; LANES] {
    use std::arch::x86_64::*;
    let mut out = [0.0; LANES];
    // SAFETY: 16 values from an array of 16.
    let x = unsafe { _mm512_loadu_ps(v2.as_ptr()) };
    let hx = _mm512_mul_ps(_mm512_set1_ps(0.5), x);
    let y = _mm512_rsqrt14_ps(x);
    let yy = _mm512_mul_ps(y, y);
    let y = _mm512_mul_ps(y, _mm512_fnmadd_ps(hx, yy, _mm512_set1_ps(1.5)));
    let positive = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(x, _mm512_setzero_ps());
    let y = _mm512_maskz_mov_ps(positive, y);
    let tiny =
        _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(positive, x, _mm512_set1_ps(f32::MIN_POSITIVE));
    // SAFETY: 16 values into an array of 16.
    unsafe { _mm512_storeu_ps(out.as_mut_ptr(), y) };
    if tiny != 0 {
        subnormal_inv_sqrt(v2, &mut out);
    }
    out
}

/// Elements the vector loop takes at once (each of its accumulators is this wide).
pub const LANES: usize = 16;

/// A function twice: compiled for AVX-512F (`$avx512`, where `RSQRT` is true: AVX-512's
/// reciprocal square root estimate may be used) and for AVX2 and FMA (`$avx2`, `RSQRT` false),
/// the same body. Each is safe to call only where the processor has its instructions.
macro_rules! compiled_for {
    (
        $(#[$doc:meta])*
        fn $avx512:ident / $avx2:ident <$t:ident: $bound:ident>
        ($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty $body:block
    ) => {
        $(#[$doc])*
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,popcnt")]
        #[allow(clippy::unused_unit)]
        fn $avx512<$t: $bound>($($arg: $ty),*) -> $ret {
            #[allow(dead_code)]
            const RSQRT: bool = true;
            $body
        }
        $(#[$doc])*
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma,popcnt")]
        #[allow(clippy::unused_unit)]
        fn $avx2<$t: $bound>($($arg: $ty),*) -> $ret {
            #[allow(dead_code)]
            const RSQRT: bool = false;
            $body
        }
    };
}

/// The sines and cosines of [`LANES`] angles (rad) at once, in vector registers (the kernel's
/// own, within two units in the last place of `f64::sin_cos`); an angle of `2^20` rad or more,
/// or one that is no number, by `f64::sin_cos`.
///
/// ```
/// use terzaghi_core::model::batch::{LANES, sin_cos_lanes};
/// let x: [f64; LANES] = std::array::from_fn(|i| i as f64 * 0.4 - 3.0);
/// let (s, c) = sin_cos_lanes(&x);
/// assert!((s[3] - x[3].sin()).abs() < 1e-15 && (c[3] - x[3].cos()).abs() < 1e-15);
/// ```
pub fn sin_cos_lanes(x: &[f64; LANES]) -> ([f64; LANES], [f64; LANES]) {
    // Compiled for the processor's vector instructions where it has them (the same
    // operations: the same values).
    #[cfg(target_arch = "x86_64")]
    match Isa::detected() {
        // SAFETY: the processor has the instructions it was detected to have.
        Isa::Avx512 => return unsafe { sin_cos_avx512::<f64>(x) },
        // SAFETY: as above.
        Isa::Avx2 => return unsafe { sin_cos_avx2::<f64>(x) },
        Isa::Baseline => {}
    }
    sin_cos_any(x)
}

compiled_for! {
    /// [`sin_cos_lanes`] compiled for the processor's instructions.
    fn sin_cos_avx512 / sin_cos_avx2 <T: Real>(x: &[f64; LANES]) -> ([f64; LANES], [f64; LANES]) {
        sin_cos_any(x)
    }
}

/// [`sin_cos_lanes`], for any processor.
#[inline(always)]
fn sin_cos_any(x: &[f64; LANES]) -> ([f64; LANES], [f64; LANES]) {
    // Within the lanes' reach: a number below 2^20 in size (NaN is not).
    let near = |v: f64| v.abs() < 1_048_576.0;
    let (mut s, mut c) = vmath::sin_cos(x);
    if !x.iter().all(|&v| near(v)) {
        for l in (0..LANES).filter(|&l| !near(x[l])) {
            (s[l], c[l]) = x[l].sin_cos();
        }
    }
    (s, c)
}

/// `atan2(y, x)` of [`LANES`] pairs at once: where `x` is positive and both are finite, the
/// kernel's own arc tangent of `y / x` (within three units in the last place of `f64::atan2`,
/// compiled for the processor's vector instructions); any other pair by `f64::atan2`.
///
/// ```
/// use terzaghi_core::model::batch::{LANES, atan2_lanes};
/// let y: [f64; LANES] = std::array::from_fn(|i| i as f64 * 0.3 - 2.0);
/// let x: [f64; LANES] = std::array::from_fn(|i| 1.5 - i as f64 * 0.2);
/// let a = atan2_lanes(&y, &x);
/// assert!((a[3] - y[3].atan2(x[3])).abs() < 1e-15 && a[12] == y[12].atan2(x[12]));
/// ```
pub fn atan2_lanes(y: &[f64; LANES], x: &[f64; LANES]) -> [f64; LANES] {
    #[cfg(target_arch = "x86_64")]
    match Isa::detected() {
        // SAFETY: the processor has the instructions it was detected to have.
        Isa::Avx512 => return unsafe { atan2_avx512::<f64>(y, x) },
        // SAFETY: as above.
        Isa::Avx2 => return unsafe { atan2_avx2::<f64>(y, x) },
        Isa::Baseline => {}
    }
    atan2_any(y, x)
}

compiled_for! {
    /// [`atan2_lanes`] compiled for the processor's instructions.
    fn atan2_avx512 / atan2_avx2 <T: Real>(y: &[f64; LANES], x: &[f64; LANES]) -> [f64; LANES] {
        atan2_any(y, x)
    }
}

/// [`atan2_lanes`], for any processor.
#[inline(always)]
fn atan2_any(y: &[f64; LANES], x: &[f64; LANES]) -> [f64; LANES] {
    let (mut ratio, mut lanes) = ([0.0; LANES], [false; LANES]);
    for l in 0..LANES {
        lanes[l] = x[l] > 0.0 && x[l] < f64::INFINITY && y[l].abs() < f64::INFINITY;
        ratio[l] = y[l] / x[l];
    }
    let mut out = vmath::atan(&ratio);
    if !lanes.iter().all(|&ok| ok) {
        for l in (0..LANES).filter(|&l| !lanes[l]) {
            out[l] = y[l].atan2(x[l]);
        }
    }
    out
}

/// `x^exponent` of every lane, as `exp(exponent ln x)` in the lanes (compiled for the
/// processor's vector instructions): within `|exponent ln x| + 4` units in the last place of
/// `f64::powf` (the product's rounding grows with its size: below 1e-14 of the power for any
/// depth law's). A lane that is not a normal positive number, or whose product is beyond the
/// lanes' `exp`, by `f64::powf`.
///
/// ```
/// use terzaghi_core::model::batch::{LANES, powf_lanes};
/// let x: [f64; LANES] = std::array::from_fn(|i| i as f64 * 0.7);
/// let p = powf_lanes(&x, 1.37);
/// assert!((p[5] - x[5].powf(1.37)).abs() < 1e-15 * x[5].powf(1.37) && p[0] == 0.0);
/// ```
pub fn powf_lanes(x: &[f64; LANES], exponent: f64) -> [f64; LANES] {
    #[cfg(target_arch = "x86_64")]
    match Isa::detected() {
        // SAFETY: the processor has the instructions it was detected to have.
        Isa::Avx512 => return unsafe { powf_avx512::<f64>(x, exponent) },
        // SAFETY: as above.
        Isa::Avx2 => return unsafe { powf_avx2::<f64>(x, exponent) },
        Isa::Baseline => {}
    }
    powf_any(x, exponent)
}

compiled_for! {
    /// [`powf_lanes`] compiled for the processor's instructions.
    fn powf_avx512 / powf_avx2 <T: Real>(x: &[f64; LANES], exponent: f64) -> [f64; LANES] {
        powf_any(x, exponent)
    }
}

/// [`powf_lanes`], for any processor.
#[inline(always)]
fn powf_any(x: &[f64; LANES], exponent: f64) -> [f64; LANES] {
    let ln = vmath::ln(x);
    let (mut y, mut lanes) = ([0.0; LANES], true);
    for l in 0..LANES {
        y[l] = exponent * ln[l];
        lanes &= x[l] >= f64::MIN_POSITIVE && x[l] < f64::INFINITY && y[l].abs() <= 700.0;
    }
    let mut out = vmath::exp(&y);
    if !lanes {
        for l in 0..LANES {
            let ok = x[l] >= f64::MIN_POSITIVE && x[l] < f64::INFINITY && y[l].abs() <= 700.0;
            if !ok {
                out[l] = x[l].powf(exponent);
            }
        }
    }
    out
}

/// `ln` of every lane (each positive: a fitting width's `a`), in the lanes (within a unit in
/// the last place of `f64::ln`); a number below the smallest normal one by `f64::ln`.
#[inline(always)]
fn ln_lanes(x: &[f64; LANES]) -> [f64; LANES] {
    let mut out = vmath::ln(x);
    let normal = x.iter().fold(true, |k, &v| k & (v >= f64::MIN_POSITIVE));
    if !normal {
        for (o, &v) in out.iter_mut().zip(x) {
            if v < f64::MIN_POSITIVE {
                *o = v.ln();
            }
        }
    }
    out
}

/// A leg's elements as columns, padded with empty elements to a multiple of [`LANES`].
#[derive(Debug, Clone)]
pub struct Soa<T> {
    s: Vec<T>,
    q: Vec<T>,
    /// `1e6 width length` (N/cm^3 to N per metre of depth).
    wl: Vec<T>,
    c2: Vec<T>,
    s2: Vec<T>,
    /// Per [`LANES`] elements: a circle about them all, `[s, q, radius]` (m), whose lowest
    /// point above the surface lets the loop skip them.
    blocks: Vec<[f64; 3]>,
}

impl<T> Soa<T> {
    fn empty() -> Soa<T> {
        Soa {
            s: Vec::new(),
            q: Vec::new(),
            wl: Vec::new(),
            c2: Vec::new(),
            s2: Vec::new(),
            blocks: Vec::new(),
        }
    }
}

/// The circles of [`Soa::blocks`] about points `(s, q)` (padding included), with room for
/// the rounding of the loop's type.
fn blocks_of(points: impl ExactSizeIterator<Item = (f64, f64)> + Clone) -> Vec<[f64; 3]> {
    let pts: Vec<(f64, f64)> = points.collect();
    pts.chunks(LANES)
        .map(|b| {
            let (lo_s, hi_s, lo_q, hi_q) = b.iter().fold(
                (
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                ),
                |(a, bb, c, d), &(s, q)| (a.min(s), bb.max(s), c.min(q), d.max(q)),
            );
            let (cs, cq) = (0.5 * (lo_s + hi_s), 0.5 * (lo_q + hi_q));
            let r = b
                .iter()
                .map(|&(s, q)| (s - cs).hypot(q - cq))
                .fold(0.0f64, f64::max);
            let scale = cs.abs() + cq.abs() + r;
            [cs, cq, r + 1e-6 * scale + 1e-12]
        })
        .collect()
}

impl<T: Real> Soa<T> {
    fn of(rows: &[[f64; 7]], width_m: f64) -> Soa<T> {
        let n = rows.len().div_ceil(LANES) * LANES;
        let col = |f: &dyn Fn(&[f64; 7]) -> f64| -> Vec<T> {
            let mut v: Vec<T> = rows.iter().map(|r| T::of(f(r))).collect();
            v.resize(n, T::ZERO);
            v
        };
        let (s, q) = (col(&|r| r[0]), col(&|r| r[1]));
        let blocks = blocks_of(s.iter().zip(&q).map(|(s, q)| (s.to_f64(), q.to_f64())));
        Soa {
            s,
            q,
            wl: col(&|r| N_CM3_TO_N_M3 * width_m * r[2]),
            c2: col(&|r| r[3]),
            s2: col(&|r| r[4]),
            blocks,
        }
    }
}

/// A profile's elements in both types.
#[derive(Debug, Clone)]
pub struct Elements {
    f64s: Soa<f64>,
    f32s: Soa<f32>,
    /// The farthest element's distance from the hip (m): a hip higher than this has no element
    /// in the medium.
    reach_m: f64,
}

/// The fitted coefficients, summed as the vector loop uses them.
#[derive(Debug, Clone, Copy)]
struct Fit {
    a00: f64,
    a10: f64,
    /// `B11 - B-11`, `B11 + B-11`, `B01`.
    b_diff: f64,
    b_sum: f64,
    b01: f64,
    /// `C11 + C-11`, `C-11 - C11`, `C01`, `D10`.
    c_sum: f64,
    c_diff: f64,
    c01: f64,
    d10: f64,
}

/// How a kernel integrates its model.
#[derive(Debug, Clone)]
enum Plan {
    /// RFT of a profile with the fitted coefficients, no speed law.
    Profile(Box<Elements>, Fit),
    /// RFT of a flat plate with the fitted coefficients, no speed law: `elements` equal
    /// elements over its submerged length.
    Plate(Fit, usize),
    /// The improved (or conventional) Terzaghi model, [`LANES`] legs at a time.
    Terzaghi(Box<Improved>),
    /// Leg by leg through [`ForceModel::predict_moving`].
    EachLeg,
}

/// A Terzaghi model's numbers, as [`improved_lanes`] reads them.
#[derive(Debug, Clone, Copy)]
struct Improved {
    c: MediumConstants,
    /// `ln a`, and `width b_k` (m).
    ln_a: f64,
    width_b_k_m: f64,
    width_m: f64,
    length_m: f64,
}

/// Leg `i`'s fitting width: its own `b_k` and `a` where `legs` gives them, else `model`'s.
fn leg_width<T: Real>(
    model: &TerzaghiModel,
    legs: &Legs<'_, T>,
    i: usize,
) -> Result<FittingWidth, ModelError> {
    FittingWidth::new(
        legs.b_k
            .map_or(model.fitting_width().b_k(), |v| v[i].to_f64()),
        legs.a.map_or(model.fitting_width().a(), |v| v[i].to_f64()),
    )
}

/// One model for many legs (see the module's documentation).
#[derive(Debug, Clone)]
pub struct LegKernel {
    model: ForceModel,
    plan: Plan,
    isa: Isa,
}

/// The inputs of a batch: each leg's values at one index of every slice (`None`: zero).
#[derive(Debug, Clone, Copy)]
pub struct Legs<'a, T> {
    /// The joint's attack angle (rad).
    pub beta_rad: &'a [T],
    /// The hip's height above the surface (m).
    pub hip_height_m: &'a [T],
    /// The body's pitch (rad), added to the attack angle.
    pub pitch_rad: Option<&'a [T]>,
    /// The leg's rotation rate (rad/s).
    pub omega_rad_s: Option<&'a [T]>,
    /// The hip's velocity forward and up (m/s).
    pub forward_m_s: Option<&'a [T]>,
    /// See `forward_m_s`.
    pub up_m_s: Option<&'a [T]>,
    /// Each leg's fitting width `b_k` and `a` (the improved model only): a medium per
    /// environment.
    pub b_k: Option<&'a [T]>,
    /// See `b_k`.
    pub a: Option<&'a [T]>,
}

impl<'a, T> Legs<'a, T> {
    /// Legs of which every motion is given: `[beta_rad, hip_height_m, pitch_rad, omega_rad_s,
    /// forward_m_s, up_m_s]`, with the model's fitting width (set `b_k` and `a` after for one
    /// per leg).
    pub fn moving([beta, h, pitch, omega, forward, up]: [&'a [T]; 6]) -> Legs<'a, T> {
        Legs {
            beta_rad: beta,
            hip_height_m: h,
            pitch_rad: Some(pitch),
            omega_rad_s: Some(omega),
            forward_m_s: Some(forward),
            up_m_s: Some(up),
            b_k: None,
            a: None,
        }
    }
}

/// What a batch writes: each leg's drag, lift (N) and hip torque (N m).
#[derive(Debug)]
pub struct LegForcesOut<'a, T> {
    /// Drag (N).
    pub drag_n: &'a mut [T],
    /// Lift (N).
    pub lift_n: &'a mut [T],
    /// Hip torque (N m).
    pub hip_torque_nm: &'a mut [T],
}

/// Where [`LegKernel::wrenches`] writes the rest of each leg's wrench (one value per leg).
#[derive(Debug)]
pub struct LegSideOut<'a, T> {
    /// The side force along the hip frame's `y`, the robot's right (N).
    pub side_n: &'a mut [T],
    /// The moment about the hip frame's `x`, the robot's backward (N m).
    pub roll_moment_nm: &'a mut [T],
    /// The moment about the vertical (N m).
    pub yaw_moment_nm: &'a mut [T],
}

/// A leg a batch could not evaluate: its index in the inputs, and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("leg {index} (flat index): {problem}")]
pub struct LegError {
    /// The leg's index in the input slices.
    pub index: usize,
    /// Why.
    pub problem: LegProblem,
}

/// Why a leg of a batch has no forces.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LegProblem {
    /// An input the model refuses (a non-finite value, a fitting width that is not positive).
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A force beyond the output type's range.
    #[error("its {output} is {value}, beyond the output type's range")]
    Overflow {
        /// The output's name.
        output: &'static str,
        /// The force in `f64`.
        value: f64,
    },
    /// A per-leg fitting width for a model that has none.
    #[error(
        "b_k and a per leg are the improved Terzaghi model's fitting width; this model has none"
    )]
    NoFittingWidth,
}

impl LegKernel {
    /// The kernel of `model`; a per-leg fitting width (`Legs::b_k`, `Legs::a`) is taken by
    /// the improved Terzaghi model only.
    pub fn new(model: ForceModel) -> LegKernel {
        let plan = match &model {
            ForceModel::Rft(m) => {
                let parts: RftParts<'_> = m.batch_parts();
                // A leg with the bearing of sheared sand goes leg by leg: its share depends on
                // the whole leg's resultant, which the element loops do not form.
                match (
                    parts.coefficients,
                    parts.has_speed_law || m.sheared().is_some(),
                ) {
                    (super::RftCoefficients::Fit(f), false) => {
                        let fit = Fit {
                            a00: f.a00,
                            a10: f.a10,
                            b_diff: f.b11 - f.bm11,
                            b_sum: f.b11 + f.bm11,
                            b01: f.b01,
                            c_sum: f.c11 + f.cm11,
                            c_diff: f.cm11 - f.c11,
                            c01: f.c01,
                            d10: f.d10,
                        };
                        match parts.profile_elements {
                            Some(rows) => {
                                let w = m.plate().width_m();
                                let reach_m =
                                    rows.iter().map(|r| r[0].hypot(r[1])).fold(0.0f64, f64::max);
                                Plan::Profile(
                                    Box::new(Elements {
                                        f64s: Soa::of(rows, w),
                                        f32s: Soa::of(rows, w),
                                        reach_m,
                                    }),
                                    fit,
                                )
                            }
                            None => Plan::Plate(fit, parts.elements),
                        }
                    }
                    _ => Plan::EachLeg,
                }
            }
            ForceModel::Terzaghi(m) => {
                let (c, ln_a) = m.batch_constants();
                Plan::Terzaghi(Box::new(Improved {
                    c,
                    ln_a,
                    width_b_k_m: m.plate().width_m() * m.fitting_width().b_k(),
                    width_m: m.plate().width_m(),
                    length_m: m.plate().length_m(),
                }))
            }
            _ => Plan::EachLeg,
        };
        LegKernel {
            model,
            plan,
            isa: Isa::detected(),
        }
    }

    /// The kernel with its element loop compiled for `isa` (the processor's best by default);
    /// `None` where the processor lacks it.
    pub fn on(self, isa: Isa) -> Option<LegKernel> {
        let ok = match isa {
            Isa::Baseline => true,
            Isa::Avx2 => Isa::detected() != Isa::Baseline,
            Isa::Avx512 => Isa::detected() == Isa::Avx512,
        };
        ok.then_some(LegKernel { isa, ..self })
    }

    /// The element loop's compilation in use.
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// The model.
    pub fn model(&self) -> &ForceModel {
        &self.model
    }

    /// Whether the model takes a fitting width per leg (`Legs::b_k`, `Legs::a`): the improved
    /// Terzaghi model's.
    pub fn takes_fitting_width(&self) -> bool {
        matches!(&self.model, ForceModel::Terzaghi(m) if m.fitting_width() != FittingWidth::CONVENTIONAL)
    }

    /// Whether legs go through their own vector loop (RFT with the fitted coefficients),
    /// rather than [`ForceModel::predict_moving`] one by one.
    pub fn is_vectorised(&self) -> bool {
        !matches!(self.plan, Plan::EachLeg)
    }

    /// Writes the forces of legs `first..first + out.drag_n.len()` of `legs` into `out`. A
    /// non-finite input, a per-leg width the model does not take or that is not positive, or a
    /// force that overflows, is an error naming the leg (the outputs are then partly written).
    ///
    /// # Panics
    /// If an input slice is shorter than `first + out.drag_n.len()`, or the outputs differ in
    /// length.
    pub fn forces<T: Real>(
        &self,
        legs: &Legs<'_, T>,
        first: usize,
        out: LegForcesOut<'_, T>,
    ) -> Result<(), LegError> {
        let n = out.drag_n.len();
        assert!(out.lift_n.len() == n && out.hip_torque_nm.len() == n);
        let widths = match &self.model {
            _ if legs.b_k.is_none() && legs.a.is_none() => None,
            ForceModel::Terzaghi(m) if m.fitting_width() != FittingWidth::CONVENTIONAL => Some(m),
            _ if n == 0 => None,
            _ => {
                return Err(LegError {
                    index: first,
                    problem: LegProblem::NoFittingWidth,
                });
            }
        };
        match (&self.plan, widths) {
            (Plan::Terzaghi(imp), w) => return self.terzaghi_blocks(imp, legs, first, out, w),
            (Plan::Profile(e, fit), None) if self.depth_law().is_none() => {
                return self.profile_blocks(e, fit, legs, first, out);
            }
            (Plan::Profile(..) | Plan::Plate(..), None) => {
                return self.rft_blocks(legs, first, out);
            }
            _ => {}
        }
        // Leg by leg: the models without a vector plan (`Plan::EachLeg`).
        self.each_leg(legs, None, first, out, None, widths)
    }

    /// [`Self::forces`] with the rest of each leg's wrench: `lateral_m_s` is each hip's
    /// velocity to its left (m/s; `None`: zero), and `more` takes the side force and the
    /// moments about the hip frame's `x` and `z` ([`super::Prediction`]'s `side_n`,
    /// `roll_moment_nm`, `yaw_moment_nm`). A planar leg moving in its plane (the flat-plate
    /// models always; an RFT leg where every `lateral_m_s` is zero) goes through the vector
    /// loop, its side force and moments zero; a body, or an RFT leg moving across its plane,
    /// leg by leg through [`ForceModel::predict_moving`]. Errors as [`Self::forces`]'s; a
    /// lateral velocity that is not finite names its leg.
    ///
    /// # Panics
    /// As [`Self::forces`], and if `lateral_m_s` or an output of `more` is shorter.
    pub fn wrenches<T: Real>(
        &self,
        legs: &Legs<'_, T>,
        lateral_m_s: Option<&[T]>,
        first: usize,
        out: LegForcesOut<'_, T>,
        more: LegSideOut<'_, T>,
    ) -> Result<(), LegError> {
        let n = out.drag_n.len();
        assert!(
            more.side_n.len() == n
                && more.roll_moment_nm.len() == n
                && more.yaw_moment_nm.len() == n
        );
        let lateral = lateral_m_s.map(|v| &v[first..first + n]);
        if let Some(k) = lateral.and_then(|v| v.iter().position(|x| !x.to_f64().is_finite())) {
            let v = lateral.map_or(0.0, |v| v[k].to_f64());
            return Err(LegError {
                index: first + k,
                problem: ModelError::NotFinite {
                    name: "hip lateral velocity (m/s)",
                    value: v,
                }
                .into(),
            });
        }
        let in_plane = match &self.model {
            ForceModel::Terzaghi(_) | ForceModel::Sinkage(_) => true,
            ForceModel::Rft(_) => lateral.is_none_or(|v| v.iter().all(|x| x.to_f64() == 0.0)),
            ForceModel::Body(_) => false,
        };
        if in_plane {
            self.forces(legs, first, out)?;
            for o in [more.side_n, more.roll_moment_nm, more.yaw_moment_nm] {
                o.fill(T::ZERO);
            }
            return Ok(());
        }
        if legs.b_k.is_some() || legs.a.is_some() {
            // Only the improved model takes them, and it is planar (above).
            return Err(LegError {
                index: first,
                problem: LegProblem::NoFittingWidth,
            });
        }
        self.each_leg(legs, lateral_m_s, first, out, Some(more), None)
    }

    /// Legs `first..` one by one through [`ForceModel::predict_moving`] (or the improved
    /// model's own width, `widths`), with the hips' lateral velocity where given, writing the
    /// rest of the wrench into `more` where given.
    fn each_leg<T: Real>(
        &self,
        legs: &Legs<'_, T>,
        lateral_m_s: Option<&[T]>,
        first: usize,
        out: LegForcesOut<'_, T>,
        mut more: Option<LegSideOut<'_, T>>,
        widths: Option<&TerzaghiModel>,
    ) -> Result<(), LegError> {
        let n = out.drag_n.len();
        let at = |o: Option<&[T]>, i: usize| o.map_or(0.0, |v| v[i].to_f64());
        for k in 0..n {
            let i = first + k;
            let fail = |error: ModelError| LegError {
                index: i,
                problem: error.into(),
            };
            let named = |name: &'static str, v: f64| super::finite(name, v).map_err(fail);
            let beta = named("attack angle beta (rad)", legs.beta_rad[i].to_f64())?;
            let hip = HipMotion {
                height_m: named("hip height (m)", legs.hip_height_m[i].to_f64())?,
                pitch_rad: named("pitch (rad)", at(legs.pitch_rad, i))?,
                omega_rad_s: named("leg rate omega (rad/s)", at(legs.omega_rad_s, i))?,
                forward_m_s: named("hip forward velocity (m/s)", at(legs.forward_m_s, i))?,
                up_m_s: named("hip up velocity (m/s)", at(legs.up_m_s, i))?,
                forward_position_m: 0.0,
                lateral_m_s: named("hip lateral velocity (m/s)", at(lateral_m_s, i))?,
            };
            let f = match widths {
                Some(m) => {
                    let w = leg_width(m, legs, i).map_err(fail)?;
                    let f = m
                        .with_fitting_width(w)
                        .evaluate_at_height(beta + hip.pitch_rad, hip.height_m)
                        .map_err(fail)?;
                    [f.drag_n, f.lift_n, f.hip_torque_nm, 0.0, 0.0, 0.0]
                }
                None => {
                    let p = self.model.predict_moving(beta, &hip).map_err(fail)?;
                    p.wrench()
                }
            };
            let names = [
                "drag",
                "lift",
                "hip torque",
                "side force",
                "roll moment",
                "yaw moment",
            ];
            let checked = if more.is_some() { 6 } else { 3 };
            for (output, &v) in names.into_iter().zip(&f).take(checked) {
                if !T::of(v).to_f64().is_finite() {
                    return Err(LegError {
                        index: i,
                        problem: LegProblem::Overflow { output, value: v },
                    });
                }
            }
            out.drag_n[k] = T::of(f[0]);
            out.lift_n[k] = T::of(f[1]);
            out.hip_torque_nm[k] = T::of(f[2]);
            if let Some(m) = more.as_mut() {
                m.side_n[k] = T::of(f[3]);
                m.roll_moment_nm[k] = T::of(f[4]);
                m.yaw_moment_nm[k] = T::of(f[5]);
            }
        }
        Ok(())
    }

    /// [`Self::forces`] of a Terzaghi model, [`LANES`] legs at a time: the legs whose plate
    /// may reach the medium, packed into the lanes (the others are zero without a sum); a leg
    /// the lanes cannot take (an exponent beyond their range, a spiral so thin that `e^2x - 1`
    /// needs `expm1`, a force that is no number) by
    /// [`super::TerzaghiModel::evaluate_at_height`].
    fn terzaghi_blocks<T: Real>(
        &self,
        imp: &Improved,
        legs: &Legs<'_, T>,
        first: usize,
        out: LegForcesOut<'_, T>,
        per_leg: Option<&TerzaghiModel>,
    ) -> Result<(), LegError> {
        // The whole loop compiled for the kernel's instructions (its reading, checks and
        // packing too, not only the lanes' equations).
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the kernel's ISA is one the processor has (`LegKernel::on`).
            Isa::Avx512 => unsafe { terzaghi_avx512(self, imp, legs, first, out, per_leg) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            Isa::Avx2 => unsafe { terzaghi_avx2(self, imp, legs, first, out, per_leg) },
            _ => self.terzaghi_run(imp, legs, first, out, per_leg),
        }
    }

    /// [`Self::terzaghi_blocks`]' loop, in the batch's type, [`SPAN`] legs at a time in three
    /// passes: each block of [`LANES`] legs read, checked and its legs that may reach the
    /// medium packed to the span's front (each block's marked by a bit); the packed legs
    /// evaluated [`LANES`] at a time; each block's forces expanded back to its legs' places,
    /// zero where no leg was packed. Nothing is read back soon after it is stored in parts,
    /// and nothing is scattered leg by leg.
    #[inline(always)]
    fn terzaghi_run<T: Real>(
        &self,
        imp: &Improved,
        legs: &Legs<'_, T>,
        first: usize,
        out: LegForcesOut<'_, T>,
        per_leg: Option<&TerzaghiModel>,
    ) -> Result<(), LegError> {
        let n = out.drag_n.len();
        let c = LaneConsts::<T>::of(imp);
        // The packed legs' columns (angle, clamped height, `ln a`, `width b_k`), the forces
        // they give, and each block's bits; a block's packing may write a whole window.
        let mut cols = [[T::ZERO; SPAN + LANES]; 4];
        let mut f = [[T::ZERO; SPAN + LANES]; 3];
        let mut keeps = [0u16; SPAN / LANES];
        let (mut ln_a, mut width_b_k_m) = ([c.ln_a; LANES], [c.width_b_k_m; LANES]);
        for span in (0..n).step_by(SPAN) {
            let span_n = SPAN.min(n - span);
            let mut p = 0;
            for (b, start) in (span..span + span_n).step_by(LANES).enumerate() {
                let m = LANES.min(n - start);
                let at = first + start;
                // Read, and checked all at once: `0 x` is 0 for a number and NaN for
                // anything else, and so is their sum (a loop without a branch).
                let beta_given = read_as(legs.beta_rad, at, m, T::of(4.0));
                let h = read_as(legs.hip_height_m, at, m, T::ZERO);
                let given_or =
                    |from: Option<&[T]>, or: T| from.map_or([or; LANES], |v| read_as(v, at, m, or));
                let given = |from: Option<&[T]>| given_or(from, T::ZERO);
                let pitch = given(legs.pitch_rad);
                // Not the model's, but checked as every batch checks them.
                let (omega, forward, up) = (
                    given(legs.omega_rad_s),
                    given(legs.forward_m_s),
                    given(legs.up_m_s),
                );
                let mut finite = true;
                for l in 0..LANES {
                    let z = T::ZERO;
                    let c = beta_given[l] * z + h[l] * z + pitch[l] * z;
                    finite &= c + omega[l] * z + forward[l] * z + up[l] * z == z;
                }
                if !finite {
                    return Err(Block::first_not_finite(legs, at, m));
                }
                if let Some(own) = per_leg {
                    // Every leg's width is checked, in the medium or not: all at once (positive
                    // and finite), and leg by leg for the error where one is not.
                    let (model_b_k, model_a) = (own.fitting_width().b_k(), own.fitting_width().a());
                    let b_k = given_or(legs.b_k, T::of(model_b_k));
                    let a = given_or(legs.a, T::of(model_a));
                    let mut fit = true;
                    for l in 0..LANES {
                        fit &= (b_k[l] > T::ZERO)
                            & (a[l] > T::ZERO)
                            & (b_k[l] * T::ZERO == T::ZERO)
                            & (a[l] * T::ZERO == T::ZERO);
                    }
                    if !fit {
                        for l in 0..m {
                            leg_width(own, legs, at + l).map_err(|e| LegError {
                                index: at + l,
                                problem: e.into(),
                            })?;
                        }
                    }
                    // As `FittingWidth` holds them: in `f64` (the model's as it has them).
                    let (mut b_k64, mut a64) = ([model_b_k; LANES], [model_a; LANES]);
                    for l in 0..LANES {
                        if legs.b_k.is_some() {
                            b_k64[l] = b_k[l].to_f64();
                        }
                        if legs.a.is_some() {
                            a64[l] = a[l].to_f64();
                        }
                    }
                    let ln = ln_lanes(&a64);
                    for l in 0..LANES {
                        ln_a[l] = T::of(ln[l]);
                        width_b_k_m[l] = T::of(imp.width_m * b_k64[l]);
                    }
                }
                // Added in the lanes; an angle beyond a turn wrapped by a call of its own
                // (where it is inlined, the lanes compute every branch of `wrap_beta_rad`, its
                // `fmod` too).
                // (Loops, not `from_fn` or `map`: those are not always inlined, and out of line
                // they are compiled without the kernel's instructions.)
                let mut beta = [T::ZERO; LANES];
                for l in 0..LANES {
                    beta[l] = beta_given[l] + pitch[l];
                }
                let turned = beta
                    .iter()
                    .fold(false, |a, b| a | !(*b >= T::ZERO && *b < c.tau));
                if turned {
                    // In a copy: `beta` itself stays in registers.
                    let mut wrapped = beta;
                    wrap_lanes(&mut wrapped[..m]);
                    beta = wrapped;
                }
                // A plate pointing up (sine not positive), or a hip at or above its length
                // (`length - h / sin` not positive), has nothing in the medium.
                let (mut reaches, mut clamped) = ([false; LANES], [T::ZERO; LANES]);
                for l in 0..LANES {
                    reaches[l] = (beta[l] > T::ZERO) & (beta[l] <= c.pi) & (h[l] < c.length_m);
                    clamped[l] = if h[l] > T::ZERO { h[l] } else { T::ZERO };
                }
                let keep = bits_of(&reaches) & first_lanes_mask(m);
                keeps[b] = keep;
                let [c_beta, c_clamped, c_ln_a, c_width] = &mut cols;
                compress(self.isa, keep, &beta, window(c_beta, p));
                compress(self.isa, keep, &clamped, window(c_clamped, p));
                if per_leg.is_some() {
                    compress(self.isa, keep, &ln_a, window(c_ln_a, p));
                    compress(self.isa, keep, &width_b_k_m, window(c_width, p));
                }
                p += keep.count_ones() as usize;
            }
            // Past the packed legs: pointing up, out of the medium.
            window(&mut cols[0], p).fill(T::of(4.0));
            window(&mut cols[1], p).fill(T::ZERO);
            for q in (0..p).step_by(LANES) {
                let lanes = |k: usize| lanes_at(&cols[k], q);
                let (beta, clamped) = (lanes(0), lanes(1));
                let (ln_a, width_b_k_m) = if per_leg.is_some() {
                    (lanes(2), lanes(3))
                } else {
                    ([c.ln_a; LANES], [c.width_b_k_m; LANES])
                };
                let leg = |l: usize| span + packed_leg(&keeps, q + l);
                let g = self.terzaghi_lanes(
                    &c,
                    legs,
                    per_leg,
                    [&ln_a, &width_b_k_m, &beta, &clamped],
                    LANES.min(p - q),
                    leg,
                    first,
                )?;
                for (k, g) in g.iter().enumerate() {
                    *window(&mut f[k], q) = *g;
                }
            }
            // Each block's forces back to its legs' places.
            let mut p = 0;
            let mut outs = [&mut *out.drag_n, &mut *out.lift_n, &mut *out.hip_torque_nm];
            for (b, start) in (span..span + span_n).step_by(LANES).enumerate() {
                let m = LANES.min(n - start);
                for (o, f) in outs.iter_mut().zip(&f) {
                    let x = expand(self.isa, keeps[b], window_of(f, p));
                    if let Ok(whole) = <&mut [T; LANES]>::try_from(&mut o[start..start + m]) {
                        *whole = x;
                    } else {
                        o[start..start + m].copy_from_slice(&x[..m]);
                    }
                }
                p += keeps[b].count_ones() as usize;
            }
        }
        Ok(())
    }

    /// The forces of `lanes` (`ln a`, `width b_k`, the wrapped angle and the clamped hip
    /// height), the first `m` of them legs, each the leg `leg(lane)` of the outputs; a lane
    /// the lanes cannot take by [`super::TerzaghiModel::evaluate_at_height`], from the leg's
    /// inputs as given. Every value returned for the first `m` lanes is a number.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn terzaghi_lanes<T: Real>(
        &self,
        c: &LaneConsts<T>,
        legs: &Legs<'_, T>,
        per_leg: Option<&TerzaghiModel>,
        [ln_a, width_b_k_m, beta, clamped]: [&[T; LANES]; 4],
        m: usize,
        leg: impl Fn(usize) -> usize,
        first: usize,
    ) -> Result<[[T; LANES]; 3], LegError> {
        let ForceModel::Terzaghi(model) = &self.model else {
            unreachable!("a Terzaghi plan is a Terzaghi model's")
        };
        let (mut f, mut scalar) = ([[T::ZERO; LANES]; 3], [false; LANES]);
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the kernel's ISA is one the processor has (`LegKernel::on`).
            Isa::Avx512 => unsafe {
                improved_avx512(c, ln_a, width_b_k_m, beta, clamped, &mut f, &mut scalar)
            },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            Isa::Avx2 => unsafe {
                improved_avx2(c, ln_a, width_b_k_m, beta, clamped, &mut f, &mut scalar)
            },
            _ => improved_lanes(c, ln_a, width_b_k_m, beta, clamped, &mut f, &mut scalar),
        }
        let mut scalar = bits_of(&scalar) & first_lanes_mask(m);
        while scalar != 0 {
            let l = scalar.trailing_zeros() as usize;
            scalar &= scalar - 1;
            let i = first + leg(l);
            let fail = |e: ModelError| LegError {
                index: i,
                problem: e.into(),
            };
            let own;
            let leg_model = match per_leg {
                Some(own_model) => {
                    own =
                        own_model.with_fitting_width(leg_width(own_model, legs, i).map_err(fail)?);
                    &own
                }
                None => model,
            };
            let pitch = legs.pitch_rad.map_or(0.0, |v| v[i].to_f64());
            let r = leg_model
                .evaluate_at_height(
                    legs.beta_rad[i].to_f64() + pitch,
                    legs.hip_height_m[i].to_f64(),
                )
                .map_err(fail)?;
            for (k, (output, v)) in ["drag", "lift", "hip torque"]
                .into_iter()
                .zip([r.drag_n, r.lift_n, r.hip_torque_nm])
                .enumerate()
            {
                if !T::of(v).finite() {
                    return Err(LegError {
                        index: i,
                        problem: LegProblem::Overflow { output, value: v },
                    });
                }
                f[k][l] = T::of(v);
            }
        }
        Ok(f)
    }

    /// [`Self::forces`] of a profile's legs (RFT with the fitted coefficients, no law in
    /// depth), [`LANES`] legs at a time: the legs that may reach the medium are packed into
    /// the lanes (the others are zero without a sum), and each lane sums its leg's elements
    /// in order, in the batch's type; a leg whose speeds are out of the type's range by
    /// [`ForceModel::predict_moving`].
    fn profile_blocks<T: Real>(
        &self,
        e: &Elements,
        fit: &Fit,
        legs: &Legs<'_, T>,
        first: usize,
        out: LegForcesOut<'_, T>,
    ) -> Result<(), LegError> {
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the kernel's ISA is one the processor has (`LegKernel::on`).
            Isa::Avx512 => unsafe { profile_blocks_avx512(self, e, fit, legs, first, out) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            Isa::Avx2 => unsafe { profile_blocks_avx2(self, e, fit, legs, first, out) },
            _ => self.profile_run(e, fit, legs, first, out),
        }
    }

    /// [`Self::profile_blocks`]' loop.
    #[inline(always)]
    fn profile_run<T: Real>(
        &self,
        e: &Elements,
        fit: &Fit,
        legs: &Legs<'_, T>,
        first: usize,
        mut out: LegForcesOut<'_, T>,
    ) -> Result<(), LegError> {
        let n = out.drag_n.len();
        let soa = T::elements(e);
        let mut block = Block::new();
        let mut packed = PackedRft::new();
        for start in (0..n).step_by(LANES) {
            let m = LANES.min(n - start);
            block.gather(legs, first + start, m)?;
            for o in [&mut *out.drag_n, &mut *out.lift_n, &mut *out.hip_torque_nm] {
                zero(&mut o[start..start + m]);
            }
            let (sin, cos) = vmath::sin_cos(&block.beta);
            // A leg reaches the medium if a block's circle of elements does (the lowest point
            // of a circle at `(s, q)` is `s sin + q cos + r` below the hip).
            let mut reach = [f64::NEG_INFINITY; LANES];
            for &[bs, bq, br] in &soa.blocks {
                for l in 0..LANES {
                    reach[l] = reach[l].max(bs * sin[l] + bq * cos[l] + br);
                }
            }
            let mut keep = 0u16;
            for (l, (h, r)) in block.h.iter().zip(&reach).enumerate() {
                keep |= u16::from(h < r) << l;
            }
            keep &= first_lanes_mask(m);
            let (mut omega, mut vx, mut vz, mut scalar) =
                ([1.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
            for l in 0..LANES {
                let (x, z) = (-block.forward[l], block.up[l]);
                // A leg that neither turns nor moves is evaluated as turning forward
                // (quasi-static), as `Frame::new`.
                let still = block.omega[l] == 0.0 && x == 0.0 && z == 0.0;
                let (w, x, z) = if still {
                    (1.0, 0.0, 0.0)
                } else {
                    (block.omega[l], x, z)
                };
                let scale = w.abs() * e.reach_m + x.abs() + z.abs();
                let in_range = scale <= T::MAX_SPEED_SCALE && scale >= T::MIN_SPEED_SCALE;
                // A leg out of range is evaluated by `predict_moving`; its lane turns still.
                if in_range {
                    (omega[l], vx[l], vz[l]) = (w, x, z);
                } else {
                    scalar[l] = 1.0;
                }
            }
            let q = &mut packed;
            let p = pack(
                self.isa,
                keep,
                start,
                q.m,
                &mut q.at,
                [
                    (&sin, &mut q.sin),
                    (&cos, &mut q.cos),
                    (&block.h, &mut q.h),
                    (&omega, &mut q.omega),
                    (&vx, &mut q.vx),
                    (&vz, &mut q.vz),
                    (&scalar, &mut q.scalar),
                ],
            );
            packed.m = p;
            if p >= LANES {
                self.profile_packed(soa, fit, &packed, LANES, legs, first, &mut out)?;
                packed.shift();
            }
        }
        let m = packed.m;
        if m > 0 {
            // Past the legs: above every element.
            packed.h[m..LANES].fill(f64::INFINITY);
            self.profile_packed(soa, fit, &packed, m, legs, first, &mut out)?;
        }
        Ok(())
    }

    /// The forces of the first `m` of `packed`'s legs into `out` (its first [`LANES`] lanes
    /// evaluated).
    #[allow(clippy::too_many_arguments)]
    fn profile_packed<T: Real>(
        &self,
        soa: &Soa<T>,
        fit: &Fit,
        p: &PackedRft,
        m: usize,
        legs: &Legs<'_, T>,
        first: usize,
        out: &mut LegForcesOut<'_, T>,
    ) -> Result<(), LegError> {
        let frames = LaneFrames::of(p, fit);
        let mut f = match self.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the kernel's ISA is one the processor has (`LegKernel::on`).
            Isa::Avx512 => unsafe { profile_avx512(soa, &frames) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            Isa::Avx2 => unsafe { profile_avx2(soa, &frames) },
            _ => profile_lanes::<T, false, false>(soa, &frames),
        };
        for l in (0..m).filter(|&l| p.scalar[l] != 0.0) {
            let i = first + p.at[l];
            let at = |o: Option<&[T]>| o.map_or(0.0, |v| v[i].to_f64());
            let hip = HipMotion {
                height_m: legs.hip_height_m[i].to_f64(),
                pitch_rad: at(legs.pitch_rad),
                omega_rad_s: at(legs.omega_rad_s),
                forward_m_s: at(legs.forward_m_s),
                up_m_s: at(legs.up_m_s),
                forward_position_m: 0.0,
                lateral_m_s: 0.0,
            };
            let r = self
                .model
                .predict_moving(legs.beta_rad[i].to_f64(), &hip)
                .map_err(|e| LegError {
                    index: i,
                    problem: e.into(),
                })?;
            [f[0][l], f[1][l], f[2][l]] = [r.drag_n, r.lift_n, r.hip_torque_nm];
        }
        scatter(&f, &p.at[..m], first, out)
    }

    /// [`Self::forces`] of RFT's legs by the vector loop, [`LANES`] legs' angles at a time; a
    /// leg whose speeds are out of the loop type's range by
    /// [`ForceModel::predict_moving`].
    fn rft_blocks<T: Real>(
        &self,
        legs: &Legs<'_, T>,
        first: usize,
        mut out: LegForcesOut<'_, T>,
    ) -> Result<(), LegError> {
        let n = out.drag_n.len();
        let mut scratch = Scratch::default();
        let mut block = Block::new();
        for start in (0..n).step_by(LANES) {
            let m = LANES.min(n - start);
            block.gather(legs, first + start, m)?;
            let (sin, cos) = vmath::sin_cos(&block.beta);
            let mut forces = [[0.0; LANES]; 3];
            for l in 0..m {
                let i = first + start + l;
                let hip = block.hip(l);
                let sc = (sin[l], cos[l]);
                let f = match &self.plan {
                    Plan::Profile(e, fit) => self.profile_leg::<T>(e, fit, sc, &hip, &mut scratch),
                    Plan::Plate(fit, elements) => {
                        self.plate_leg::<T>(fit, *elements, sc, &hip, &mut scratch)
                    }
                    _ => unreachable!("RFT's plans only"),
                };
                let f = match f {
                    Some(f) => f,
                    None => {
                        let p = self
                            .model
                            .predict_moving(block.beta_given[l], &block.hip_given(l))
                            .map_err(|e| LegError {
                                index: i,
                                problem: e.into(),
                            })?;
                        [p.drag_n, p.lift_n, p.hip_torque_nm]
                    }
                };
                [forces[0][l], forces[1][l], forces[2][l]] = f;
            }
            write_block(&forces, m, first + start, start, &mut out)?;
        }
        Ok(())
    }

    /// The depth law of an RFT model, if any.
    fn depth_law(&self) -> Option<&super::RftDepthLaw> {
        match &self.model {
            ForceModel::Rft(m) => m.depth_law(),
            _ => None,
        }
    }

    /// A profile leg by the vector loop; `None` where its speed is out of the type's range.
    fn profile_leg<T: Real>(
        &self,
        e: &Elements,
        fit: &Fit,
        sin_cos: (f64, f64),
        hip: &HipMotion,
        scratch: &mut Scratch<T>,
    ) -> Option<[f64; 3]> {
        let h = hip.height_m;
        // No element below the surface: nothing to integrate.
        if h > e.reach_m * (1.0 + 1e-6) {
            return Some([0.0; 3]);
        }
        let frame = Frame::new::<T>(sin_cos, h, hip, e.reach_m)?;
        let soa = T::elements(e);
        Some(sum(soa, fit, &frame, self.depth_law(), scratch, self.isa))
    }

    /// A flat plate's leg by the vector loop: `elements` equal elements over its submerged
    /// length, as [`super::RftModel::evaluate_moving`] cuts it.
    fn plate_leg<T: Real>(
        &self,
        fit: &Fit,
        elements: usize,
        sin_cos: (f64, f64),
        hip: &HipMotion,
        scratch: &mut Scratch<T>,
    ) -> Option<[f64; 3]> {
        let ForceModel::Rft(m) = &self.model else {
            return None;
        };
        let h = hip.height_m;
        let plate = m.plate();
        let l = plate.length_m();
        // Plate::submerged_length_m of the hip clamped to the surface.
        let l_s = if sin_cos.0 <= 0.0 {
            0.0
        } else {
            (l - h.max(0.0) / sin_cos.0).max(0.0)
        };
        if l_s <= 0.0 {
            return Some([0.0; 3]);
        }
        let frame = Frame::new::<T>(sin_cos, h, hip, l)?;
        let ds = l_s / elements as f64;
        let wl = N_CM3_TO_N_M3 * plate.width_m() * ds;
        let n = elements.div_ceil(LANES) * LANES;
        let soa = &mut scratch.plate;
        for col in [
            &mut soa.s,
            &mut soa.q,
            &mut soa.wl,
            &mut soa.c2,
            &mut soa.s2,
        ] {
            col.clear();
            col.resize(n, T::ZERO);
        }
        for i in 0..elements {
            soa.s[i] = T::of((l - l_s) + (i as f64 + 0.5) * ds);
            soa.wl[i] = T::of(wl);
            soa.c2[i] = T::of(1.0);
        }
        soa.blocks = blocks_of(soa.s.iter().map(|s| (s.to_f64(), 0.0)));
        let soa = std::mem::replace(&mut scratch.plate, Soa::empty());
        let f = sum(&soa, fit, &frame, self.depth_law(), scratch, self.isa);
        scratch.plate = soa;
        Some(f)
    }
}

compiled_for! {
    /// [`LegKernel::terzaghi_blocks`] compiled for the processor's instructions.
    fn terzaghi_avx512 / terzaghi_avx2 <T: Real>(
        k: &LegKernel,
        imp: &Improved,
        legs: &Legs<'_, T>,
        first: usize,
        out: LegForcesOut<'_, T>,
        per_leg: Option<&TerzaghiModel>,
    ) -> Result<(), LegError> {
        k.terzaghi_run(imp, legs, first, out, per_leg)
    }
}

compiled_for! {
    /// [`LegKernel::profile_blocks`] compiled for the processor's instructions.
    fn profile_blocks_avx512 / profile_blocks_avx2 <T: Real>(
        k: &LegKernel,
        e: &Elements,
        fit: &Fit,
        legs: &Legs<'_, T>,
        first: usize,
        out: LegForcesOut<'_, T>,
    ) -> Result<(), LegError> {
        k.profile_run(e, fit, legs, first, out)
    }
}

/// Writes `m` legs' forces (drag, lift, torque by lane) at `at` of `out`, in its type; one
/// beyond the type's range is an error naming its leg (`first` the block's first).
fn write_block<T: Real>(
    f: &[[f64; LANES]; 3],
    m: usize,
    first: usize,
    at: usize,
    out: &mut LegForcesOut<'_, T>,
) -> Result<(), LegError> {
    let mut finite = true;
    for (dst, src) in [
        &mut out.drag_n[at..at + m],
        &mut out.lift_n[at..at + m],
        &mut out.hip_torque_nm[at..at + m],
    ]
    .into_iter()
    .zip(f)
    {
        match <&mut [T; LANES]>::try_from(&mut *dst) {
            Ok(whole) => *whole = src.map(T::of),
            Err(_) => {
                for (d, s) in dst.iter_mut().zip(src) {
                    *d = T::of(*s);
                }
            }
        }
        // Lane by lane, without a branch: a fold of `&` runs in vector registers, where a
        // sum's order is fixed and is not.
        finite &= dst.iter().fold(true, |a, d| a & d.to_f64().is_finite());
    }
    if finite {
        return Ok(());
    }
    for (l, k) in (0..m).flat_map(|l| (0..3).map(move |k| (l, k))) {
        let output = ["drag", "lift", "hip torque"][k];
        {
            if !T::of(f[k][l]).to_f64().is_finite() {
                return Err(LegError {
                    index: first + l,
                    problem: LegProblem::Overflow {
                        output,
                        value: f[k][l],
                    },
                });
            }
        }
    }
    unreachable!("a force was beyond the type's range")
}

/// Writes lane `l`'s forces (drag, lift, torque by lane) at `at[l]` of `out`, in its type; one
/// beyond the type's range is an error naming its leg (`first` the batch's first).
#[inline(always)]
fn scatter<T: Real>(
    f: &[[f64; LANES]; 3],
    at: &[usize],
    first: usize,
    out: &mut LegForcesOut<'_, T>,
) -> Result<(), LegError> {
    for (l, &k) in at.iter().enumerate() {
        let v = [T::of(f[0][l]), T::of(f[1][l]), T::of(f[2][l])];
        if !v.iter().all(|x| x.to_f64().is_finite()) {
            return write_block(&lane(f, l), 1, first + k, k, out);
        }
        out.drag_n[k] = v[0];
        out.lift_n[k] = v[1];
        out.hip_torque_nm[k] = v[2];
    }
    Ok(())
}

/// Zeroes `o` (a whole block as one store of known size).
#[inline(always)]
fn zero<T: Real>(o: &mut [T]) {
    match <&mut [T; LANES]>::try_from(&mut *o) {
        Ok(whole) => *whole = [T::ZERO; LANES],
        Err(_) => o.iter_mut().for_each(|x| *x = T::ZERO),
    }
}

/// Lane `l` of `f` in lane 0.
#[cold]
fn lane(f: &[[f64; LANES]; 3], l: usize) -> [[f64; LANES]; 3] {
    let mut one = [[0.0; LANES]; 3];
    for (o, f) in one.iter_mut().zip(f) {
        o[0] = f[l];
    }
    one
}

/// Room for a block of legs packed and the next block's: a block's legs are packed
/// whole, then the first [`LANES`] evaluated.
const PACK: usize = 2 * LANES;

/// The first [`LANES`] of `a`.
#[inline(always)]
fn first_lanes<T: Copy>(a: &[T; PACK]) -> [T; LANES] {
    std::array::from_fn(|l| a[l])
}

/// The [`LANES`] of `a` from `p`.
///
/// # Panics
/// If `a` has fewer than `p + LANES`.
#[inline(always)]
fn window<T>(a: &mut [T], p: usize) -> &mut [T; LANES] {
    (&mut a[p..p + LANES])
        .try_into()
        .expect("a window of LANES")
}

/// The [`LANES`] of `a` from `p` (a load of known size).
///
/// # Panics
/// If `a` has fewer than `p + LANES`.
#[inline(always)]
fn lanes_at<T: Copy>(a: &[T], p: usize) -> [T; LANES] {
    *<&[T; LANES]>::try_from(&a[p..p + LANES]).expect("a window of LANES")
}

/// The [`LANES`] of `a` from `p`, in place (read where they are: a copy of them, then a
/// load across its parts, would stall).
///
/// # Panics
/// If `a` has fewer than `p + LANES`.
#[inline(always)]
fn window_of<T>(a: &[T], p: usize) -> &[T; LANES] {
    (&a[p..p + LANES]).try_into().expect("a window of LANES")
}

/// Legs a Terzaghi batch takes at once in [`LegKernel::terzaghi_run`]'s passes: their packed
/// columns and forces stay in the first level of cache.
const SPAN: usize = 256;

/// The lanes `bits` marks of `src`, in order, at the front of `dst` (the rest overwritten).
#[inline(always)]
fn compress<T: Real>(isa: Isa, bits: u16, src: &[T; LANES], dst: &mut [T; LANES]) {
    #[cfg(target_arch = "x86_64")]
    if isa == Isa::Avx512 {
        // SAFETY: the kernel's ISA is one the processor has (`LegKernel::on`).
        return unsafe { T::compress_avx512(bits, src, dst) };
    }
    #[cfg(target_arch = "x86_64")]
    if isa == Isa::Avx2 {
        // SAFETY: as above.
        return unsafe { compress_avx2(bits, src, dst) };
    }
    let _ = isa;
    // Every lane written to the next place, the place kept only for a lane marked (no branch
    // to mispredict; the place is at most the lane's own).
    let mut q = 0;
    for (l, &x) in src.iter().enumerate() {
        dst[q] = x;
        q += usize::from(bits >> l & 1 == 1);
    }
}

/// [`compress`]' inverse: the lanes `bits` marks taken from `src`'s front, in order; the
/// others zero.
#[inline(always)]
fn expand<T: Real>(isa: Isa, bits: u16, src: &[T; LANES]) -> [T; LANES] {
    #[cfg(target_arch = "x86_64")]
    if isa == Isa::Avx512 {
        // SAFETY: the kernel's ISA is one the processor has (`LegKernel::on`).
        return unsafe { T::expand_avx512(bits, src) };
    }
    #[cfg(target_arch = "x86_64")]
    if isa == Isa::Avx2 {
        // SAFETY: as above.
        return unsafe { expand_avx2(bits, src) };
    }
    let _ = isa;
    // Every lane takes the next packed one, or zero (no branch to mispredict; the place is at
    // most the lane's own).
    let (mut out, mut q) = ([T::ZERO; LANES], 0);
    for (l, o) in out.iter_mut().enumerate() {
        let marked = bits >> l & 1 == 1;
        let x = src[q];
        *o = if marked { x } else { T::ZERO };
        q += usize::from(marked);
    }
    out
}

/// For each mask of a group of `G` lanes (`N = 2^G` masks) of `8 / G` words each: the source
/// word of each word of the group's compress (the marked lanes in order, then word 0), or of
/// its `expand` (a marked lane takes the next of the packed lanes; an unmarked one word 0,
/// zeroed after).
const fn word_table<const G: usize, const N: usize>(expand: bool) -> [[u8; 8]; N] {
    let w = 8 / G;
    let mut t = [[0u8; 8]; N];
    let mut m = 0;
    while m < N {
        // Lane `l` of the group is the `j`-th marked one.
        let (mut j, mut l) = (0, 0);
        while l < G {
            if m >> l & 1 == 1 {
                let (to, from) = if expand { (l, j) } else { (j, l) };
                let mut k = 0;
                while k < w {
                    t[m][to * w + k] = (from * w + k) as u8;
                    k += 1;
                }
                j += 1;
            }
            l += 1;
        }
        m += 1;
    }
    t
}

/// The words of a compress or an expand of eight `f32` lanes, and of four `f64` lanes.
static COMPRESS_8: [[u8; 8]; 256] = word_table::<8, 256>(false);
static EXPAND_8: [[u8; 8]; 256] = word_table::<8, 256>(true);
static COMPRESS_4: [[u8; 8]; 16] = word_table::<4, 16>(false);
static EXPAND_4: [[u8; 8]; 16] = word_table::<4, 16>(true);

/// A group's word indices for `_mm256_permutevar8x32_ps`, and the lanes per group.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn group_words<T>(compress: bool, m: usize) -> (&'static [u8; 8], usize) {
    match (std::mem::size_of::<T>(), compress) {
        (4, true) => (&COMPRESS_8[m], 8),
        (4, false) => (&EXPAND_8[m], 8),
        (_, true) => (&COMPRESS_4[m], 4),
        (_, false) => (&EXPAND_4[m], 4),
    }
}

/// [`compress`] on AVX2: a group of lanes (eight `f32`, four `f64`) at a time, permuted by a
/// table and stored whole where the previous group's marked lanes end (over its others).
///
/// # Safety
/// The processor has AVX2, and `T` is `f32` or `f64`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt")]
#[inline]
fn compress_avx2<T: Real>(bits: u16, src: &[T; LANES], dst: &mut [T; LANES]) {
    use std::arch::x86_64::*;
    let g = group_words::<T>(true, 0).1;
    let mut pos = 0;
    for k in 0..LANES / g {
        let m = (bits as usize >> (k * g)) & ((1 << g) - 1);
        let (words, _) = group_words::<T>(true, m);
        // SAFETY: a group of 32 bytes read from lane `k g` of `src` and stored from lane
        // `pos <= k g` of `dst` (no more lanes are marked before it than there are): each ends
        // within its array of `LANES`; the table's row is 8 bytes.
        unsafe {
            let v = _mm256_loadu_ps(src.as_ptr().add(k * g).cast());
            let idx = _mm256_cvtepu8_epi32(_mm_loadl_epi64(words.as_ptr().cast()));
            _mm256_storeu_ps(
                dst.as_mut_ptr().add(pos).cast(),
                _mm256_permutevar8x32_ps(v, idx),
            );
        }
        pos += m.count_ones() as usize;
    }
}

/// [`expand`] on AVX2: a group of lanes at a time, read from where the previous group's marked
/// lanes end, permuted by a table, the unmarked lanes zeroed.
///
/// # Safety
/// The processor has AVX2, and `T` is `f32` or `f64`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt")]
#[inline]
fn expand_avx2<T: Real>(bits: u16, src: &[T; LANES]) -> [T; LANES] {
    use std::arch::x86_64::*;
    let g = group_words::<T>(false, 0).1;
    let w = 8 / g;
    let mut out = [T::ZERO; LANES];
    let mut pos = 0;
    // Each word's lane's bit within its group.
    let lane_bit = _mm256_setr_epi32(
        1,
        1 << (1 / w),
        1 << (2 / w),
        1 << (3 / w),
        1 << (4 / w),
        1 << (5 / w),
        1 << (6 / w),
        1 << (7 / w),
    );
    for k in 0..LANES / g {
        let m = (bits as usize >> (k * g)) & ((1 << g) - 1);
        let (words, _) = group_words::<T>(false, m);
        // SAFETY: 32 bytes read from lane `pos <= k g` of `src` and stored at lane `k g` of
        // `out`: each ends within its array of `LANES`; the table's row is 8 bytes.
        unsafe {
            let v = _mm256_loadu_ps(src.as_ptr().add(pos).cast());
            let idx = _mm256_cvtepu8_epi32(_mm_loadl_epi64(words.as_ptr().cast()));
            let marked = _mm256_cmpeq_epi32(
                _mm256_and_si256(_mm256_set1_epi32(m as i32), lane_bit),
                lane_bit,
            );
            let x = _mm256_and_ps(
                _mm256_permutevar8x32_ps(v, idx),
                _mm256_castsi256_ps(marked),
            );
            _mm256_storeu_ps(out.as_mut_ptr().add(k * g).cast(), x);
        }
        pos += m.count_ones() as usize;
    }
    out
}

/// The bits of `b`, lane `l` bit `l`.
#[inline(always)]
fn bits_of(b: &[bool; LANES]) -> u16 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is x86-64's baseline; 16 bools (each byte 0 or 1) read as 16 bytes,
        // each one's bit moved to its top, where `movemask` takes it.
        unsafe {
            let v = _mm_loadu_si128(b.as_ptr().cast());
            _mm_movemask_epi8(_mm_slli_epi64::<7>(v)) as u16
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    b.iter()
        .enumerate()
        .fold(0, |k, (l, &x)| k | u16::from(x) << l)
}

/// Where the packed lane `q` of a span came from: its leg's place in the span, by the blocks'
/// bits (a leg the lanes hand to the scalar path, so seldom).
#[cold]
#[inline(never)]
fn packed_leg(keeps: &[u16], q: usize) -> usize {
    let mut left = q;
    for (b, &k) in keeps.iter().enumerate() {
        let here = k.count_ones() as usize;
        if left < here {
            let lane = (0..LANES)
                .filter(|&l| k >> l & 1 == 1)
                .nth(left)
                .expect("fewer marked lanes than counted");
            return b * LANES + lane;
        }
        left -= here;
    }
    unreachable!("packed lane {q} beyond the span's marked legs")
}

/// Moves the second half of `a` to the first (a copy of known size).
#[inline(always)]
fn shift<T: Copy>(a: &mut [T; PACK]) {
    let (front, back) = a.split_at_mut(LANES);
    front.copy_from_slice(back);
}

/// The mask of the first `m` lanes.
#[inline(always)]
fn first_lanes_mask(m: usize) -> u16 {
    if m >= LANES {
        u16::MAX
    } else {
        (1u16 << m) - 1
    }
}

/// Appends the lanes `keep` marks (a bit each), of each column's source, to its destination
/// from lane `p`, in order, and their indices (`start` plus the lane) to `at`; returns the new
/// count. On AVX-512 by the processor's compress; else every lane is written to the next place
/// and the place kept only for a lane marked (no branch to mispredict).
///
/// # Panics
/// If `p` is not below [`LANES`].
#[inline(always)]
fn pack<T: Real, const N: usize>(
    isa: Isa,
    keep: u16,
    start: usize,
    p: usize,
    at: &mut [usize; PACK],
    mut cols: [(&[T; LANES], &mut [T; PACK]); N],
) -> usize {
    assert!(p < LANES);
    #[cfg(target_arch = "x86_64")]
    if isa == Isa::Avx512 {
        // SAFETY: the kernel's ISA is one the processor has (`LegKernel::on`), and `p` is
        // below `LANES`.
        return unsafe { pack_avx512(keep, start, p, at, cols) };
    }
    let _ = isa;
    let mut q = p;
    for l in 0..LANES {
        at[q] = start + l;
        for (src, dst) in cols.iter_mut() {
            dst[q] = src[l];
        }
        q += usize::from(keep >> l & 1 == 1);
    }
    q
}

/// [`pack`] by AVX-512's compress.
///
/// # Safety
/// The processor has AVX-512F, and `p < LANES`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn pack_avx512<T: Real, const N: usize>(
    bits: u16,
    start: usize,
    p: usize,
    at: &mut [usize; PACK],
    cols: [(&[T; LANES], &mut [T; PACK]); N],
) -> usize {
    use std::arch::x86_64::*;
    for (src, dst) in cols {
        // SAFETY: the caller's promise.
        unsafe { T::compress_avx512(bits, src, window(dst, p)) };
    }
    let (lo, hi) = (bits as u8, (bits >> 8) as u8);
    let mid = p + lo.count_ones() as usize;
    let first = _mm512_add_epi64(
        _mm512_set1_epi64(start as i64),
        _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0),
    );
    let second = _mm512_add_epi64(first, _mm512_set1_epi64(8));
    // SAFETY: 8 stored from `p < 16` and from `mid <= p + 8 < 24`: each store ends within
    // `PACK`; `usize` is 64 bits on x86-64.
    unsafe {
        let d = at.as_mut_ptr().cast::<i64>();
        _mm512_storeu_si512(d.add(p).cast(), _mm512_maskz_compress_epi64(lo, first));
        _mm512_storeu_si512(d.add(mid).cast(), _mm512_maskz_compress_epi64(hi, second));
    }
    mid + hi.count_ones() as usize
}

/// Legs of a profile's batch that may reach the medium, packed into the lanes.
struct PackedRft {
    /// How many lanes are legs.
    m: usize,
    /// Each lane's index in the outputs.
    at: [usize; PACK],
    /// The attack angle's (with the pitch) sine and cosine; the hip's height (m).
    sin: [f64; PACK],
    cos: [f64; PACK],
    h: [f64; PACK],
    /// The leg's rate (rad/s) and the hip's velocity in the leg's frame (m/s), as
    /// `Frame::new` gives them.
    omega: [f64; PACK],
    vx: [f64; PACK],
    vz: [f64; PACK],
    /// 1 for speeds out of the type's range: the leg goes to `predict_moving`.
    scalar: [f64; PACK],
}

impl PackedRft {
    fn new() -> PackedRft {
        PackedRft {
            m: 0,
            at: [0; PACK],
            sin: [0.0; PACK],
            cos: [1.0; PACK],
            h: [f64::INFINITY; PACK],
            omega: [1.0; PACK],
            vx: [0.0; PACK],
            vz: [0.0; PACK],
            scalar: [0.0; PACK],
        }
    }

    /// Drops the first [`LANES`] legs (evaluated), the rest moved to the front.
    #[inline(always)]
    fn shift(&mut self) {
        let rest = self.m - LANES;
        for a in [
            &mut self.sin,
            &mut self.cos,
            &mut self.h,
            &mut self.omega,
            &mut self.vx,
            &mut self.vz,
            &mut self.scalar,
        ] {
            shift(a);
        }
        shift(&mut self.at);
        self.m = rest;
    }
}

/// [`LANES`] legs' frames (as [`Frame`]) and the fitted coefficients, as
/// [`profile_lanes`] reads them.
struct LaneFrames {
    sin: [f64; LANES],
    cos: [f64; LANES],
    h: [f64; LANES],
    omega: [f64; LANES],
    vx: [f64; LANES],
    vz: [f64; LANES],
    fit: Fit,
}

impl LaneFrames {
    fn of(p: &PackedRft, fit: &Fit) -> LaneFrames {
        LaneFrames {
            sin: first_lanes(&p.sin),
            cos: first_lanes(&p.cos),
            h: first_lanes(&p.h),
            omega: first_lanes(&p.omega),
            vx: first_lanes(&p.vx),
            vz: first_lanes(&p.vz),
            fit: *fit,
        }
    }
}

compiled_for! {
    /// [`profile_lanes`] compiled for the processor's instructions (`RSQRT`: AVX-512's
    /// estimate).
    fn profile_avx512 / profile_avx2 <T: Real>(soa: &Soa<T>, lanes: &LaneFrames) -> [[f64; LANES]; 3] {
        profile_lanes::<T, true, RSQRT>(soa, lanes)
    }
}

/// A profile's forces on [`LANES`] legs at once, each lane a leg: [`sum_lanes`]'s equations
/// per element, the element's numbers shared by the lanes and the leg's by its lane, summed
/// in the elements' order. A block of elements whose circle lies above every lane's surface
/// is skipped.
#[inline(always)]
fn profile_lanes<T: Real, const FMA: bool, const RSQRT: bool>(
    soa: &Soa<T>,
    lanes: &LaneFrames,
) -> [[f64; LANES]; 3] {
    let fma = |a: T, b: T, d: T| if FMA { a.mul_add(b, d) } else { a * b + d };
    let t = |a: &[f64; LANES]| a.map(T::of);
    let (sin, cos) = (&lanes.sin, &lanes.cos);
    // The chord's direction `u = (-cos, -sin)`, the travel `n = (sin, -cos)`, as `Frame`.
    let u0 = cos.map(|c| T::of(-c));
    let u1 = sin.map(|s| T::of(-s));
    let n0 = t(sin);
    let n1 = u0;
    let c2b: [T; LANES] = std::array::from_fn(|l| T::of(cos[l] * cos[l] - sin[l] * sin[l]));
    let s2b: [T; LANES] = std::array::from_fn(|l| T::of(2.0 * sin[l] * cos[l]));
    let (h, omega, vhx, vhz) = (t(&lanes.h), t(&lanes.omega), t(&lanes.vx), t(&lanes.vz));
    let k = |x: f64| T::of(x);
    let fit = &lanes.fit;
    let (a00, a10, b_diff, b_sum, b01) = (
        k(fit.a00),
        k(fit.a10),
        k(fit.b_diff),
        k(fit.b_sum),
        k(fit.b01),
    );
    let (c_sum, c_diff, c01, d10) = (k(fit.c_sum), k(fit.c_diff), k(fit.c01), k(fit.d10));
    let z = T::ZERO;
    let mut drag = [z; LANES];
    let mut lift = [z; LANES];
    let mut torque = [z; LANES];
    for (b, &[bs, bq, br]) in soa.blocks.iter().enumerate() {
        let reaches = (0..LANES).fold(false, |a, l| {
            a | (bs * sin[l] + bq * cos[l] + br > lanes.h[l])
        });
        if !reaches {
            continue;
        }
        for j in b * LANES..(b + 1) * LANES {
            let (s, q, wl, c2, s2) = (soa.s[j], soa.q[j], soa.wl[j], soa.c2[j], soa.s2[j]);
            let mut vx = [z; LANES];
            let mut vz = [z; LANES];
            let mut v2 = [z; LANES];
            for l in 0..LANES {
                vx[l] = fma(omega[l], s * n0[l] - q * u0[l], vhx[l]);
                vz[l] = fma(omega[l], s * n1[l] - q * u1[l], vhz[l]);
                v2[l] = fma(vx[l], vx[l], vz[l] * vz[l]);
            }
            let inv = if RSQRT {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `RSQRT` is set only in `profile_avx512`, compiled for AVX-512F and
                // called where the processor has it.
                unsafe {
                    T::inv_sqrt_avx512(&v2)
                }
                #[cfg(not(target_arch = "x86_64"))]
                v2.map(Real::inv_sqrt_or_zero)
            } else {
                v2.map(Real::inv_sqrt_or_zero)
            };
            for l in 0..LANES {
                let p0 = fma(s, u0[l], q * n0[l]);
                let p1 = fma(s, u1[l], q * n1[l]);
                let d = -(h[l] + p1);
                // The motion's direction `(x, -sg)`; the tangent's twice-angle `(c2e, sm)`.
                let x = vx[l] * inv[l];
                let sg = -(vz[l] * inv[l]);
                let c2e = c2 * c2b[l] - s2 * s2b[l];
                let sm = fma(c2, s2b[l], s2 * c2b[l]);
                let az = fma(
                    b01,
                    sg,
                    fma(b_sum, c2e * sg, fma(b_diff, sm * x, fma(a10, c2e, a00))),
                );
                let ax = fma(
                    d10,
                    sm,
                    fma(c01, x, fma(c_diff, sm * sg, c_sum * (c2e * x))),
                );
                let kk = if d > z && inv[l] > z { d * wl } else { z };
                drag[l] = fma(ax, kk, drag[l]);
                lift[l] = fma(az, kk, lift[l]);
                torque[l] = torque[l] - fma(p1, ax, p0 * az) * kk;
            }
        }
    }
    [
        drag.map(T::to_f64),
        lift.map(T::to_f64),
        torque.map(T::to_f64),
    ]
}

/// `from[first..first + m]` as `f64` lanes, `pad` past them (in registers: a whole block is
/// one load of known size).
#[inline(always)]
fn read<T: Real>(from: &[T], first: usize, m: usize, pad: f64) -> [f64; LANES] {
    read_as(from, first, m, T::of(pad)).map(T::to_f64)
}

/// Up to [`LANES`] legs' inputs, checked finite, as `f64`; past the legs, one pointing up.
struct Block {
    /// The attack angle with the pitch, wrapped to `[0, 2pi)`.
    beta: [f64; LANES],
    /// As given, and the pitch.
    beta_given: [f64; LANES],
    pitch: [f64; LANES],
    h: [f64; LANES],
    omega: [f64; LANES],
    forward: [f64; LANES],
    up: [f64; LANES],
}

impl Block {
    /// A block past every leg: pointing up, out of the medium.
    fn new() -> Block {
        Block {
            beta: [4.0; LANES],
            beta_given: [4.0; LANES],
            pitch: [0.0; LANES],
            h: [0.0; LANES],
            omega: [0.0; LANES],
            forward: [0.0; LANES],
            up: [0.0; LANES],
        }
    }

    /// Reads legs `first..first + m` of `legs` into the block (the lanes past `m` as
    /// [`Block::new`]'s); a non-finite input is an error naming its leg.
    #[inline(always)]
    fn gather<T: Real>(
        &mut self,
        legs: &Legs<'_, T>,
        first: usize,
        m: usize,
    ) -> Result<(), LegError> {
        // Read, and checked all at once: `0 x` is 0 for a number and NaN for anything else,
        // and so is their sum (a loop without a branch). Each lane's values are made in
        // registers and stored once (a store of other widths before a wide load stalls it).
        let beta_given = read(legs.beta_rad, first, m, 4.0);
        let h = read(legs.hip_height_m, first, m, 0.0);
        let mut check: [f64; LANES] = std::array::from_fn(|l| beta_given[l] * 0.0 + h[l] * 0.0);
        let mut other = |from: Option<&[T]>| match from {
            Some(from) => {
                let x = read(from, first, m, 0.0);
                for (c, x) in check.iter_mut().zip(&x) {
                    *c += x * 0.0;
                }
                x
            }
            None => [0.0; LANES],
        };
        let pitch = other(legs.pitch_rad);
        let omega = other(legs.omega_rad_s);
        let forward = other(legs.forward_m_s);
        let up = other(legs.up_m_s);
        (self.beta_given, self.h, self.pitch) = (beta_given, h, pitch);
        (self.omega, self.forward, self.up) = (omega, forward, up);
        let finite = check.iter().fold(true, |a, c| a & (*c == 0.0));
        if !finite {
            return Err(Block::first_not_finite(legs, first, m));
        }
        // Added in the lanes; an angle beyond a turn wrapped by a call of its own (where it
        // is inlined, the lanes compute every branch of `wrap_beta_rad`, its `fmod` too).
        let mut turned = false;
        for l in 0..LANES {
            let b = beta_given[l] + pitch[l];
            self.beta[l] = b;
            turned |= !(0.0..std::f64::consts::TAU).contains(&b);
        }
        if turned {
            wrap_lanes(&mut self.beta[..m]);
        }
        Ok(())
    }

    /// The error of the first non-finite input among legs `first..first + m`.
    #[cold]
    fn first_not_finite<T: Real>(legs: &Legs<'_, T>, first: usize, m: usize) -> LegError {
        let at = |o: Option<&[T]>, i: usize| o.map_or(0.0, |v| v[i].to_f64());
        for i in first..first + m {
            for (name, v) in [
                ("attack angle beta (rad)", legs.beta_rad[i].to_f64()),
                ("hip height (m)", legs.hip_height_m[i].to_f64()),
                ("pitch (rad)", at(legs.pitch_rad, i)),
                ("leg rate omega (rad/s)", at(legs.omega_rad_s, i)),
                ("hip forward velocity (m/s)", at(legs.forward_m_s, i)),
                ("hip up velocity (m/s)", at(legs.up_m_s, i)),
            ] {
                if let Err(e) = super::finite(name, v) {
                    return LegError {
                        index: i,
                        problem: e.into(),
                    };
                }
            }
        }
        unreachable!("a value was not finite")
    }

    /// Lane `l`'s hip, its pitch already in [`Block::beta`].
    fn hip(&self, l: usize) -> HipMotion {
        HipMotion {
            pitch_rad: 0.0,
            ..self.hip_given(l)
        }
    }

    /// Lane `l`'s hip as given, for [`ForceModel::predict_moving`] with the angle given.
    fn hip_given(&self, l: usize) -> HipMotion {
        HipMotion {
            height_m: self.h[l],
            pitch_rad: self.pitch[l],
            omega_rad_s: self.omega[l],
            forward_m_s: self.forward[l],
            up_m_s: self.up[l],
            forward_position_m: 0.0,
            lateral_m_s: 0.0,
        }
    }
}

/// Buffers a batch reuses from leg to leg.
#[derive(Debug)]
struct Scratch<T> {
    /// A plate leg's elements.
    plate: Soa<T>,
    /// Each element's stressed depth, where a depth law applies.
    depth: Vec<T>,
}

impl<T> Default for Scratch<T> {
    fn default() -> Self {
        Scratch {
            plate: Soa::empty(),
            depth: Vec::new(),
        }
    }
}

/// A leg's pose and motion as the element loop reads it.
#[derive(Debug, Clone, Copy)]
struct Frame {
    h: f64,
    /// The chord's direction `u`, the travel `n`, `cos 2 beta`, `sin 2 beta`.
    u: (f64, f64),
    n: (f64, f64),
    c2b: f64,
    s2b: f64,
    omega: f64,
    v_hip: (f64, f64),
}

impl Frame {
    /// `None` where the speeds are out of the range whose squares the type holds.
    fn new<T: Real>(
        (sin_b, cos_b): (f64, f64),
        h: f64,
        hip: &HipMotion,
        reach_m: f64,
    ) -> Option<Frame> {
        let [vx, vz] = hip.leg_frame_velocity_m_s();
        // A leg that neither turns nor moves is evaluated as turning forward (quasi-static).
        let still = hip.omega_rad_s == 0.0 && vx == 0.0 && vz == 0.0;
        let (omega, v_hip) = if still {
            (1.0, (0.0, 0.0))
        } else {
            (hip.omega_rad_s, (vx, vz))
        };
        let scale = omega.abs() * reach_m + v_hip.0.abs() + v_hip.1.abs();
        if !(scale <= T::MAX_SPEED_SCALE && scale >= T::MIN_SPEED_SCALE) {
            return None;
        }
        Some(Frame {
            h,
            u: (-cos_b, -sin_b),
            n: (sin_b, -cos_b),
            c2b: cos_b * cos_b - sin_b * sin_b,
            s2b: 2.0 * sin_b * cos_b,
            omega,
            v_hip,
        })
    }
}

/// The forces of `soa`'s elements for a leg in `frame`: drag, lift, hip torque.
fn sum<T: Real>(
    soa: &Soa<T>,
    fit: &Fit,
    frame: &Frame,
    depth_law: Option<&super::RftDepthLaw>,
    scratch: &mut Scratch<T>,
    isa: Isa,
) -> [f64; 3] {
    let t = |x: f64| T::of(x);
    let (u0, u1, n0, n1, h) = (
        t(frame.u.0),
        t(frame.u.1),
        t(frame.n.0),
        t(frame.n.1),
        t(frame.h),
    );
    // A depth law's power, once per element below the surface, before the vector loop:
    // sixteen at a time in the lanes (the columns are padded to whole lanes).
    let depth = depth_law.map(|law| {
        scratch.depth.clear();
        for (s, q) in soa.s.chunks_exact(LANES).zip(soa.q.chunks_exact(LANES)) {
            let d: [T; LANES] = std::array::from_fn(|l| -(h + (s[l] * u1 + q[l] * n1)));
            if !d.iter().any(|&d| d > T::ZERO) {
                scratch.depth.extend([T::ZERO; LANES]);
                continue;
            }
            // A lane above the surface takes 1 cm, then zero.
            let x = d.map(|d| if d > T::ZERO { d.to_f64() } else { 0.01 });
            let p = law.effective_depths_m(&x);
            scratch
                .depth
                .extend((0..LANES).map(|l| if d[l] > T::ZERO { T::of(p[l]) } else { T::ZERO }));
        }
        scratch.depth.as_slice()
    });
    let c = Consts {
        u0,
        u1,
        n0,
        n1,
        h,
        c2b: t(frame.c2b),
        s2b: t(frame.s2b),
        omega: t(frame.omega),
        vhx: t(frame.v_hip.0),
        vhz: t(frame.v_hip.1),
        a00: t(fit.a00),
        a10: t(fit.a10),
        b_diff: t(fit.b_diff),
        b_sum: t(fit.b_sum),
        b01: t(fit.b01),
        c_sum: t(fit.c_sum),
        c_diff: t(fit.c_diff),
        c01: t(fit.c01),
        d10: t(fit.d10),
    };
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the processor has the features the function is compiled for.
        Isa::Avx512 => unsafe { sum_avx512(soa, depth, &c, frame.h) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        Isa::Avx2 => unsafe { sum_avx2(soa, depth, &c, frame.h) },
        _ => sum_lanes::<T, false, false>(soa, depth, &c, frame.h),
    }
}

/// Which of the element loop's compilations the processor runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Isa {
    /// AVX-512F: sixteen lanes in one or two registers, fused multiply-adds, and the reciprocal
    /// square root estimate refined by Newton's steps.
    Avx512,
    /// AVX2 and FMA: fused multiply-adds, the exact square root and division.
    Avx2,
    /// The target's baseline (SSE2 on x86-64): the exact operations of
    /// [`super::RftModel::evaluate_moving`], not fused.
    Baseline,
}

impl Isa {
    /// The fastest this processor runs.
    pub fn detected() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            // Every processor with AVX2 counts bits in one instruction (popcnt).
            if !std::arch::is_x86_feature_detected!("popcnt") {
                return Isa::Baseline;
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                return Isa::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                return Isa::Avx2;
            }
        }
        Isa::Baseline
    }
}

/// A leg's constants in the loop's type.
struct Consts<T> {
    u0: T,
    u1: T,
    n0: T,
    n1: T,
    h: T,
    c2b: T,
    s2b: T,
    omega: T,
    vhx: T,
    vhz: T,
    a00: T,
    a10: T,
    b_diff: T,
    b_sum: T,
    b01: T,
    c_sum: T,
    c_diff: T,
    c01: T,
    d10: T,
}

compiled_for! {
    /// [`sum_lanes`] compiled for the processor's instructions (`RSQRT`: AVX-512's estimate).
    fn sum_avx512 / sum_avx2 <T: Real>(
        soa: &Soa<T>,
        depth: Option<&[T]>,
        c: &Consts<T>,
        h: f64,
    ) -> [f64; 3] {
        sum_lanes::<T, true, RSQRT>(soa, depth, c, h)
    }
}

/// The element loop, [`LANES`] elements at a time, each lane its own sums (so that it needs
/// no reassociation to run in vector registers, and gives the same sums whatever the
/// register's width). `FMA`: fuse multiply-adds; `RSQRT`: the AVX-512 reciprocal square root
/// (both only where the caller is compiled for them).
///
/// Per element, as [`super::RftModel::evaluate_moving`]: its point `p = s u + q n`, depth
/// `-(h + p_z)`, velocity `omega (s n - q u) + v_hip`, and RFT's stresses at its tangent's
/// angle and its motion's. The mirror of a motion toward -x cancels out of the forces (it
/// multiplies `alpha_x` and the drag it gives, and both of the mixed terms of `alpha_z`),
/// so the loop has no branch. A block of elements whose circle lies above the surface is
/// skipped (its elements would add zeros).
#[inline(always)]
fn sum_lanes<T: Real, const FMA: bool, const RSQRT: bool>(
    soa: &Soa<T>,
    depth: Option<&[T]>,
    c: &Consts<T>,
    h: f64,
) -> [f64; 3] {
    // a b + d
    let fma = |a: T, b: T, d: T| if FMA { a.mul_add(b, d) } else { a * b + d };
    let mut drag = [T::ZERO; LANES];
    let mut lift = [T::ZERO; LANES];
    let mut torque = [T::ZERO; LANES];
    let z = T::ZERO;
    let (u1, n1) = (c.u1.to_f64(), c.n1.to_f64());
    for (b, &[bs, bq, br]) in soa.blocks.iter().enumerate() {
        if -(h + (bs * u1 + bq * n1)) + br <= 0.0 {
            continue;
        }
        let start = b * LANES;
        let s = &soa.s[start..start + LANES];
        let q = &soa.q[start..start + LANES];
        let wl = &soa.wl[start..start + LANES];
        let c2 = &soa.c2[start..start + LANES];
        let s2 = &soa.s2[start..start + LANES];
        let dl = depth.map(|d| &d[start..start + LANES]);
        let mut vx = [z; LANES];
        let mut vz = [z; LANES];
        let mut v2 = [z; LANES];
        for l in 0..LANES {
            let (s, q) = (s[l], q[l]);
            vx[l] = fma(c.omega, s * c.n0 - q * c.u0, c.vhx);
            vz[l] = fma(c.omega, s * c.n1 - q * c.u1, c.vhz);
            v2[l] = fma(vx[l], vx[l], vz[l] * vz[l]);
        }
        let inv = if RSQRT {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `RSQRT` is set only in `sum_avx512`, compiled for AVX-512F and called
            // where the processor has it.
            unsafe {
                T::inv_sqrt_avx512(&v2)
            }
            #[cfg(not(target_arch = "x86_64"))]
            v2.map(Real::inv_sqrt_or_zero)
        } else {
            v2.map(Real::inv_sqrt_or_zero)
        };
        for l in 0..LANES {
            let (s, q) = (s[l], q[l]);
            let p0 = fma(s, c.u0, q * c.n0);
            let p1 = fma(s, c.u1, q * c.n1);
            let d = -(c.h + p1);
            // The motion's direction `(x, -sg)`; the tangent's twice-angle `(c2e, sm)`.
            let x = vx[l] * inv[l];
            let sg = -(vz[l] * inv[l]);
            let c2e = c2[l] * c.c2b - s2[l] * c.s2b;
            let sm = fma(c2[l], c.s2b, s2[l] * c.c2b);
            let az = fma(
                c.b01,
                sg,
                fma(
                    c.b_sum,
                    c2e * sg,
                    fma(c.b_diff, sm * x, fma(c.a10, c2e, c.a00)),
                ),
            );
            let ax = fma(
                c.d10,
                sm,
                fma(c.c01, x, fma(c.c_diff, sm * sg, c.c_sum * (c2e * x))),
            );
            let stressed = match dl {
                Some(dl) => dl[l],
                None => d,
            };
            let k = if d > z && inv[l] > z {
                stressed * wl[l]
            } else {
                z
            };
            drag[l] = fma(ax, k, drag[l]);
            lift[l] = fma(az, k, lift[l]);
            torque[l] = torque[l] - fma(p1, ax, p0 * az) * k;
        }
    }
    let total = |a: &[T; LANES]| a.iter().fold(0.0, |acc, v| acc + v.to_f64());
    [total(&drag), total(&lift), total(&torque)]
}

/// A Terzaghi model's numbers in the batch's type, as [`improved_lanes`] reads them (each
/// product of constants formed in `f64` first, as the model forms it).
struct LaneConsts<T> {
    lambda: T,
    k: T,
    theta_end: T,
    cos_phi: T,
    sin_alpha: T,
    cos_alpha: T,
    k_p: T,
    inv_spiral_den: T,
    inv_4k: T,
    tan_delta: T,
    /// `3 k`, and `3 k cos alpha - sin alpha`.
    three_k: T,
    sf_tail: T,
    length_m: T,
    /// The model's own `ln a` and `width b_k` (m).
    ln_a: T,
    width_b_k_m: T,
    /// The largest `|x|` the lanes' `exp` takes.
    reach: T,
    pi: T,
    tau: T,
}

impl<T: Real> LaneConsts<T> {
    fn of(imp: &Improved) -> LaneConsts<T> {
        let c = &imp.c;
        let t = T::of;
        LaneConsts {
            lambda: t(c.lambda),
            k: t(c.k),
            theta_end: t(c.theta_end),
            cos_phi: t(c.cos_phi),
            sin_alpha: t(c.sin_alpha),
            cos_alpha: t(c.cos_alpha),
            k_p: t(c.k_p),
            inv_spiral_den: t(c.inv_spiral_den),
            inv_4k: t(c.inv_4k),
            tan_delta: t(c.tan_delta),
            three_k: t(3.0 * c.k),
            sf_tail: t(3.0 * c.k * c.cos_alpha - c.sin_alpha),
            length_m: t(imp.length_m),
            ln_a: t(imp.ln_a),
            width_b_k_m: t(imp.width_b_k_m),
            reach: t(T::EXP_REACH),
            pi: t(std::f64::consts::PI),
            tau: t(std::f64::consts::TAU),
        }
    }
}

/// `from[first..first + m]` as lanes of its type, `pad` past them.
#[inline(always)]
fn read_as<T: Real>(from: &[T], first: usize, m: usize, pad: T) -> [T; LANES] {
    if let Ok(whole) = <&[T; LANES]>::try_from(&from[first..first + m]) {
        // A whole block: one load of known size, in registers (a copy of unknown size is a
        // call, and its stores stall the loads that follow).
        return *whole;
    }
    let mut x = [pad; LANES];
    x[..m].copy_from_slice(&from[first..first + m]);
    x
}

/// Wraps the angles beyond a turn (in `f64`, as [`wrap_beta_rad`]).
#[cold]
#[inline(never)]
fn wrap_lanes<T: Real>(beta: &mut [T]) {
    for b in beta {
        *b = T::of(wrap_beta_rad(b.to_f64()));
    }
}

/// Forces of a Terzaghi model, each lane one leg, in the batch's type: `beta` wrapped to
/// `[0, 2pi)` with the pitch, `h` the hip's height (>= 0), each lane's `ln a` and `width b_k`
/// (m). Drag, lift and torque per lane, and which lanes [`LegKernel::terzaghi_packed`] must
/// evaluate one by one. The expressions are [`super::TerzaghiModel::evaluate_at_height`]'s, in
/// its order, with every branch taken and the answer chosen (in `f64`, its very operations).
#[inline(always)]
fn improved_lanes<T: Real>(
    c: &LaneConsts<T>,
    ln_a: &[T; LANES],
    width_b_k_m: &[T; LANES],
    beta: &[T; LANES],
    h: &[T; LANES],
    f: &mut [[T; LANES]; 3],
    scalar: &mut [bool; LANES],
) {
    let (z, one, t) = (T::ZERO, T::of(1.0), T::of);
    let (quarter, half, minus_half) = (t(0.25), t(0.5), t(-0.5));
    let (two_thirds, minus_two_thirds) = (t(2.0 / 3.0), t(-2.0 / 3.0));
    let thin_below = t(1e-3);
    let (sin, cos) = T::sin_cos_lanes(beta);
    let mut x_width = [z; LANES];
    let mut x_spiral = [z; LANES];
    for l in 0..LANES {
        x_width[l] = -beta[l] * ln_a[l];
        x_spiral[l] = (c.theta_end - beta[l]) * c.k;
    }
    let e_width = T::exp_lanes(&x_width);
    let e_spiral = T::exp_lanes(&x_spiral);
    for l in 0..LANES {
        let b = beta[l];
        let pointing_down = b <= c.pi;
        let sin_b = if pointing_down { sin[l] } else { z };
        let cos_b = if pointing_down { cos[l] } else { one };
        let l_s = if sin_b <= z {
            z
        } else {
            let v = c.length_m - h[l] / sin_b;
            if v > z { v } else { z }
        };
        let w = width_b_k_m[l] * e_width[l] * c.lambda;
        let theta = c.theta_end - b;
        let d_perp = two_thirds * l_s;
        let spiral = theta > z;
        let e1 = e_spiral[l];
        let r_b = l_s * e1;
        let e2_m1 = e1 * e1 - one;
        let g_lg = w * l_s * l_s * e2_m1 * c.inv_4k;
        let sf = sin_b + c.three_k * cos_b + e1 * e1 * e1 * c.sf_tail;
        let moment_lg = w * l_s * l_s * l_s * sf * c.inv_spiral_den;
        let rs = r_b * c.sin_alpha;
        let ls = l_s * sin_b;
        let (g_t, d_tg, f_l, d_l) = if spiral {
            (
                quarter * w * r_b * r_b * c.cos_phi,
                two_thirds * r_b * c.cos_alpha,
                half * w * (rs * rs) * c.k_p,
                two_thirds * r_b * c.sin_alpha,
            )
        } else {
            (
                minus_half * w * l_s * l_s * sin_b * cos_b,
                minus_two_thirds * l_s * cos_b,
                half * w * (ls * ls) * c.k_p,
                two_thirds * l_s * sin_b,
            )
        };
        let m_lg = if spiral && g_lg > z { moment_lg } else { z };
        let moment = g_t * d_tg + f_l * d_l + m_lg;
        let normal = moment / d_perp;
        let tangential = normal * c.tan_delta;
        let drag = normal * sin_b - tangential * cos_b;
        let lift = normal * cos_b + tangential * sin_b;
        let torque = normal * (c.length_m - l_s + d_perp);
        let in_medium = l_s > z;
        f[0][l] = if in_medium { drag } else { z };
        f[1][l] = if in_medium { lift } else { z };
        f[2][l] = if in_medium { torque } else { z };
        let thin = spiral && x_spiral[l] < thin_below;
        let beyond = |x: T| x > c.reach || -x > c.reach;
        let far = beyond(x_width[l]) || beyond(x_spiral[l]);
        let bad = !(drag.finite() && lift.finite() && torque.finite());
        scalar[l] = in_medium && (thin || far || bad);
    }
}

compiled_for! {
    /// [`improved_lanes`] compiled for the processor's instructions.
    fn improved_avx512 / improved_avx2 <T: Real>(
        c: &LaneConsts<T>,
        ln_a: &[T; LANES],
        width_b_k_m: &[T; LANES],
        beta: &[T; LANES],
        h: &[T; LANES],
        f: &mut [[T; LANES]; 3],
        scalar: &mut [bool; LANES],
    ) -> () {
        improved_lanes(c, ln_a, width_b_k_m, beta, h, f, scalar)
    }
}

#[cfg(test)]
mod tests {

    /// The depth law's power in the lanes is libm's to `|exponent ln x| + 4` units in the last
    /// place over the depths a body meets (0.1 um to 10 m, over 1 cm) and the exponents a
    /// medium file allows,
    /// and libm's itself for a lane the lanes do not take (zero, subnormal, negative, infinite,
    /// NaN, or a power beyond the lanes' reach).
    #[test]
    fn the_power_in_lanes_is_libm_s_to_a_few_units() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let mut worst = 0.0f64;
        for _ in 0..20_000 {
            let exponent = rng.random_range(0.05..5.0);
            let x: [f64; LANES] = std::array::from_fn(|_| 10f64.powf(rng.random_range(-5.0..3.0)));
            let p = powf_lanes(&x, exponent);
            for l in 0..LANES {
                let want = x[l].powf(exponent);
                // The product's rounding grows with its size: |exponent ln x| + 4 units.
                let units = (p[l] - want).abs() / (want * f64::EPSILON);
                worst = worst.max(units / ((exponent * x[l].ln()).abs() + 4.0));
            }
        }
        assert!(worst <= 1.0, "{worst} of the bound");
        let odd = [0.0, 1e-310, f64::INFINITY, f64::NAN, 1e300, -2.0];
        let x: [f64; LANES] = std::array::from_fn(|l| odd[l % odd.len()]);
        let p = powf_lanes(&x, 3.0);
        for l in 0..LANES {
            let want = x[l].powf(3.0);
            assert!(
                p[l] == want || (p[l].is_nan() && want.is_nan()),
                "{} {}",
                x[l],
                p[l]
            );
        }
    }
    use super::*;
    use crate::model::TerzaghiModel;
    use crate::model::{
        Medium, Plate, RftCoefficients, RftDepthLaw, RftFit, RftModel, c_leg_profile,
    };
    use std::f64::consts::PI;

    fn models() -> Vec<(&'static str, ForceModel)> {
        let plate = Plate::new(0.1, 0.025, 0.0).unwrap();
        let c = RftCoefficients::Fit(RftFit::POPPY_LP);
        let law = RftDepthLaw::new(1.7, 0.8)
            .unwrap()
            .with_offset(0.002)
            .unwrap();
        vec![
            (
                "rft plate",
                ForceModel::Rft(RftModel::new(plate, c.clone(), 100).unwrap()),
            ),
            (
                "rft plate, law in depth",
                ForceModel::Rft(
                    RftModel::new(plate, c.clone(), 100)
                        .unwrap()
                        .with_depth_law(Some(law)),
                ),
            ),
            (
                "c-leg",
                ForceModel::Rft(
                    RftModel::with_profile(plate, c.clone(), 96, c_leg_profile(0.05, PI, 16))
                        .unwrap(),
                ),
            ),
            (
                "c-leg, law in depth",
                ForceModel::Rft(
                    RftModel::with_profile(plate, c, 96, c_leg_profile(0.05, PI, 16))
                        .unwrap()
                        .with_depth_law(Some(law)),
                ),
            ),
            (
                "improved",
                ForceModel::Terzaghi(TerzaghiModel::new(
                    plate,
                    Medium::new(13000.0, 30.0, 20.0).unwrap(),
                    FittingWidth::new(30.0, 2.3).unwrap(),
                )),
            ),
            (
                "conventional",
                ForceModel::Terzaghi(TerzaghiModel::conventional(
                    plate,
                    Medium::new(16170.0, 30.0, 19.0).unwrap(),
                )),
            ),
        ]
    }

    /// A grid of legs: angles over two turns, hips from below the surface to above the reach,
    /// still and moving every way.
    fn legs() -> Vec<[f64; 6]> {
        let mut v = Vec::new();
        // Over two turns, and where the improved model's spiral vanishes (phi 30 deg: at
        // 150 deg), on either side of where its lanes hand a leg to the scalar path.
        let spiral_end = 150f64.to_radians();
        let betas = (0..73)
            .map(|i| -PI + i as f64 * 0.17)
            .chain([-2e-3, -5e-4, -1e-6, 0.0, 1e-6].map(|d| spiral_end + d));
        for beta in betas {
            for h in [-0.01, 0.0, 0.02, 0.05, 0.12] {
                for (pitch, omega, fwd, up) in [
                    (0.0, 0.0, 0.0, 0.0),
                    (0.1, 4.0, 0.0, 0.0),
                    (0.0, -3.0, 0.0, 0.0),
                    (-0.05, 2.0, 0.3, -0.05),
                    (0.0, 0.0, -0.2, 0.1),
                    (0.0, 1e-120, 0.0, 0.0),
                ] {
                    v.push([beta, h, pitch, omega, fwd, up]);
                }
            }
        }
        v
    }

    #[test]
    fn a_value_that_is_no_number_is_named_with_its_leg() {
        let n = 40;
        let (beta, hip, still) = (vec![0.6; n], vec![0.01; n], vec![0.0; n]);
        let mut omega = vec![2.0; n];
        omega[37] = f64::INFINITY;
        let mut up = vec![0.0; n];
        up[3] = f64::NAN;
        for (name, model) in models() {
            let kernel = LegKernel::new(model);
            for (omega, up, index, what) in [
                (&omega, &still, 37, "leg rate omega"),
                (&still, &up, 3, "hip up velocity"),
            ] {
                let legs = Legs {
                    beta_rad: &beta,
                    hip_height_m: &hip,
                    pitch_rad: None,
                    omega_rad_s: Some(omega),
                    forward_m_s: None,
                    up_m_s: Some(up),
                    b_k: None,
                    a: None,
                };
                let (mut d, mut l, mut t) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                let e = kernel
                    .forces(
                        &legs,
                        0,
                        LegForcesOut {
                            drag_n: &mut d,
                            lift_n: &mut l,
                            hip_torque_nm: &mut t,
                        },
                    )
                    .unwrap_err();
                assert_eq!(e.index, index, "{name}");
                assert!(e.to_string().contains(what), "{name}: {e}");
            }
        }
    }

    /// The lanes' `atan2` is libm's to three units in the last place in the right half plane
    /// (the torso's pitch of the MuJoCo coupling), and libm's own elsewhere.
    #[test]
    fn the_lanes_atan2_is_libm_s() {
        let mut worst = 0.0f64;
        for i in 0..20_000 {
            let u = |l: usize| (i * LANES + l) as f64 / (20_000 * LANES) as f64;
            let y: [f64; LANES] =
                std::array::from_fn(|l| (u(l) * 40.0 - 20.0).exp2() * (u(l) - 0.5));
            let x: [f64; LANES] = std::array::from_fn(|l| match (i + l) % 7 {
                0 => -1.0 + u(l),
                1 => 0.0,
                _ => (u(l) * 60.0 - 30.0).exp2(),
            });
            let got = atan2_lanes(&y, &x);
            for l in 0..LANES {
                let want = y[l].atan2(x[l]);
                if x[l] > 0.0 {
                    let spacing = f64::EPSILON * want.abs().max(f64::MIN_POSITIVE);
                    worst = worst.max((got[l] - want).abs() / spacing);
                } else {
                    assert_eq!(
                        got[l].to_bits(),
                        want.to_bits(),
                        "atan2({}, {})",
                        y[l],
                        x[l]
                    );
                }
            }
        }
        assert!(worst <= 3.0, "atan2 off by {worst} ulp");
    }

    /// Packing a block's marked lanes to the front and expanding them back puts every marked
    /// lane where it was and zero elsewhere, on every instruction set and in both types, for
    /// every one of the 65,536 marks.
    #[test]
    fn every_packing_of_a_block_unpacks_to_its_own_lanes() {
        fn check<T: Real + std::fmt::Debug>() {
            let src: [T; LANES] = std::array::from_fn(|l| T::of(l as f64 + 1.0));
            for isa in [Isa::Baseline, Isa::Avx2, Isa::Avx512] {
                if LegKernel::new(ForceModel::Terzaghi(TerzaghiModel::conventional(
                    Plate::new(0.1, 0.025, 0.0).unwrap(),
                    Medium::new(16170.0, 30.0, 19.0).unwrap(),
                )))
                .on(isa)
                .is_none()
                {
                    continue;
                }
                for bits in 0..=u16::MAX {
                    let mut packed = [T::ZERO; LANES];
                    compress(isa, bits, &src, &mut packed);
                    let n = bits.count_ones() as usize;
                    let marked: Vec<T> = (0..LANES)
                        .filter(|l| bits >> l & 1 == 1)
                        .map(|l| src[l])
                        .collect();
                    assert_eq!(&packed[..n], &marked[..], "{isa:?} packed {bits:#06x}");
                    let back = expand(isa, bits, &packed);
                    for l in 0..LANES {
                        let want = if bits >> l & 1 == 1 { src[l] } else { T::ZERO };
                        assert_eq!(back[l], want, "{isa:?} lane {l} of {bits:#06x}");
                    }
                }
            }
        }
        check::<f64>();
        check::<f32>();
    }

    /// The improved model packs the legs that may touch the medium into its lanes: a leg left
    /// out is still checked, and one packed is still named by its own index.
    #[test]
    fn packed_legs_keep_their_names() {
        let n = 40;
        // Every third leg points up, out of the medium; the rest are in it.
        let beta: Vec<f32> = (0..n).map(|i| if i % 3 == 0 { 4.0 } else { 1.0 }).collect();
        let hip = vec![0.02f32; n];
        let mut b_k = vec![30.0f32; n];
        let mut a = vec![2.3f32; n];
        let ForceModel::Terzaghi(model) = models()
            .into_iter()
            .find(|(name, _)| *name == "improved")
            .expect("the improved model")
            .1
        else {
            unreachable!()
        };
        let run = |b_k: &[f32], a: &[f32], first: usize| {
            let m = n - first;
            let (mut d, mut l, mut t) = (vec![0.0f32; m], vec![0.0f32; m], vec![0.0f32; m]);
            let r = LegKernel::new(ForceModel::Terzaghi(model.clone())).forces(
                &Legs {
                    beta_rad: &beta,
                    hip_height_m: &hip,
                    pitch_rad: None,
                    omega_rad_s: None,
                    forward_m_s: None,
                    up_m_s: None,
                    b_k: Some(b_k),
                    a: Some(a),
                },
                first,
                LegForcesOut {
                    drag_n: &mut d,
                    lift_n: &mut l,
                    hip_torque_nm: &mut t,
                },
            );
            (r, d)
        };
        let (ok, d) = run(&b_k, &a, 0);
        ok.unwrap();
        assert!((0..n).all(|i| (d[i] == 0.0) == (i % 3 == 0)), "{d:?}");
        // A width that is no width, on a leg out of the medium.
        a[21] = -1.0;
        let e = run(&b_k, &a, 0).0.unwrap_err();
        assert_eq!(e.index, 21, "{e}");
        assert!(e.to_string().contains("a"), "{e}");
        a[21] = 2.3;
        // A force beyond float32's range, on the seventh leg packed after the first five.
        b_k[23] = 3e38;
        for first in [0, 5] {
            let e = run(&b_k, &a, first).0.unwrap_err();
            assert_eq!(e.index, 23, "{e}");
            assert!(matches!(e.problem, LegProblem::Overflow { .. }), "{e}");
        }
    }

    /// A hip moving at 1e-157 m/s with a leg turning: an RFT plate's padding element, at the
    /// hip, moves at the hip's speed, whose square is below the smallest normal number. The
    /// AVX-512 estimate read it as zero and gave NaN for every force (fuzz/regressions).
    #[test]
    fn a_speed_whose_square_is_subnormal_gives_the_baselines_forces() {
        let leg = [
            -4.0854,
            0.0567,
            -0.2427,
            -5.0201,
            8.306_867e-158,
            5.284_598_565_89e-312,
        ];
        let cols: Vec<Vec<f64>> = leg.iter().map(|v| vec![*v; 3]).collect();
        let input = Legs::moving(std::array::from_fn(|k| &cols[k][..]));
        for (name, model) in models() {
            let run = |isa: Isa| {
                let kernel = LegKernel::new(model.clone()).on(isa)?;
                let (mut d, mut l, mut t) = (vec![0.0; 3], vec![0.0; 3], vec![0.0; 3]);
                let out = LegForcesOut {
                    drag_n: &mut d,
                    lift_n: &mut l,
                    hip_torque_nm: &mut t,
                };
                kernel.forces(&input, 0, out).unwrap();
                Some([d[2], l[2], t[2]])
            };
            let want = run(Isa::Baseline).unwrap();
            assert!(want[1] != 0.0, "{name}: in the medium");
            for isa in [Isa::Avx2, Isa::Avx512] {
                if let Some(got) = run(isa) {
                    for (g, w) in got.iter().zip(want) {
                        assert!(
                            (g - w).abs() <= 1e-12,
                            "{name} on {isa:?}: {got:?}, {want:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn sines_of_angles_beyond_the_lanes_reach_are_libm_s() {
        let mut x = [0.5; LANES];
        x[2] = 3.0e6;
        x[7] = -1.0e9;
        x[9] = f64::NAN;
        let (s, c) = sin_cos_lanes(&x);
        for l in [2, 7] {
            assert_eq!((s[l], c[l]), x[l].sin_cos(), "lane {l}");
        }
        assert!((s[0] - 0.5f64.sin()).abs() < 1e-15 && (c[0] - 0.5f64.cos()).abs() < 1e-15);
        assert!(s[9].is_nan() && c[9].is_nan());
    }

    #[test]
    fn a_fitting_width_per_leg_gives_each_leg_its_own_models_forces() {
        let legs = legs();
        let n = legs.len();
        let col = |k: usize| legs.iter().map(|l| l[k]).collect::<Vec<f64>>();
        let cols: Vec<Vec<f64>> = (0..3).map(col).collect();
        // Six legs per environment share a medium, as a batch of robots does; a few legs take
        // a spiral thin enough for the scalar path, with their own width.
        let b_k: Vec<f64> = (0..n).map(|i| 5.0 + (i / 6 % 17) as f64 * 3.0).collect();
        let a: Vec<f64> = (0..n).map(|i| 1.1 + (i / 6 % 13) as f64 * 0.15).collect();
        let input = Legs {
            beta_rad: &cols[0],
            hip_height_m: &cols[1],
            pitch_rad: Some(&cols[2]),
            omega_rad_s: None,
            forward_m_s: None,
            up_m_s: None,
            b_k: Some(&b_k),
            a: Some(&a),
        };
        let ForceModel::Terzaghi(model) = models()
            .into_iter()
            .find(|(name, _)| *name == "improved")
            .expect("the improved model")
            .1
        else {
            unreachable!()
        };
        for isa in [Isa::Baseline, Isa::Avx2, Isa::Avx512] {
            let Some(kernel) = LegKernel::new(ForceModel::Terzaghi(model.clone())).on(isa) else {
                continue;
            };
            let (mut d, mut l, mut t) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            kernel
                .forces(
                    &input,
                    0,
                    LegForcesOut {
                        drag_n: &mut d,
                        lift_n: &mut l,
                        hip_torque_nm: &mut t,
                    },
                )
                .unwrap();
            let mut in_medium = 0;
            for (i, x) in legs.iter().enumerate() {
                let own = model.with_fitting_width(FittingWidth::new(b_k[i], a[i]).unwrap());
                let f = own.evaluate_at_height(x[0] + x[2], x[1]).unwrap();
                let scale = f.drag_n.abs().max(f.lift_n.abs()).max(1.0);
                in_medium += usize::from(f.lift_n != 0.0);
                for (k, (got, want)) in [d[i], l[i], t[i]]
                    .into_iter()
                    .zip([f.drag_n, f.lift_n, f.hip_torque_nm])
                    .enumerate()
                {
                    assert!(
                        (got - want).abs() <= 1e-13 * scale,
                        "{isa:?}, leg {i} {x:?}, b_k {} a {}, output {k}: {got} against {want}",
                        b_k[i],
                        a[i]
                    );
                }
            }
            assert!(in_medium > n / 4, "{in_medium} of {n} legs in the medium");
        }
        // A width that is no width is named with its leg.
        let mut bad = a.clone();
        bad[101] = -1.0;
        let kernel = LegKernel::new(ForceModel::Terzaghi(model));
        let (mut d, mut l, mut t) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let e = kernel
            .forces(
                &Legs {
                    a: Some(&bad),
                    ..input
                },
                0,
                LegForcesOut {
                    drag_n: &mut d,
                    lift_n: &mut l,
                    hip_torque_nm: &mut t,
                },
            )
            .unwrap_err();
        assert_eq!(e.index, 101);
        assert!(e.to_string().contains("-1"), "{e}");
    }

    #[test]
    fn a_batch_gives_each_leg_what_predict_moving_gives() {
        let legs = legs();
        let col = |k: usize| legs.iter().map(|l| l[k]).collect::<Vec<f64>>();
        let cols: Vec<Vec<f64>> = (0..6).map(col).collect();
        let input = Legs::moving(std::array::from_fn(|k| &cols[k][..]));
        let isas = [Isa::Baseline, Isa::Avx2, Isa::Avx512];
        let cases = models()
            .into_iter()
            .flat_map(|(name, m)| isas.map(|isa| (name, isa, m.clone())));
        for (name, isa, model) in cases {
            let Some(kernel) = LegKernel::new(model.clone()).on(isa) else {
                continue;
            };
            let name = format!("{name} on {isa:?}");
            assert!(kernel.is_vectorised(), "{name}");
            let n = legs.len();
            let (mut d, mut l, mut t) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            kernel
                .forces(
                    &input,
                    0,
                    LegForcesOut {
                        drag_n: &mut d,
                        lift_n: &mut l,
                        hip_torque_nm: &mut t,
                    },
                )
                .unwrap();
            let mut scale = 0.0f64;
            let want: Vec<[f64; 3]> = legs
                .iter()
                .map(|x| {
                    let hip = HipMotion {
                        height_m: x[1],
                        pitch_rad: x[2],
                        omega_rad_s: x[3],
                        forward_m_s: x[4],
                        up_m_s: x[5],
                        ..HipMotion::default()
                    };
                    let p = model.predict_moving(x[0], &hip).unwrap();
                    scale = scale.max(p.drag_n.abs()).max(p.lift_n.abs());
                    [p.drag_n, p.lift_n, p.hip_torque_nm]
                })
                .collect();
            assert!(scale > 1.0, "{name}: legs in the medium");
            for (i, w) in want.iter().enumerate() {
                for (k, (got, w)) in [d[i], l[i], t[i]].iter().zip(w).enumerate() {
                    let tol = 1e-13 * scale * if k == 2 { 0.2 } else { 1.0 };
                    assert!(
                        (got - w).abs() <= tol,
                        "{name}, leg {i} {:?}, output {k}: {got} against {w}",
                        legs[i]
                    );
                }
            }
            // f32: the same legs, to the type's precision.
            let cols32: Vec<Vec<f32>> = cols
                .iter()
                .map(|c| c.iter().map(|&v| v as f32).collect())
                .collect();
            let input32 = Legs::moving(std::array::from_fn(|k| &cols32[k][..]));
            let (mut d32, mut l32, mut t32) = (vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]);
            kernel
                .forces(
                    &input32,
                    0,
                    LegForcesOut {
                        drag_n: &mut d32,
                        lift_n: &mut l32,
                        hip_torque_nm: &mut t32,
                    },
                )
                .unwrap();
            let worst = (0..n)
                .map(|i| {
                    (d32[i] as f64 - d[i])
                        .abs()
                        .max((l32[i] as f64 - l[i]).abs())
                })
                .fold(0.0f64, f64::max);
            assert!(
                worst <= 1e-3 * scale,
                "{name}: f32 off by {worst} of {scale}"
            );
        }
    }

    /// A batch of wheels (a body), and of RFT plates moving across their plane, gives each
    /// leg's whole wrench as `predict_moving` does, side force and moments included; a planar
    /// leg moving in its plane has `forces`' values and no side force; a lateral velocity that
    /// is no number names its leg.
    #[test]
    fn wrenches_are_predict_moving_s_for_bodies_and_legs_moving_across() {
        use crate::model::body::{Body, BodyLeg};
        let wheel = ForceModel::Body(Box::new(BodyLeg::new(
            Body::wheel(0.058, 0.05, None, 360).unwrap(),
            RftCoefficients::Fit(RftFit::POPPY_LP),
            Some(RftDepthLaw::new(4.546, 1.219).unwrap()),
            None,
            Plate::new(0.058, 0.05, 0.0).unwrap(),
        )));
        let plate = models().into_iter().next().unwrap().1;
        let n = 37;
        let col = |f: &dyn Fn(f64) -> f64| -> Vec<f64> { (0..n).map(|i| f(i as f64)).collect() };
        let beta = col(&|i| 0.1 * i);
        let height = col(&|i| 0.04 - 0.0012 * i);
        let omega = col(&|i| 0.35 * (i % 5.0 - 1.0));
        let forward = col(&|i| 0.01 * (i % 3.0));
        let up = col(&|i| -0.002 * (i % 2.0));
        let lateral = col(&|i| 0.004 * (i % 7.0 - 3.0));
        let legs = Legs {
            beta_rad: &beta,
            hip_height_m: &height,
            pitch_rad: None,
            omega_rad_s: Some(&omega),
            forward_m_s: Some(&forward),
            up_m_s: Some(&up),
            b_k: None,
            a: None,
        };
        // Every output of `kernel.wrenches` (or its first three, `forces`).
        let run = |kernel: &LegKernel, lateral: Option<&[f64]>, six: bool| {
            let mut out = vec![vec![0.0f64; n]; 6];
            let [d, l, t, s, r, y] = &mut out[..] else {
                unreachable!()
            };
            let forces = LegForcesOut {
                drag_n: d,
                lift_n: l,
                hip_torque_nm: t,
            };
            let more = LegSideOut {
                side_n: s,
                roll_moment_nm: r,
                yaw_moment_nm: y,
            };
            match six {
                true => kernel.wrenches(&legs, lateral, 0, forces, more),
                false => kernel.forces(&legs, 0, forces),
            }
            .map(|()| out)
        };
        for (name, model) in [("wheel", wheel), ("rft plate", plate)] {
            let kernel = LegKernel::new(model.clone());
            let out = run(&kernel, Some(&lateral), true).unwrap();
            let mut sideways = 0;
            for i in 0..n {
                let hip = HipMotion {
                    omega_rad_s: omega[i],
                    forward_m_s: forward[i],
                    up_m_s: up[i],
                    lateral_m_s: lateral[i],
                    ..HipMotion::still(height[i])
                };
                let p = model.predict_moving(beta[i], &hip).unwrap();
                let want = p.wrench();
                for (c, w) in want.iter().enumerate() {
                    assert_eq!(out[c][i], *w, "{name}, leg {i}, output {c}");
                }
                sideways += usize::from(p.side_n.abs() > 1e-3);
            }
            assert!(sideways >= 5, "{name}: {sideways} legs with a side force");
            // In the plane: forces' values, nothing sideways.
            let planar = run(&kernel, None, true).unwrap();
            let three = run(&kernel, None, false).unwrap();
            assert_eq!(&planar[..3], &three[..3], "{name}");
            if name != "wheel" {
                assert!(planar[3..].iter().flatten().all(|v| *v == 0.0), "{name}");
            }
            // A lateral velocity that is no number names its leg.
            let mut bad = lateral.clone();
            bad[11] = f64::NAN;
            let e = run(&kernel, Some(&bad), true).unwrap_err();
            assert_eq!(e.index, 11, "{name}: {e}");
            assert!(e.to_string().contains("lateral velocity"), "{name}: {e}");
        }
    }
}
