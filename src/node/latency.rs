//! Processing-time statistics: a fixed-size log-linear histogram (no allocation per sample), so
//! that the node can report p50, p99 and max of long runs in flat memory.

/// Buckets of 1/16 of a power of two of nanoseconds, up to about 17 s.
const SUB: usize = 16;
const OCTAVES: usize = 34;

#[derive(Debug, Clone)]
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
    let octave = 63 - ns.leading_zeros() as usize; // >= 4
    let sub = ((ns >> (octave - 4)) & (SUB as u64 - 1)) as usize;
    ((octave - 3) * SUB + sub).min(SUB * OCTAVES - 1)
}

fn bucket_upper_ns(b: usize) -> u64 {
    if b < SUB {
        return b as u64;
    }
    let octave = b / SUB + 3;
    let sub = (b % SUB) as u64;
    ((SUB as u64 + sub + 1) << (octave - 4)) - 1
}

impl Histogram {
    pub fn record(&mut self, ns: u64) {
        self.counts[bucket(ns)] += 1;
        self.total += 1;
        self.max_ns = self.max_ns.max(ns);
    }

    pub fn count(&self) -> u64 {
        self.total
    }

    pub fn max_ns(&self) -> u64 {
        self.max_ns
    }

    /// The `q` quantile (upper edge of its bucket, at most 1/16 above the true value).
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
    fn quantiles_within_a_sixteenth() {
        let mut h = Histogram::default();
        for ns in 1..=10_000u64 {
            h.record(ns * 10);
        }
        let p50 = h.quantile_ns(0.5) as f64;
        let p99 = h.quantile_ns(0.99) as f64;
        assert!((p50 / 50_000.0 - 1.0).abs() < 0.07, "{p50}");
        assert!((p99 / 99_000.0 - 1.0).abs() < 0.07, "{p99}");
        assert_eq!(h.max_ns(), 100_000);
        for ns in [0u64, 1, 15, 16, 17, 1000, 123_456_789] {
            assert!(bucket_upper_ns(bucket(ns)) >= ns, "{ns}");
        }
    }
}
