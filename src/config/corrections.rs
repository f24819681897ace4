//! A leg's corrected model as node parameters (`<leg>.corrections.*`), read and validated, and
//! written back as a params file (what `terzaghi diagnose` writes as `corrected.yaml`).
//!
//! ```yaml
//! front_left:
//!   b_k: 24.2
//!   a: 1.91
//!   corrections:
//!     effects: [surcharge, extraction]     # the terms in use, in the order fitted
//!     typical_speed_rad_s: 3.1             # what rate measures speed against
//!     session_strokes: 20                  # compaction's stroke position
//!     fitted_for: {length_m: 0.1, width_m: 0.05, hip_height_m: 0.07, unit_weight_n_m3: 6700.0,
//!                  phi_deg: 30.0, delta_deg: 20.0}
//!     surcharge: {normal_n_m4: 1.2e5, tangential_n_m4: 3.0e4}
//!     extraction: {drag_scale: -0.3, lift_scale: 0.2, slope_per_rad: 0.1}
//! ```
//!
//! `fitted_for` is the leg the corrections were fitted for: a file fitted for another plate,
//! hip height or medium is refused, naming what differs.

use super::{ConfigError, ParamMap, ParamValue, invalid};
use crate::model::corrections::{ALL, Corrections, CorrectionsError, Effect, Nonlinear, Term};
use crate::model::{Medium, Plate};

/// The keys of `fitted_for`, each with the leg's value it must match.
const FITTED_FOR: [&str; 6] = [
    "length_m",
    "width_m",
    "hip_height_m",
    "unit_weight_n_m3",
    "phi_deg",
    "delta_deg",
];

fn leg_values(plate: &Plate, medium: &Medium) -> [f64; 6] {
    [
        plate.length_m(),
        plate.width_m(),
        plate.hip_height_m(),
        medium.unit_weight_n_m3(),
        medium.phi_deg(),
        medium.delta_deg(),
    ]
}

/// Whether `key` (after `<leg>.`) is a corrections parameter this version knows.
pub fn is_corrections_key(key: &str) -> bool {
    let Some(rest) = key.strip_prefix("corrections.") else {
        return false;
    };
    match rest.split_once('.') {
        None => matches!(rest, "effects" | "typical_speed_rad_s" | "session_strokes"),
        Some(("fitted_for", k)) => FITTED_FOR.contains(&k),
        Some((effect, param)) => Effect::from_name(effect).is_some_and(|e| {
            e.linear_params().contains(&param) || e.nonlinear_param() == Some(param)
        }),
    }
}

/// The corrections of leg `leg` (whose plate and medium are given, and whose fitting width is
/// `b_k, a`), if `<leg>.corrections.effects` is set; every value checked against its bounds.
pub fn leg_corrections(
    params: &ParamMap,
    leg: &str,
    plate: &Plate,
    medium: &Medium,
    b_k: f64,
    a: f64,
) -> Result<Option<Corrections>, ConfigError> {
    let key = |s: &str| format!("{leg}.corrections.{s}");
    for k in params.keys() {
        if let Some(rest) = k.strip_prefix(&format!("{leg}."))
            && rest.starts_with("corrections.")
            && !is_corrections_key(rest)
        {
            return Err(invalid(
                k,
                &params[k],
                format!(
                    "unknown corrections parameter; known: effects, typical_speed_rad_s, session_strokes, fitted_for.{{{}}}, and <effect>.<parameter> for the effects {}",
                    FITTED_FOR.join(","),
                    ALL.map(Effect::name).join(", ")
                ),
            ));
        }
    }
    let effects_key = key("effects");
    let names: Vec<String> = match params.get(&effects_key) {
        None => return Ok(None),
        Some(ParamValue::StringArray(v)) => v.clone(),
        Some(ParamValue::String(s)) if s.is_empty() => Vec::new(),
        Some(ParamValue::String(s)) => vec![s.clone()],
        Some(v) => {
            return Err(invalid(&effects_key, v, "expected a list of effect names"));
        }
    };
    let number = |k: &str| -> Result<Option<f64>, ConfigError> {
        match params.get(k) {
            None => Ok(None),
            Some(ParamValue::Double(x)) if x.is_finite() => Ok(Some(*x)),
            Some(ParamValue::Int(x)) => Ok(Some(*x as f64)),
            Some(v) => Err(invalid(k, v, "expected a finite number")),
        }
    };
    let need = |k: String, what: &str| -> Result<f64, ConfigError> {
        number(&k)?.ok_or_else(|| ConfigError::Missing {
            name: k.clone(),
            hint: format!("{what} (terzaghi diagnose writes it in corrected.yaml)"),
        })
    };
    // The leg the corrections were fitted for must be this one.
    let ours = leg_values(plate, medium);
    for (name, v) in FITTED_FOR.iter().zip(ours) {
        let k = key(&format!("fitted_for.{name}"));
        if let Some(f) = number(&k)?
            && (f - v).abs() > 1e-6 * v.abs().max(1e-3)
        {
            return Err(invalid(
                &k,
                &f,
                format!(
                    "the corrections were fitted for a leg with {name} {f}, this leg has {leg}.{name} = {v}: they belong to another robot, geometry or medium (diagnose a session of this leg)"
                ),
            ));
        }
    }
    let mut c = Corrections::none(b_k, a);
    let mut nonlinear = Nonlinear::default();
    for name in &names {
        let Some(e) = Effect::from_name(name) else {
            return Err(invalid(
                &effects_key,
                &format!("{names:?}"),
                format!(
                    "unknown effect {name:?}; known: {}",
                    ALL.map(Effect::name).join(", ")
                ),
            ));
        };
        let mut coefficients = Vec::new();
        for p in e.linear_params() {
            coefficients.push(need(
                key(&format!("{name}.{p}")),
                "a coefficient of a listed effect",
            )?);
        }
        if let Some(p) = e.nonlinear_param() {
            nonlinear = nonlinear.with(
                e,
                need(key(&format!("{name}.{p}")), "a listed effect's parameter")?,
            );
        }
        c.terms.push(Term {
            effect: e,
            coefficients,
        });
    }
    c.nonlinear = nonlinear;
    if c.has(Effect::Rate) {
        c.typical_speed_rad_s = need(key("typical_speed_rad_s"), "rate measures speed against it")?;
    }
    if c.has(Effect::Compaction) {
        let k = key("session_strokes");
        let v = need(
            k.clone(),
            "compaction's change is placed among the session's strokes",
        )?;
        if !(v >= 2.0 && v.fract() == 0.0 && v <= 1e9) {
            return Err(invalid(
                &k,
                &v,
                "expected a whole number of strokes, at least 2",
            ));
        }
        c.session_strokes = v as usize;
    }
    c.validate(plate.length_m()).map_err(|e| match e {
        CorrectionsError::OutOfBounds {
            effect,
            param,
            value,
            lo,
            hi,
        } => invalid(
            &key(&effect.value_name(&param)),
            &value,
            format!("outside its physical bounds [{lo}, {hi}]"),
        ),
        CorrectionsError::Invalid {
            name,
            value,
            expected,
            ..
        } => {
            let k = if matches!(name, "b_k" | "a") {
                format!("{leg}.{name}")
            } else {
                key(name)
            };
            invalid(&k, &value, format!("must be {expected}"))
        }
        other => invalid(&effects_key, &format!("{names:?}"), other.to_string()),
    })?;
    Ok(Some(c))
}

/// The parameters of leg `leg`'s corrections, as [`leg_corrections`] reads them back (with
/// `fitted_for` this leg's plate and medium).
pub fn corrections_params(
    leg: &str,
    plate: &Plate,
    medium: &Medium,
    c: &Corrections,
) -> Vec<(String, ParamValue)> {
    let key = |s: &str| format!("{leg}.corrections.{s}");
    let mut out = vec![
        (format!("{leg}.b_k"), ParamValue::Double(c.b_k)),
        (format!("{leg}.a"), ParamValue::Double(c.a)),
        (
            key("effects"),
            ParamValue::StringArray(c.terms.iter().map(|t| t.effect.name().into()).collect()),
        ),
    ];
    if c.has(Effect::Rate) {
        out.push((
            key("typical_speed_rad_s"),
            ParamValue::Double(c.typical_speed_rad_s),
        ));
    }
    if c.has(Effect::Compaction) {
        out.push((
            key("session_strokes"),
            ParamValue::Int(c.session_strokes as i64),
        ));
    }
    for (name, v) in FITTED_FOR.iter().zip(leg_values(plate, medium)) {
        out.push((key(&format!("fitted_for.{name}")), ParamValue::Double(v)));
    }
    for t in &c.terms {
        let e = t.effect;
        for (p, v) in e.linear_params().iter().zip(&t.coefficients) {
            out.push((key(&e.value_name(p)), ParamValue::Double(*v)));
        }
        if let Some(p) = e.nonlinear_param() {
            out.push((
                key(&e.value_name(p)),
                ParamValue::Double(c.nonlinear.get(e)),
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leg() -> (Plate, Medium) {
        (
            Plate::new(0.25, 0.06, 0.15).unwrap(),
            Medium::new(16170.0, 32.0, 19.0).unwrap(),
        )
    }

    fn sample() -> Corrections {
        let mut c = Corrections::none(2.0, 1.5);
        c.terms.push(Term {
            effect: Effect::Surcharge,
            coefficients: vec![1.5e5, -2.0e4],
        });
        c.terms.push(Term {
            effect: Effect::Rate,
            coefficients: vec![10.0, 2.0, 0.1, 0.05],
        });
        c.terms.push(Term {
            effect: Effect::SensorLag,
            coefficients: vec![],
        });
        c.nonlinear = Nonlinear {
            speed_exponent: 1.5,
            lag_s: 0.02,
            ..Default::default()
        };
        c.typical_speed_rad_s = 3.0;
        c
    }

    #[test]
    fn written_parameters_read_back_as_the_same_corrections() {
        let (p, m) = leg();
        let c = sample();
        let params: ParamMap = corrections_params("fl", &p, &m, &c).into_iter().collect();
        let back = leg_corrections(&params, "fl", &p, &m, 2.0, 1.5)
            .unwrap()
            .unwrap();
        assert_eq!(back, c);
        // No effects key: no corrections.
        assert_eq!(
            leg_corrections(&ParamMap::new(), "fl", &p, &m, 1.0, 1.0).unwrap(),
            None
        );
    }

    #[test]
    fn another_leg_a_missing_coefficient_and_a_bad_value_are_refused_by_name() {
        let (p, m) = leg();
        let mut params: ParamMap = corrections_params("fl", &p, &m, &sample())
            .into_iter()
            .collect();
        let other = Plate::new(0.25, 0.06, 0.12).unwrap();
        let e = leg_corrections(&params, "fl", &other, &m, 2.0, 1.5).unwrap_err();
        assert!(
            e.to_string()
                .contains("fl.corrections.fitted_for.hip_height_m = 0.15"),
            "{e}"
        );
        params.insert(
            "fl.corrections.sensor_lag.time_constant_s".into(),
            ParamValue::Double(-1.0),
        );
        let e = leg_corrections(&params, "fl", &p, &m, 2.0, 1.5).unwrap_err();
        assert!(
            e.to_string().contains(
                "fl.corrections.sensor_lag.time_constant_s = -1: outside its physical bounds"
            ),
            "{e}"
        );
        params.remove("fl.corrections.surcharge.normal_n_m4");
        let e = leg_corrections(&params, "fl", &p, &m, 2.0, 1.5).unwrap_err();
        assert!(
            e.to_string()
                .contains("fl.corrections.surcharge.normal_n_m4 is required"),
            "{e}"
        );
        params.insert("fl.corrections.moisture.x".into(), ParamValue::Double(1.0));
        let e = leg_corrections(&params, "fl", &p, &m, 2.0, 1.5).unwrap_err();
        assert!(
            e.to_string().contains("unknown corrections parameter"),
            "{e}"
        );
    }
}
