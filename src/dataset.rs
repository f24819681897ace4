//! Reading force logs: CSV with a header that names at least `beta_rad,drag_n,lift_n`
//! (optionally `t_s`). A `beta_deg` column stands in for `beta_rad`, so that the output of
//! `terzaghi predict` reads back (its other columns, and a DEM log's `hip_torque_nm`, are
//! read past). A leg's hip may move: `hip_height_m` (negative below the surface), and
//! optionally `hip_vx_m_s`, `hip_vy_m_s`, `hip_vz_m_s` and `pitch_rad` ([`read_log`]). Any other column is
//! refused by name, never ignored. Cells `nan`/`inf` are kept as samples for the
//! identification to count and skip; a cell that is not a number is an error naming its line.

use crate::ident::Sample;
use std::io::Read;
use std::path::Path;

/// What is wrong with a force log (CSV); names the file, and the line and column where it can.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The file cannot be read.
    #[error("cannot read {path}: {error}")]
    Io {
        /// The file.
        path: String,
        /// The system's error.
        error: std::io::Error,
    },
    /// The file has no header.
    #[error("{path}: empty file (expected a header with beta_rad,drag_n,lift_n)")]
    Empty {
        /// The file.
        path: String,
    },
    /// The header lacks a column every log has.
    #[error("{path}: header lacks column {column:?} (found: {found})")]
    MissingColumn {
        /// The file.
        path: String,
        /// The column it lacks.
        column: &'static str,
        /// The columns it has.
        found: String,
    },
    /// A value that is not a number.
    #[error("{path} line {line}, column {column}: {value:?} is not a number")]
    NotANumber {
        /// The file.
        path: String,
        /// The line (from 1).
        line: u64,
        /// The column.
        column: &'static str,
        /// The value, as written.
        value: String,
    },
    /// A column the log may not have, refused rather than ignored.
    #[error(
        "{path}: unknown column {column:?} (a force log has t_s, beta_rad or beta_deg, drag_n, lift_n, and for a moving hip hip_height_m, hip_vx_m_s, hip_vy_m_s, hip_vz_m_s, pitch_rad){hint}"
    )]
    UnknownColumn {
        /// The file.
        path: String,
        /// The column.
        column: String,
        /// The known column it may have meant, as text to append ("" for none).
        hint: String,
    },
    /// A hip column given to a command that takes a leg at its configured hip height.
    #[error(
        "{path}: {column} gives the hip's motion, which only replay --reevaluate reads (with a params file); this command takes a leg turning at its configured hip height"
    )]
    HipNotTaken {
        /// The file.
        path: String,
        /// The hip column.
        column: &'static str,
    },
    /// A hip velocity or pitch column without `hip_height_m`.
    #[error("{path}: {column} needs hip_height_m beside it")]
    HipWithoutHeight {
        /// The file.
        path: String,
        /// The column given without the height.
        column: &'static str,
    },
    /// A line that is not a CSV record of the header's columns.
    #[error("{path} line {line}: {message}")]
    Malformed {
        /// The file.
        path: String,
        /// The line (from 1).
        line: u64,
        /// What is wrong with it.
        message: String,
    },
}

/// Columns a force log may have besides the samples' own and the hip's: what `terzaghi
/// predict` writes, and a DEM log's torque; they are read past.
const READ_PAST: [&str; 4] = ["submerged_m", "depth_m", "hip_torque_nm", "regime"];
/// The hip's columns.
const HIP_COLUMNS: [&str; 5] = [
    "hip_height_m",
    "hip_vx_m_s",
    "hip_vy_m_s",
    "hip_vz_m_s",
    "pitch_rad",
];

/// The hip of one row of a log: its height above the surface (m, negative below it) and, where
/// the log gives them, its horizontal and vertical velocity (m/s) and the body's pitch (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HipRow {
    /// The hip's height above the surface (m; negative below it).
    pub height_m: f64,
    /// The hip's horizontal velocity (m/s), where the log gives it.
    pub vx_m_s: Option<f64>,
    /// The hip's horizontal velocity across the robot's forward, toward its left (m/s), where
    /// the log gives it.
    pub vy_m_s: Option<f64>,
    /// The hip's vertical velocity, up (m/s), where the log gives it.
    pub vz_m_s: Option<f64>,
    /// The body's pitch (rad), where the log gives it.
    pub pitch_rad: Option<f64>,
}

/// A force log: its samples, and its hip's rows where it has `hip_height_m`.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceLog {
    /// The samples, one per row.
    pub samples: Vec<Sample>,
    /// The hip of each row, where the log has `hip_height_m`.
    pub hips: Option<Vec<HipRow>>,
}

/// Reads the samples of a CSV file; a log with hip columns is refused (see [`read_log`]).
pub fn read_samples_csv(path: &Path) -> Result<Vec<Sample>, DatasetError> {
    let log = read_log(path)?;
    if log.hips.is_some() {
        return Err(DatasetError::HipNotTaken {
            path: path.display().to_string(),
            column: "hip_height_m",
        });
    }
    Ok(log.samples)
}

/// Reads a force log from a CSV file, with its hip's columns if it has them.
pub fn read_log(path: &Path) -> Result<ForceLog, DatasetError> {
    let name = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|error| DatasetError::Io {
        path: name.clone(),
        error,
    })?;
    read_log_from(file, &name)
}

/// Reads samples from any CSV reader; `name` is used in messages. A log with hip columns is
/// refused.
pub fn read_samples<R: Read>(input: R, name: &str) -> Result<Vec<Sample>, DatasetError> {
    let log = read_log_from(input, name)?;
    if log.hips.is_some() {
        return Err(DatasetError::HipNotTaken {
            path: name.to_string(),
            column: "hip_height_m",
        });
    }
    Ok(log.samples)
}

/// [`read_log`] from any CSV reader; `name` is used in messages.
pub fn read_log_from<R: Read>(input: R, name: &str) -> Result<ForceLog, DatasetError> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(input);
    let malformed = |e: csv::Error| {
        let line = e.position().map(|p| p.line()).unwrap_or(0);
        match e.kind() {
            csv::ErrorKind::Io(_) => DatasetError::Io {
                path: name.to_string(),
                error: std::io::Error::other(e.to_string()),
            },
            _ => DatasetError::Malformed {
                path: name.to_string(),
                line,
                message: e.to_string(),
            },
        }
    };
    let headers = rdr.headers().map_err(malformed)?.clone();
    if headers.is_empty() || headers.iter().all(str::is_empty) {
        return Err(DatasetError::Empty {
            path: name.to_string(),
        });
    }
    let col = |column: &'static str| {
        headers
            .iter()
            .position(|h| h == column)
            .ok_or_else(|| DatasetError::MissingColumn {
                path: name.to_string(),
                column,
                found: headers.iter().collect::<Vec<_>>().join(","),
            })
    };
    let deg = headers.iter().position(|h| h == "beta_deg");
    let (ib, beta_column, to_rad) = match (col("beta_rad"), deg) {
        (Ok(i), _) => (i, "beta_rad", 1.0),
        (Err(_), Some(i)) => (i, "beta_deg", std::f64::consts::PI / 180.0),
        (Err(e), None) => return Err(e),
    };
    let (id, il) = (col("drag_n")?, col("lift_n")?);
    let it = headers.iter().position(|h| h == "t_s");
    let own = ["t_s", "beta_rad", "beta_deg", "drag_n", "lift_n"];
    for h in headers.iter() {
        if !(own.contains(&h) || HIP_COLUMNS.contains(&h) || READ_PAST.contains(&h)) {
            let near = own
                .iter()
                .chain(&HIP_COLUMNS)
                .map(|k| (strsim::levenshtein(h, k), *k))
                .min()
                .filter(|(d, _)| *d <= 3)
                .map(|(_, k)| format!("; did you mean {k}?"))
                .unwrap_or_default();
            return Err(DatasetError::UnknownColumn {
                path: name.to_string(),
                column: h.to_string(),
                hint: near,
            });
        }
    }
    let hip_col = |c: &str| headers.iter().position(|h| h == c);
    let ih = hip_col("hip_height_m");
    let (ivx, ivy, ivz, ip) = (
        hip_col("hip_vx_m_s"),
        hip_col("hip_vy_m_s"),
        hip_col("hip_vz_m_s"),
        hip_col("pitch_rad"),
    );
    if ih.is_none() {
        for (i, c) in [
            (ivx, "hip_vx_m_s"),
            (ivy, "hip_vy_m_s"),
            (ivz, "hip_vz_m_s"),
            (ip, "pitch_rad"),
        ] {
            if i.is_some() {
                return Err(DatasetError::HipWithoutHeight {
                    path: name.to_string(),
                    column: c,
                });
            }
        }
    }
    let mut hips = ih.map(|_| Vec::new());
    let mut out = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(malformed)?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let cell = |i: usize, column: &'static str| -> Result<f64, DatasetError> {
            let v = rec.get(i).unwrap_or("");
            v.parse::<f64>().map_err(|_| DatasetError::NotANumber {
                path: name.to_string(),
                line,
                column,
                value: v.to_string(),
            })
        };
        out.push(Sample {
            t_s: it.map(|i| cell(i, "t_s")).transpose()?,
            beta_rad: cell(ib, beta_column)? * to_rad,
            drag_n: cell(id, "drag_n")?,
            lift_n: cell(il, "lift_n")?,
        });
        if let (Some(hips), Some(ih)) = (hips.as_mut(), ih) {
            hips.push(HipRow {
                height_m: cell(ih, "hip_height_m")?,
                vx_m_s: ivx.map(|i| cell(i, "hip_vx_m_s")).transpose()?,
                vy_m_s: ivy.map(|i| cell(i, "hip_vy_m_s")).transpose()?,
                vz_m_s: ivz.map(|i| cell(i, "hip_vz_m_s")).transpose()?,
                pitch_rad: ip.map(|i| cell(i, "pitch_rad")).transpose()?,
            });
        }
    }
    Ok(ForceLog { samples: out, hips })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_columns_in_any_order_and_keeps_nan_for_counting() {
        let s = read_samples(
            "lift_n,regime,beta_rad,drag_n\n1,a,0.5,2\nnan,b,0.6,3\n".as_bytes(),
            "t",
        )
        .unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(
            (s[0].beta_rad, s[0].drag_n, s[0].lift_n, s[0].t_s),
            (0.5, 2.0, 1.0, None)
        );
        assert!(s[1].lift_n.is_nan());
    }

    #[test]
    fn an_unknown_column_is_refused_and_hip_columns_are_read() {
        let e = read_samples(
            "t_s,beta_rad,drag_n,lift_n,hip_heigth_m\n0,0,0,0,0\n".as_bytes(),
            "d.csv",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("unknown column \"hip_heigth_m\"")
                && e.contains("did you mean hip_height_m?"),
            "{e}"
        );
        let log = read_log_from(
            "t_s,beta_rad,drag_n,lift_n,hip_height_m,hip_vz_m_s\n0,0,0,1,-0.01,-0.005\n".as_bytes(),
            "d.csv",
        )
        .unwrap();
        let h = log.hips.unwrap()[0];
        assert_eq!(
            (h.height_m, h.vz_m_s, h.vx_m_s),
            (-0.01, Some(-0.005), None)
        );
        // A command that takes no hip says so rather than ignoring it.
        let e = read_samples(
            "t_s,beta_rad,drag_n,lift_n,hip_height_m\n0,0,0,1,-0.01\n".as_bytes(),
            "d.csv",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("only replay --reevaluate"), "{e}");
        let e = read_log_from(
            "beta_rad,drag_n,lift_n,pitch_rad\n0,0,0,0\n".as_bytes(),
            "d.csv",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("pitch_rad needs hip_height_m"), "{e}");
    }

    #[test]
    fn beta_deg_stands_in_for_beta_rad() {
        let s = read_samples("beta_deg,drag_n,lift_n\n90,1,2\n".as_bytes(), "t").unwrap();
        assert!((s[0].beta_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    }

    #[test]
    fn errors_name_the_line_and_column() {
        let e = read_samples(
            "beta_rad,drag_n,lift_n\n0.5,1,2\n0.6,abc,2\n".as_bytes(),
            "d.csv",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "d.csv line 3, column drag_n: \"abc\" is not a number"
        );
        let e = read_samples("beta,drag_n,lift_n\n".as_bytes(), "d.csv").unwrap_err();
        assert!(e.to_string().contains("beta_rad"), "{e}");
        let e = read_samples("".as_bytes(), "d.csv").unwrap_err();
        assert!(e.to_string().contains("empty"), "{e}");
        let e = read_samples("beta_rad,drag_n,lift_n\n1,2\n".as_bytes(), "d.csv").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
    }
}
