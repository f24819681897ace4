//! A plate-sinkage test as a bevameter exports it: lines of free text, then a header that names
//! the force (or pressure) and the sinkage with their units, `Force (N), Sinkage (mm)`, then
//! one pair per line and no time. Loading is told from the sinkage's own sequence: each row is
//! given a time one millisecond after the one before, so that a row deeper than the ones before
//! it is the plate moving down ([`crate::model::sinkage::sinkage_regimes`]).

use crate::model::sinkage::PlateShape;
use anyhow::{Result, bail};

/// The rows of an export: `(depth_m, force_n, line)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Export {
    /// Its rows, in the file's order.
    pub rows: Vec<(f64, f64, usize)>,
    /// Lines of free text before the header.
    pub preamble_lines: usize,
    /// The plate its free text names (`Plate: disc 45 mm`, `Plate: rectangle 50 x 100 mm`).
    pub plate: Option<PlateShape>,
}

/// The plate a line of free text names: `plate ... disc D mm` (or `diameter D mm`), `plate ...
/// rectangle W x L mm` (mm, cm or m); `None` where the line names none; an error naming the
/// line where it names one that is no plate (zero or negative).
fn plate_of(line: &str, file: &str, at: usize) -> Result<Option<PlateShape>> {
    let l = line.to_ascii_lowercase();
    if !l.contains("plate") {
        return Ok(None);
    }
    let unit = if l.contains("mm") {
        1e-3
    } else if l.contains("cm") {
        1e-2
    } else if l.trim_end().ends_with('m') {
        1.0
    } else {
        return Ok(None);
    };
    let nums: Vec<f64> = l
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .filter_map(|t| t.parse::<f64>().ok())
        .collect();
    let shape = if l.contains("disc") || l.contains("diameter") || l.contains("circular") {
        match nums.first() {
            Some(d) => PlateShape::disc(d * unit),
            None => return Ok(None),
        }
    } else if l.contains("rectangle") || l.contains(" x ") {
        match nums.as_slice() {
            [w, len, ..] => PlateShape::rectangle(w * unit, len * unit),
            _ => return Ok(None),
        }
    } else {
        return Ok(None);
    };
    shape
        .map(Some)
        .map_err(|e| anyhow::anyhow!("{file} line {at}: {e} ({:?})", line.trim()))
}

/// The time a row of an export is given after the one before it (s).
pub const ROW_STEP_S: f64 = 1e-3;

fn split(line: &str) -> Vec<&str> {
    let sep = if line.contains('\t') {
        '\t'
    } else if line.contains(';') {
        ';'
    } else {
        ','
    };
    line.split(sep).map(str::trim).collect()
}

fn numbers(line: &str) -> Option<Vec<f64>> {
    let cells = split(line);
    if cells.len() < 2 {
        return None;
    }
    cells.iter().map(|c| c.parse::<f64>().ok()).collect()
}

/// What a header cell names: `(kind, factor to SI)`, kind `force`, `pressure` or `sinkage`.
fn column(name: &str, file: &str, line: usize) -> Result<Option<(&'static str, f64)>> {
    let lower = name.to_ascii_lowercase();
    let kind = if lower.contains("force") || lower.contains("load") {
        "force"
    } else if lower.contains("pressure") || lower.contains("stress") {
        "pressure"
    } else if lower.contains("sinkage") || lower.contains("depth") || lower.contains("displacement")
    {
        "sinkage"
    } else {
        return Ok(None);
    };
    let unit = lower
        .split(['(', '['])
        .nth(1)
        .map(|u| u.trim_end_matches([')', ']']).trim().to_string());
    let Some(unit) = unit else {
        bail!(
            "{file} line {line}: column {name:?} gives no unit: write it in the header, as \"Force (N)\", \"Sinkage (mm)\""
        );
    };
    let factor = match (kind, unit.as_str()) {
        ("force", "n") => 1.0,
        ("force", "kn") => 1e3,
        ("pressure", "pa") => 1.0,
        ("pressure", "kpa") => 1e3,
        ("pressure", "mpa") => 1e6,
        ("sinkage", "mm") => 1e-3,
        ("sinkage", "cm") => 1e-2,
        ("sinkage", "m") => 1.0,
        _ => bail!(
            "{file} line {line}: unit {unit:?} of column {name:?} does not parse (a force in N or kN, a pressure in Pa, kPa or MPa, a sinkage in mm, cm or m)"
        ),
    };
    Ok(Some((kind, factor)))
}

/// The export in `text` (the file `file`), or `None` where `text` is not one (its first line is
/// a CSV header of the other layouts, or no line before its numbers names a force and a
/// sinkage). A pressure needs `plate` (its area); an export of no rows, or of one, a header
/// with no numbers after it and a value that is no number are errors naming file and line.
pub fn parse_export(file: &str, text: &str, plate: Option<PlateShape>) -> Result<Option<Export>> {
    let lines: Vec<&str> = text.lines().collect();
    let first_data = lines
        .iter()
        .position(|l| numbers(l).is_some_and(|v| v.iter().all(|x| x.is_finite())));
    // The header: the last line of text before the numbers (or the last line of all).
    let header_at = match first_data {
        Some(0) => return Ok(None),
        Some(i) => i - 1,
        None => match lines.iter().rposition(|l| !l.trim().is_empty()) {
            Some(i) => i,
            None => return Ok(None),
        },
    };
    let cells = split(lines[header_at]);
    // The other layouts' headers name their columns exactly, units in the names.
    const OTHER_LAYOUTS: [&str; 5] = ["t_s", "time_s", "depth_m", "force_n", "fz_n"];
    if cells.iter().any(|c| OTHER_LAYOUTS.contains(c)) {
        return Ok(None);
    }
    let mut force = None;
    let mut sinkage = None;
    for (k, c) in cells.iter().enumerate() {
        match column(c, file, header_at + 1) {
            Ok(Some(("sinkage", f))) => sinkage = Some((k, f)),
            Ok(Some((kind, f))) => force = Some((k, kind, f)),
            Ok(None) => {}
            // Units that do not parse, in a header that names both: the user's export.
            Err(e) if has_both(&cells) => return Err(e),
            Err(_) => return Ok(None),
        }
    }
    let (Some((i_force, kind, f_force)), Some((i_sink, f_sink))) = (force, sinkage) else {
        return Ok(None);
    };
    let Some(start) = first_data else {
        bail!(
            "{file} line {}: a header ({}) with no rows of numbers after it",
            header_at + 1,
            lines[header_at].trim()
        );
    };
    let mut named = None;
    for (k, l) in lines.iter().enumerate().take(header_at) {
        if let Some(p) = plate_of(l, file, k + 1)? {
            named = Some(p);
        }
    }
    let area = match (kind, plate.or(named)) {
        ("pressure", Some(p)) => p.area_m2(),
        ("pressure", None) => bail!(
            "{file} line {}: a pressure column needs the plate's area: give its plate (--plate-diameter-m, or --plate-width-m and --plate-length-m)",
            header_at + 1
        ),
        _ => 1.0,
    };
    let mut rows = Vec::new();
    for (k, l) in lines.iter().enumerate().skip(start) {
        if l.trim().is_empty() {
            continue;
        }
        let cells = split(l);
        let value = |i: usize, what: &str| -> Result<f64> {
            let c = cells.get(i).copied().unwrap_or("");
            match c.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => bail!("{file} line {}: {what} {c:?} is not a number", k + 1),
            }
        };
        let force_n = value(i_force, cells_name(kind))? * f_force * area;
        let depth_m = value(i_sink, "sinkage")? * f_sink;
        rows.push((depth_m, force_n, k + 1));
    }
    if rows.len() < 2 {
        bail!(
            "{file}: {} row{} of numbers after its header (line {}): a test needs its loading, row by row",
            rows.len(),
            if rows.len() == 1 { "" } else { "s" },
            header_at + 1
        );
    }
    Ok(Some(Export {
        rows,
        preamble_lines: header_at,
        plate: named,
    }))
}

fn cells_name(kind: &str) -> &'static str {
    if kind == "pressure" {
        "pressure"
    } else {
        "force"
    }
}

fn has_both(cells: &[&str]) -> bool {
    let l: Vec<String> = cells.iter().map(|c| c.to_ascii_lowercase()).collect();
    l.iter()
        .any(|c| c.contains("force") || c.contains("load") || c.contains("pressure"))
        && l.iter()
            .any(|c| c.contains("sinkage") || c.contains("depth") || c.contains("displacement"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_export_is_read_with_its_units_and_bad_ones_are_named() {
        let text = "Bevameter export\nsoil: JSC-1A\ntrial 3\nForce (kN), Sinkage (mm)\n0.01,1.0\n0.02,2.0\n";
        let e = parse_export("t.csv", text, None).unwrap().unwrap();
        assert_eq!(e.preamble_lines, 3);
        assert_eq!(e.rows, vec![(1e-3, 10.0, 5), (2e-3, 20.0, 6)]);
        assert_eq!(e.plate, None);
        let named = "Plate: disc 45 mm\nForce (N), Sinkage (mm)\n1,1\n2,2\n";
        let e = parse_export("t.csv", named, None).unwrap().unwrap();
        assert_eq!(e.plate, Some(PlateShape::disc(0.045).unwrap()));
        let e = parse_export(
            "t.csv",
            "Plate: rectangle 50 x 100 mm\nForce (N), Sinkage (mm)\n1,1\n2,2\n",
            None,
        )
        .unwrap()
        .unwrap();
        assert_eq!(e.plate, Some(PlateShape::rectangle(0.05, 0.1).unwrap()));
        let e = parse_export(
            "t.csv",
            "Plate: disc 0 mm\nForce (N), Sinkage (mm)\n1,1\n2,2\n",
            None,
        )
        .unwrap_err();
        assert!(e.to_string().contains("t.csv line 1"), "{e}");
        // The other layouts are no export.
        assert!(
            parse_export("t.csv", "t_s,depth_m,force_n\n0,0,0\n", None)
                .unwrap()
                .is_none()
        );
        let e = parse_export("t.csv", "Force (lbf), Sinkage (mm)\n1,2\n3,4\n", None).unwrap_err();
        assert!(e.to_string().contains("t.csv line 1: unit \"lbf\""), "{e}");
        let e = parse_export("t.csv", "Force (N), Sinkage (mm)\n", None).unwrap_err();
        assert!(e.to_string().contains("no rows of numbers"), "{e}");
        let e = parse_export("t.csv", "Force (N), Sinkage (mm)\n1,2\n", None).unwrap_err();
        assert!(e.to_string().contains("1 row of numbers"), "{e}");
        let e = parse_export("t.csv", "Force (N), Sinkage (mm)\n1,2\n3,x\n", None).unwrap_err();
        assert!(e.to_string().contains("t.csv line 3: sinkage \"x\""), "{e}");
        let e =
            parse_export("t.csv", "Pressure (kPa), Sinkage (mm)\n1,2\n3,4\n", None).unwrap_err();
        assert!(e.to_string().contains("needs the plate's area"), "{e}");
        let disc = PlateShape::disc(0.1).unwrap();
        let e = parse_export(
            "t.csv",
            "Pressure (kPa); Sinkage (m)\n1;0.002\n2;0.004\n",
            Some(disc),
        )
        .unwrap()
        .unwrap();
        assert!((e.rows[1].1 - 2e3 * disc.area_m2()).abs() < 1e-9);
    }
}
