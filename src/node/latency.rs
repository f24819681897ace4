//! Processing-time statistics: a fixed-size log-linear histogram (no allocation per sample), so
//! that the node can report p50, p99 and max of long runs in flat memory.

/// Buckets of 1/64 of a power of two of nanoseconds (1.6 %, fine enough to compare two p99s
/// against a 10 % target), up to about 17 s.
const SUB_BITS: usize = 6;
const SUB: usize = 1 << SUB_BITS;
const OCTAVES: usize = 29;

#[derive(Debug, Clone)]
/// A log-linear histogram of durations (ns): buckets of 1/64 of a power of two, up to about
/// 17 s, in fixed memory.
pub struct Histogram {
    counts: Vec<u64>,
    total: u64,
    max_ns: u64,
}

impl Default for Histogram {
    fn default() -> Self {
        Histogram {
            counts: vec![0; SUB * OCTAVES],
            total: 0,
            max_ns: 0,
        }
    }
}

fn bucket(ns: u64) -> usize {
    if ns < SUB as u64 {
        return ns as usize;
    }
    let octave = 63 - ns.leading_zeros() as usize; // >= SUB_BITS
    let sub = ((ns >> (octave - SUB_BITS)) & (SUB as u64 - 1)) as usize;
    ((octave - SUB_BITS + 1) * SUB + sub).min(SUB * OCTAVES - 1)
}

fn bucket_upper_ns(b: usize) -> u64 {
    if b < SUB {
        return b as u64;
    }
    let octave = b / SUB + SUB_BITS - 1;
    let sub = (b % SUB) as u64;
    ((SUB as u64 + sub + 1) << (octave - SUB_BITS)) - 1
}

impl Histogram {
    /// Adds one duration (ns).
    pub fn record(&mut self, ns: u64) {
        self.counts[bucket(ns)] += 1;
        self.total += 1;
        self.max_ns = self.max_ns.max(ns);
    }

    /// Durations recorded.
    pub fn count(&self) -> u64 {
        self.total
    }

    /// The longest duration recorded (ns).
    pub fn max_ns(&self) -> u64 {
        self.max_ns
    }

    /// The `q` quantile (upper edge of its bucket, at most 1/64 above the true value).
    pub fn quantile_ns(&self, q: f64) -> u64 {
        if self.total == 0 {
            return 0;
        }
        let rank = ((self.total as f64) * q.clamp(0.0, 1.0)).ceil().max(1.0) as u64;
        let mut seen = 0;
        for (b, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= rank {
                return bucket_upper_ns(b).min(self.max_ns);
            }
        }
        self.max_ns
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_within_a_sixty_fourth() {
        let mut h = Histogram::default();
        for ns in 1..=10_000u64 {
            h.record(ns * 10);
        }
        let p50 = h.quantile_ns(0.5) as f64;
        let p99 = h.quantile_ns(0.99) as f64;
        assert!((p50 / 50_000.0 - 1.0).abs() < 0.02, "{p50}");
        assert!((p99 / 99_000.0 - 1.0).abs() < 0.02, "{p99}");
        assert_eq!(h.max_ns(), 100_000);
        for ns in [0u64, 1, 63, 64, 65, 127, 128, 1000, 123_456_789] {
            let b = bucket(ns);
            assert!(bucket_upper_ns(b) >= ns, "{ns}");
            // The bucket below ends below the value: each value is in the lowest bucket that
            // holds it.
            assert!(b == 0 || bucket_upper_ns(b - 1) < ns, "{ns}");
        }
        // Up to the last bucket, about 17 s.
        assert!(bucket_upper_ns(SUB * OCTAVES - 1) > 17_000_000_000);
    }
}
