//! Reading force logs: CSV with a header that names at least `beta_rad,drag_n,lift_n`
//! (optionally `t_s`; other columns are ignored). A `beta_deg` column stands in for `beta_rad`,
//! so that the output of `terzaghi predict` reads back. Cells `nan`/`inf` are kept as samples for the
//! identification to count and skip; a cell that is not a number is an error naming its line.

use crate::ident::Sample;
use std::io::Read;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    #[error("cannot read {path}: {error}")]
    Io { path: String, error: std::io::Error },
    #[error("{path}: empty file (expected a header with beta_rad,drag_n,lift_n)")]
    Empty { path: String },
    #[error("{path}: header lacks column {column:?} (found: {found})")]
    MissingColumn {
        path: String,
        column: &'static str,
        found: String,
    },
    #[error("{path} line {line}, column {column}: {value:?} is not a number")]
    NotANumber {
        path: String,
        line: u64,
        column: &'static str,
        value: String,
    },
    #[error("{path} line {line}: {message}")]
    Malformed {
        path: String,
        line: u64,
        message: String,
    },
}

/// Reads the samples of a CSV file.
pub fn read_samples_csv(path: &Path) -> Result<Vec<Sample>, DatasetError> {
    let name = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|error| DatasetError::Io {
        path: name.clone(),
        error,
    })?;
    read_samples(file, &name)
}

/// Reads samples from any CSV reader; `name` is used in messages.
pub fn read_samples<R: Read>(input: R, name: &str) -> Result<Vec<Sample>, DatasetError> {
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
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_columns_in_any_order_and_keeps_nan_for_counting() {
        let s = read_samples(
            "lift_n,x,beta_rad,drag_n\n1,a,0.5,2\nnan,b,0.6,3\n".as_bytes(),
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
