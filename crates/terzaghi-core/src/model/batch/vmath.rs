//! `sin`, `cos` and `exp` of [`LANES`] values at once, without a branch, so that a loop over
//! them runs in vector registers: fdlibm's kernels (the polynomials glibc's and musl's `sin`,
//! `cos` and `exp` descend from) after a reduction that is exact for the arguments the batch
//! gives them (`|x| < 2^20` for `sin_cos`, `|x| <= 700` for `exp`: the caller checks). Within
//! two units in the last place of libm's (`tests::they_are_libm_s_to_two_units_in_the_last_place`).

// fdlibm's constants as it publishes them (the digits past a double's are its own).
#![allow(clippy::excessive_precision)]

use super::LANES;

/// `1.5 2^52`: added and taken off, a double rounds to the nearest integer, which its low
/// mantissa bits then hold.
const ROUND: f64 = 6_755_399_441_055_744.0;

/// `pi/2` in three parts (fdlibm's `pio2_1`, `pio2_2`, `pio2_2t`; the first two of 33 bits, so
/// that their products by a small integer are exact).
const PIO2_1: f64 = 1.570_796_326_734_125_614_17e+00;
const PIO2_2: f64 = 6.077_100_506_303_965_976_6e-11;
const PIO2_2T: f64 = 2.022_266_248_795_950_732_1e-21;

const TWO_OVER_PI: f64 = std::f64::consts::FRAC_2_PI;

const S1: f64 = -1.666_666_666_666_663_243_48e-01;
const S2: f64 = 8.333_333_333_322_489_461_24e-03;
const S3: f64 = -1.984_126_982_985_794_931_34e-04;
const S4: f64 = 2.755_731_370_707_006_767_89e-06;
const S5: f64 = -2.505_076_025_340_686_341_95e-08;
const S6: f64 = 1.589_690_995_211_550_102_21e-10;

const C1: f64 = 4.166_666_666_666_660_190_37e-02;
const C2: f64 = -1.388_888_888_887_410_957_49e-03;
const C3: f64 = 2.480_158_728_947_672_941_78e-05;
const C4: f64 = -2.755_731_435_139_066_330_35e-07;
const C5: f64 = 2.087_572_321_298_174_827_90e-09;
const C6: f64 = -1.135_964_755_778_819_482_65e-11;

/// `sin` and `cos` of every lane.
#[inline(always)]
pub fn sin_cos(x: &[f64; LANES]) -> ([f64; LANES], [f64; LANES]) {
    let mut s = [0.0; LANES];
    let mut c = [0.0; LANES];
    let round_bits = ROUND.to_bits() as i64;
    for l in 0..LANES {
        let x = x[l];
        // The nearest multiple of pi/2, n; x - n pi/2 to about 2^-100 of x (fdlibm's medium
        // case, its second step always taken).
        let t = x * TWO_OVER_PI + ROUND;
        let n = t - ROUND;
        let q = (t.to_bits() as i64).wrapping_sub(round_bits);
        let r = x - n * PIO2_1;
        let w = n * PIO2_2;
        let r2 = r - w;
        let w2 = n * PIO2_2T - ((r - r2) - w);
        let y = r2 - w2;
        // The kernels on [-pi/4, pi/4] (fdlibm's __kernel_sin and __kernel_cos, with no tail).
        let z = y * y;
        let v = z * y;
        let ps = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
        let sy = y + v * (S1 + z * ps);
        let pc = z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))));
        let cy = 1.0 - (0.5 * z - z * pc);
        // The quadrant: (s, c), (c, -s), (-s, -c), (-c, s).
        let odd = q & 1 != 0;
        let (a, b) = if odd { (cy, sy) } else { (sy, cy) };
        let sin_neg = q & 2 != 0;
        let cos_neg = (q + 1) & 2 != 0;
        s[l] = if sin_neg { -a } else { a };
        c[l] = if cos_neg { -b } else { b };
    }

    (s, c)
}

const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-01;
const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;
const LOG2_E: f64 = std::f64::consts::LOG2_E;

/// `1 / n!` for `n` in `0..=13`.
const EXP_TAYLOR: [f64; 14] = [
    1.0,
    1.0,
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5040.0,
    1.0 / 40320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
    1.0 / 6_227_020_800.0,
];

/// `exp` of every lane (`|x| <= 700`).
#[inline(always)]
pub fn exp(x: &[f64; LANES]) -> [f64; LANES] {
    let mut out = [0.0; LANES];
    let round_bits = ROUND.to_bits() as i64;
    for l in 0..LANES {
        let x = x[l];
        let t = x * LOG2_E + ROUND;
        let k = t - ROUND;
        let ki = (t.to_bits() as i64).wrapping_sub(round_bits);
        // r = x - k ln 2 in two parts (k ln2_hi is exact).
        let hi = x - k * LN2_HI;
        let lo = k * LN2_LO;
        let r = hi - lo;
        // e^r on |r| <= ln2/2 by its Taylor series to r^13 (the remainder below 2^-60).
        let p = EXP_TAYLOR.iter().rev().fold(0.0, |acc, c| acc * r + c);
        // 2^k (k within the normal exponents for |x| <= 700).
        let scale = f64::from_bits(((ki + 1023) as u64) << 52);
        out[l] = p * scale;
    }
    out
}

// ---------------------------------------------------------------- float32

// Cephes' sinf, cosf and expf (their reductions and polynomials), for a batch in float32: within
// two units in the last place of float32 (`tests::the_float32_ones_are_within_two_units`).

// The natural logarithm: FreeBSD's `e_log.c` (as musl's `log`), within one unit in the last
// place, for normal positive numbers (the caller takes the others to `f64::ln`).
const LN2_HI_LOG: f64 = 6.931_471_803_691_238_164_90e-01;
const LN2_LO_LOG: f64 = 1.908_214_929_270_587_700_02e-10;
const LG: [f64; 7] = [
    6.666_666_666_666_735_130e-01,
    3.999_999_999_940_941_908e-01,
    2.857_142_874_366_239_149e-01,
    2.222_219_843_214_978_396e-01,
    1.818_357_216_161_805_012e-01,
    1.531_383_769_920_937_332e-01,
    1.479_819_860_511_658_591e-01,
];

/// `ln` of every lane (a normal positive number).
#[inline(always)]
pub fn ln(x: &[f64; LANES]) -> [f64; LANES] {
    let mut out = [0.0; LANES];
    for l in 0..LANES {
        // x = 2^k (1 + f), 1 + f within [sqrt(2)/2, sqrt(2)).
        let bits = x[l].to_bits();
        let hx = ((bits >> 32) as u32).wrapping_add(0x3ff0_0000 - 0x3fe6_a09e);
        let k = (hx >> 20) as i32 - 0x3ff;
        let hx = (hx & 0x000f_ffff) + 0x3fe6_a09e;
        let m = f64::from_bits(((hx as u64) << 32) | (bits & 0xffff_ffff));
        let f = m - 1.0;
        let hfsq = 0.5 * f * f;
        let s = f / (2.0 + f);
        let z = s * s;
        let w = z * z;
        let t1 = w * (LG[1] + w * (LG[3] + w * LG[5]));
        let t2 = z * (LG[0] + w * (LG[2] + w * (LG[4] + w * LG[6])));
        let r = t2 + t1;
        let dk = k as f64;
        out[l] = s * (hfsq + r) + dk * LN2_LO_LOG - hfsq + f + dk * LN2_HI_LOG;
    }
    out
}

// The arc tangent: Cephes' `atan` (Moshier), within about two units in the last place: a third
// of the half turn reduced to |x| <= 0.66 by tan(pi/4) or tan(pi/2), a rational function there.
const T3P8: f64 = 2.414_213_562_373_095_048_80;
const MOREBITS: f64 = 6.123_233_995_736_765_886_130e-17;
const ATAN_P: [f64; 5] = [
    -8.750_608_600_031_904_122_785e-1,
    -1.615_753_718_733_365_076_637e1,
    -7.500_855_792_314_704_667_340e1,
    -1.228_866_684_490_136_173_410e2,
    -6.485_021_904_942_025_371_773e1,
];
const ATAN_Q: [f64; 5] = [
    2.485_846_490_142_306_297_962e1,
    1.650_270_098_316_988_542_046e2,
    4.328_810_604_912_902_668_951e2,
    4.853_903_996_359_136_964_868e2,
    1.945_506_571_482_613_964_425e2,
];

/// `atan` of every lane (any number but NaN).
#[inline(always)]
pub fn atan(x: &[f64; LANES]) -> [f64; LANES] {
    let mut out = [0.0; LANES];
    for l in 0..LANES {
        let a = x[l].abs();
        let big = a > T3P8;
        let mid = !big & (a > 0.66);
        // Every branch computed, the answer chosen (no branch to mispredict).
        let r = if big {
            -1.0 / a
        } else if mid {
            (a - 1.0) / (a + 1.0)
        } else {
            a
        };
        let base = if big {
            std::f64::consts::FRAC_PI_2
        } else if mid {
            std::f64::consts::FRAC_PI_4
        } else {
            0.0
        };
        let extra = if big {
            MOREBITS
        } else if mid {
            0.5 * MOREBITS
        } else {
            0.0
        };
        let z = r * r;
        let p = (((ATAN_P[0] * z + ATAN_P[1]) * z + ATAN_P[2]) * z + ATAN_P[3]) * z + ATAN_P[4];
        let q =
            ((((z + ATAN_Q[0]) * z + ATAN_Q[1]) * z + ATAN_Q[2]) * z + ATAN_Q[3]) * z + ATAN_Q[4];
        let y = base + ((r * (z * p / q) + r) + extra);
        out[l] = if x[l].is_sign_negative() { -y } else { y };
    }
    out
}

/// `pi/2` in three parts, the first two of few bits (their products by a small integer exact).
const PIO2_1F: f32 = 1.570_312_5;
const PIO2_2F: f32 = 4.837_512_969_970_703_125e-4;
const PIO2_3F: f32 = 7.549_789_954_891_882_16e-8;

const S1F: f32 = -1.666_665_461_1e-1;
const S2F: f32 = 8.332_160_873_6e-3;
const S3F: f32 = -1.951_529_589_1e-4;
const C1F: f32 = 4.166_664_568_298_827e-2;
const C2F: f32 = -1.388_731_625_493_765e-3;
const C3F: f32 = 2.443_315_711_809_948e-5;

/// `1.5 2^23`: added and taken off, a float rounds to the nearest integer, which its low
/// mantissa bits then hold.
const ROUND_F: f32 = 12_582_912.0;

/// `sin` and `cos` of every lane (`|x| < 2^16`: the batch's wrapped angles).
#[inline(always)]
pub fn sin_cos_f32(x: &[f32; LANES]) -> ([f32; LANES], [f32; LANES]) {
    let mut s = [0.0f32; LANES];
    let mut c = [0.0f32; LANES];
    let round_bits = ROUND_F.to_bits() as i32;
    for l in 0..LANES {
        let x = x[l];
        let t = x * std::f32::consts::FRAC_2_PI + ROUND_F;
        let n = t - ROUND_F;
        let q = (t.to_bits() as i32).wrapping_sub(round_bits);
        let y = ((x - n * PIO2_1F) - n * PIO2_2F) - n * PIO2_3F;
        let z = y * y;
        let sy = y + y * z * (S1F + z * (S2F + z * S3F));
        let cy = 1.0 - 0.5 * z + z * z * (C1F + z * (C2F + z * C3F));
        let odd = q & 1 != 0;
        let (a, b) = if odd { (cy, sy) } else { (sy, cy) };
        let sin_neg = q & 2 != 0;
        let cos_neg = (q + 1) & 2 != 0;
        s[l] = if sin_neg { -a } else { a };
        c[l] = if cos_neg { -b } else { b };
    }
    (s, c)
}

const LN2_HI_F: f32 = 0.693_359_375;
const LN2_LO_F: f32 = -2.121_944_4e-4;
const EXP_F: [f32; 6] = [
    1.987_569_150_0e-4,
    1.398_199_950_7e-3,
    8.333_451_907_3e-3,
    4.166_579_589_4e-2,
    1.666_666_545_9e-1,
    5.000_000_120_1e-1,
];

/// `exp` of every lane (`|x| <= 80`).
#[inline(always)]
pub fn exp_f32(x: &[f32; LANES]) -> [f32; LANES] {
    let mut out = [0.0f32; LANES];
    let round_bits = ROUND_F.to_bits() as i32;
    for l in 0..LANES {
        let x = x[l];
        let t = x * std::f32::consts::LOG2_E + ROUND_F;
        let k = t - ROUND_F;
        let ki = (t.to_bits() as i32).wrapping_sub(round_bits);
        let r = (x - k * LN2_HI_F) - k * LN2_LO_F;
        let p = EXP_F.iter().fold(0.0f32, |acc, c| acc * r + c);
        let e = p * r * r + r + 1.0;
        out[l] = e * f32::from_bits(((ki + 127) as u32) << 23);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ulps(a: f64, b: f64) -> f64 {
        if a == b {
            return 0.0;
        }
        let spacing = f64::EPSILON * a.abs().max(b.abs()).max(f64::MIN_POSITIVE);
        (a - b).abs() / spacing
    }

    #[test]
    fn they_are_libm_s_to_two_units_in_the_last_place() {
        let mut worst = [0.0f64; 3];
        let mut x = [0.0; LANES];
        let mut count = 0;
        // Angles over two turns each way, and exponents over the batch's range.
        for i in 0..20_000 {
            for (l, v) in x.iter_mut().enumerate() {
                *v = -4.0 * std::f64::consts::PI
                    + (i * LANES + l) as f64
                        * (8.0 * std::f64::consts::PI / (20_000 * LANES) as f64);
            }
            let (s, c) = sin_cos(&x);
            for l in 0..LANES {
                let (ws, wc) = x[l].sin_cos();
                // Near a zero of sin or cos, compare against the argument's scale instead.
                let floor = f64::EPSILON * 0.5;
                worst[0] = worst[0].max(ulps(s[l], ws).min((s[l] - ws).abs() / floor));
                worst[1] = worst[1].max(ulps(c[l], wc).min((c[l] - wc).abs() / floor));
                count += 1;
            }
            for (l, v) in x.iter_mut().enumerate() {
                *v = -700.0 + (i * LANES + l) as f64 * (1400.0 / (20_000 * LANES) as f64);
            }
            let e = exp(&x);
            for l in 0..LANES {
                worst[2] = worst[2].max(ulps(e[l], x[l].exp()));
            }
        }
        assert!(count > 300_000);
        assert!(
            worst.iter().all(|w| *w <= 2.0),
            "sin, cos, exp off by {worst:?} ulp"
        );
    }

    #[test]
    fn the_logarithm_is_libm_s_to_one_unit_in_the_last_place() {
        let mut worst = 0.0f64;
        let mut x = [0.0; LANES];
        // From the smallest normal number to the largest, and closely about 1.
        for i in 0..40_000 {
            for (l, v) in x.iter_mut().enumerate() {
                let u = (i * LANES + l) as f64 / (40_000 * LANES) as f64;
                *v = if i % 2 == 0 {
                    (u * 1416.0 - 708.0).exp() * (1.0 + u)
                } else {
                    0.9 + 0.2 * u
                };
            }
            x[0] = 1.0;
            x[1] = f64::MIN_POSITIVE;
            x[2] = f64::MAX;
            let got = ln(&x);
            for l in 0..LANES {
                worst = worst.max(ulps(got[l], x[l].ln()));
            }
        }
        assert!(worst <= 1.0, "ln off by {worst} ulp");
    }

    #[test]
    fn the_arc_tangent_is_libm_s_to_two_units_in_the_last_place() {
        let mut worst = 0.0f64;
        let mut x = [0.0; LANES];
        for i in 0..40_000 {
            for (l, v) in x.iter_mut().enumerate() {
                let u = (i * LANES + l) as f64 / (40_000 * LANES) as f64;
                // Both signs, from 1e-300 to 1e300, and closely about the reductions' bounds.
                *v = match i % 3 {
                    0 => (u * 1381.0 - 690.0).exp() * if l % 2 == 0 { 1.0 } else { -1.0 },
                    1 => -4.0 + 8.0 * u,
                    _ => 0.6 + 2.0 * u,
                };
            }
            x[0] = 0.0;
            x[1] = -0.0;
            x[2] = f64::INFINITY;
            x[3] = f64::NEG_INFINITY;
            let got = atan(&x);
            for l in 0..LANES {
                let want = x[l].atan();
                assert_eq!(
                    got[l].is_sign_negative(),
                    want.is_sign_negative(),
                    "atan({})",
                    x[l]
                );
                worst = worst.max(ulps(got[l], want));
            }
        }
        assert!(worst <= 2.0, "atan off by {worst} ulp");
    }

    #[test]
    fn the_float32_ones_are_within_two_units() {
        let ulps32 = |a: f32, b: f64| {
            let spacing = f32::EPSILON as f64 * b.abs().max(f32::MIN_POSITIVE as f64);
            (a as f64 - b).abs() / spacing
        };
        let mut worst = [0.0f64; 3];
        let mut x = [0.0f32; LANES];
        for i in 0..20_000 {
            for (l, v) in x.iter_mut().enumerate() {
                *v = (-4.0 * std::f64::consts::PI
                    + (i * LANES + l) as f64
                        * (8.0 * std::f64::consts::PI / (20_000 * LANES) as f64))
                    as f32;
            }
            let (s, c) = sin_cos_f32(&x);
            for l in 0..LANES {
                let (ws, wc) = (x[l] as f64).sin_cos();
                // Near a zero of sin or cos, against the argument's scale (float32's half unit).
                let floor = f32::EPSILON as f64 * 0.5;
                worst[0] = worst[0].max(ulps32(s[l], ws).min((s[l] as f64 - ws).abs() / floor));
                worst[1] = worst[1].max(ulps32(c[l], wc).min((c[l] as f64 - wc).abs() / floor));
            }
            for (l, v) in x.iter_mut().enumerate() {
                *v = (-80.0 + (i * LANES + l) as f64 * (160.0 / (20_000 * LANES) as f64)) as f32;
            }
            let e = exp_f32(&x);
            for l in 0..LANES {
                worst[2] = worst[2].max(ulps32(e[l], (x[l] as f64).exp()));
            }
        }
        assert!(
            worst.iter().all(|w| *w <= 2.0),
            "sin, cos, exp off by {worst:?} units of float32"
        );
    }
}
