//! Rows of a re-evaluation as CSV: `t_s,leg,beta_rad,regime,measured_drag_n,...` (see
//! [`CSV_HEADER`]), one row per prediction next to its measurement.

use super::reevaluate::Row;
use crate::model::Regime;
use anyhow::{Result, anyhow};

/// The CSV header of `replay --reevaluate`.
pub const CSV_HEADER: &str = "t_s,leg,beta_rad,regime,measured_drag_n,measured_lift_n,predicted_drag_n,predicted_lift_n,predicted_hip_torque_nm,b_k,a,identified,bare_drag_n,bare_lift_n,expected_reading_drag_n,expected_reading_lift_n,predicted_side_n,predicted_roll_moment_nm,predicted_yaw_moment_nm\n";

/// Rows of a re-evaluation as CSV, written by hand beside the csv crate: every field but the
/// leg's name is a number, a fixed word or empty, so no field needs the crate's quoting checks,
/// and the floats of a session repeat from row to row, so their text is looked up rather than
/// formatted again. Floats are in their shortest exact form (zmij); legs' names are quoted by
/// the csv crate, once. `cargo bench --bench session` measures it against the csv crate
/// (`docs/benchmarks.md`); the unit tests below and a property test (`tests/properties.rs`) read
/// its rows back with the csv crate, field for field.
pub struct CsvRows {
    /// Each leg's field, quoted as needed, with its comma.
    legs: Vec<Field>,
    /// By [`Regime::code`], with its comma.
    regimes: Vec<Field>,
    floats: FloatText,
}

/// A field's text, zero-padded to at least [`PIECE`] bytes for [`put`], and its length.
struct Field {
    padded: Vec<u8>,
    len: usize,
}

impl Field {
    fn new(text: &[u8]) -> Self {
        let mut padded = text.to_vec();
        padded.resize(text.len().max(PIECE), 0);
        Field {
            padded,
            len: text.len(),
        }
    }

    fn put(&self, out: &mut Vec<u8>) {
        put(out, &self.padded, self.len);
    }
}

/// Copies the first `len` bytes of `text` to `out`. A text of at most [`PIECE`] bytes is copied
/// as a fixed-size block and the excess cut off again: a copy of constant size compiles to a few
/// moves, where one of variable size is a call to memmove.
fn put(out: &mut Vec<u8>, text: &[u8], len: usize) {
    match text.first_chunk::<PIECE>() {
        Some(block) if len <= PIECE => {
            let end = out.len() + len;
            out.extend_from_slice(block);
            out.truncate(end);
        }
        _ => out.extend_from_slice(&text[..len]),
    }
}

const PIECE: usize = 32;

/// The text of recently written floats, with their comma, by bit pattern in a small
/// direct-mapped table. Many values of a session repeat from row to row (the time of an
/// instant for all legs, one attack angle for the legs of a tripod, a leg's width while it is
/// out of the medium, the zero forces out of it), and looking their text up costs much less
/// than formatting it again. The text is the same either way.
struct FloatText {
    slots: Vec<FloatSlot>,
    float: zmij::Buffer,
}

#[derive(Clone, Copy)]
struct FloatSlot {
    bits: u64,
    /// 0 while the slot is empty (no float formats to nothing).
    len: u8,
    text: [u8; PIECE],
}

impl FloatText {
    const SLOTS_LOG2: u32 = 9;

    fn new() -> Self {
        let empty = FloatSlot {
            bits: 0,
            len: 0,
            text: [0; PIECE],
        };
        FloatText {
            slots: vec![empty; 1 << Self::SLOTS_LOG2],
            float: zmij::Buffer::new(),
        }
    }

    /// Writes `v` and a comma.
    fn put(&mut self, out: &mut Vec<u8>, v: f64) {
        let bits = v.to_bits();
        // Fibonacci hashing: the top bits of the product mix all of the value's bits.
        let i = (bits.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (64 - Self::SLOTS_LOG2)) as usize;
        let slot = &mut self.slots[i];
        if slot.bits != bits || slot.len == 0 {
            // zmij writes at most 24 bytes (its buffer's size), so the text and its comma fit.
            let s = self.float.format(v).as_bytes();
            slot.text[..s.len()].copy_from_slice(s);
            slot.text[s.len()] = b',';
            slot.len = s.len() as u8 + 1;
            slot.bits = bits;
        }
        put(out, &slot.text, usize::from(slot.len));
    }
}

impl CsvRows {
    /// A writer of rows for the legs named `legs` (their names go into the rows).
    pub fn new(legs: &[String]) -> Result<Self> {
        let legs = legs
            .iter()
            .map(|name| {
                let mut w = csv::WriterBuilder::new()
                    .terminator(csv::Terminator::Any(b','))
                    .from_writer(Vec::new());
                w.write_field(name)?;
                w.write_record(None::<&[u8]>)?;
                Ok(Field::new(&w.into_inner().map_err(|e| anyhow!("{e}"))?))
            })
            .collect::<Result<_>>()?;
        let regimes = Regime::ALL
            .iter()
            .map(|r| Field::new(format!("{},", r.as_str()).as_bytes()))
            .collect();
        Ok(CsvRows {
            legs,
            regimes,
            floats: FloatText::new(),
        })
    }

    /// Appends row `r` as one CSV line to `out`.
    pub fn push(&mut self, out: &mut Vec<u8>, r: &Row) {
        self.floats.put(out, r.t_s);
        self.legs[r.leg].put(out);
        self.floats.put(out, r.beta_rad);
        self.regimes[usize::from(r.regime.code())].put(out);
        for m in [r.measured_drag_n, r.measured_lift_n] {
            match m {
                Some(v) => self.floats.put(out, v),
                None => out.push(b','),
            }
        }
        for v in [
            r.predicted_drag_n,
            r.predicted_lift_n,
            r.predicted_hip_torque_nm,
            r.b_k,
            r.a,
        ] {
            self.floats.put(out, v);
        }
        out.extend_from_slice(if r.identified { b"true," } else { b"false," });
        for v in [
            r.bare_drag_n,
            r.bare_lift_n,
            r.expected_reading_drag_n,
            r.expected_reading_lift_n,
            r.predicted_side_n,
            r.predicted_roll_moment_nm,
            r.predicted_yaw_moment_nm,
        ] {
            self.floats.put(out, v);
        }
        // The last field's comma ends the row instead.
        out.pop();
        out.push(b'\n');
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hand-written rows read back with the csv crate: the header names the fields in
    /// order, a leg's name with a comma or a quote is quoted, a missing measurement is an empty
    /// field, and floats come back exactly (non-finite ones as NaN and inf).
    #[test]
    fn csv_rows_read_back_field_for_field() {
        let legs = ["front_left".to_string(), "odd, \"leg\"".to_string()];
        let mut rows = CsvRows::new(&legs).unwrap();
        let mut text = CSV_HEADER.as_bytes().to_vec();
        let row = |leg, measured: Option<f64>, predicted: f64| Row {
            t_s: 1_700_000_000.001,
            leg,
            beta_rad: 0.1 + 0.2,
            regime: Regime::Penetration,
            measured_drag_n: measured,
            measured_lift_n: measured.map(|m| -m),
            predicted_drag_n: predicted,
            predicted_lift_n: 1e-300,
            predicted_hip_torque_nm: -2.5e21,
            b_k: 32.61,
            a: 2.3,
            identified: leg == 1,
            bare_drag_n: 1.5,
            bare_lift_n: -1.5,
            expected_reading_drag_n: 2.5,
            expected_reading_lift_n: predicted,
            predicted_side_n: -0.25,
            predicted_roll_moment_nm: 7e-3,
            predicted_yaw_moment_nm: -predicted,
        };
        let mut written = [
            row(0, Some(12.345678901234567), 0.0),
            row(1, None, f64::NAN),
            row(1, Some(-0.0), f64::INFINITY),
        ];
        // Two rows of one instant, then another instant.
        written[2].t_s = 1_700_000_000.002;
        for r in &written {
            rows.push(&mut text, r);
        }
        let mut rdr = csv::Reader::from_reader(&text[..]);
        let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
        assert_eq!(header.len(), 19);
        assert_eq!(header[0], "t_s");
        assert_eq!(header[11], "identified");
        assert_eq!(header[15], "expected_reading_lift_n");
        assert_eq!(header[18], "predicted_yaw_moment_nm");
        let back: Vec<csv::StringRecord> = rdr.records().map(|r| r.unwrap()).collect();
        assert_eq!(back.len(), written.len());
        for (b, w) in back.iter().zip(&written) {
            assert_eq!(b.len(), 19, "{b:?}");
            let num = |i: usize| b[i].parse::<f64>().unwrap();
            assert_eq!(num(0), w.t_s);
            assert_eq!(&b[1], legs[w.leg].as_str());
            assert_eq!(num(2), w.beta_rad);
            assert_eq!(&b[3], "penetration");
            match w.measured_drag_n {
                Some(m) => {
                    assert_eq!(num(4).to_bits(), m.to_bits());
                    assert_eq!(num(5), -m);
                }
                None => assert!(b[4].is_empty() && b[5].is_empty()),
            }
            let p = num(6);
            assert!(p == w.predicted_drag_n || (p.is_nan() && w.predicted_drag_n.is_nan()));
            assert_eq!(num(7), 1e-300);
            assert_eq!(num(8), -2.5e21);
            assert_eq!((num(9), num(10)), (32.61, 2.3));
            assert_eq!(&b[11], if w.identified { "true" } else { "false" });
            assert_eq!((num(12), num(13), num(14)), (1.5, -1.5, 2.5));
            let e = num(15);
            assert!(e == w.predicted_drag_n || (e.is_nan() && w.predicted_drag_n.is_nan()));
            assert_eq!((num(16), num(17)), (-0.25, 7e-3));
            let y = num(18);
            assert!(y == -w.predicted_drag_n || (y.is_nan() && w.predicted_drag_n.is_nan()));
        }
    }

    /// Values that repeat, in a pool larger than the table of float texts (so that slots are
    /// taken over by other values and then wanted back), read back bit for bit, and every
    /// regime reads back as its name.
    #[test]
    fn csv_rows_with_repeated_values_read_back_exactly() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.random::<u64>();
        let pool: Vec<f64> = (0..3000)
            .map(|i| match i % 3 {
                0 => f64::from_bits(next() >> 2), // any magnitude
                1 => (next() % 1_000_000) as f64 / 1000.0 - 500.0,
                _ => -((next() % 7) as f64),
            })
            .collect();
        let legs = ["a".to_string(), "b".to_string()];
        let mut rows = CsvRows::new(&legs).unwrap();
        let mut text = CSV_HEADER.as_bytes().to_vec();
        let mut written = Vec::new();
        for i in 0..20_000 {
            let mut v = || pool[(next() % pool.len() as u64) as usize];
            let r = Row {
                t_s: v(),
                leg: i % 2,
                beta_rad: v(),
                regime: Regime::ALL[i % Regime::ALL.len()],
                measured_drag_n: Some(v()),
                measured_lift_n: Some(v()),
                predicted_drag_n: v(),
                predicted_lift_n: v(),
                predicted_hip_torque_nm: v(),
                b_k: v(),
                a: v(),
                identified: false,
                bare_drag_n: v(),
                bare_lift_n: v(),
                expected_reading_drag_n: v(),
                expected_reading_lift_n: v(),
                predicted_side_n: v(),
                predicted_roll_moment_nm: v(),
                predicted_yaw_moment_nm: v(),
            };
            rows.push(&mut text, &r);
            written.push(r);
        }
        let mut rdr = csv::Reader::from_reader(&text[..]);
        let back: Vec<csv::StringRecord> = rdr.records().map(|r| r.unwrap()).collect();
        assert_eq!(back.len(), written.len());
        for (b, w) in back.iter().zip(&written) {
            let bits = |i: usize| b[i].parse::<f64>().unwrap().to_bits();
            let want = [
                w.t_s,
                w.beta_rad,
                w.measured_drag_n.unwrap(),
                w.measured_lift_n.unwrap(),
                w.predicted_drag_n,
                w.predicted_lift_n,
                w.predicted_hip_torque_nm,
                w.b_k,
                w.a,
                w.bare_drag_n,
                w.bare_lift_n,
                w.expected_reading_drag_n,
                w.expected_reading_lift_n,
                w.predicted_side_n,
                w.predicted_roll_moment_nm,
                w.predicted_yaw_moment_nm,
            ];
            for (i, v) in [0, 2, 4, 5, 6, 7, 8, 9, 10, 12, 13, 14, 15, 16, 17, 18]
                .into_iter()
                .zip(want)
            {
                assert_eq!(bits(i), v.to_bits(), "field {i} of {b:?}");
            }
            assert_eq!(&b[3], w.regime.as_str());
        }
    }
}
