//! The chamber's setpoints a session states (`# rh_levels=`), in the order it visited them.
//!
//! A chamber logs what it was driven to beside what its sensor read: the setpoint is a second,
//! independent account of each level's humidity (the sensor's read error is not in it). Forms:
//! `38,40,45` (up, once each), `38,40,45 then down` (up, then back through all but the top),
//! `45,60,75,60,45 (steps)` (as listed). A value the tool cannot read in full is no statement.

use crate::Metadata;

/// The metadata key.
pub const SETPOINTS_KEY: &str = "rh_levels";

/// The setpoints in visiting order, or None where the recording states none or states them in a
/// form this reader does not know.
pub fn stated_setpoints(metadata: &Metadata) -> Option<Vec<f64>> {
    let value = metadata.get(SETPOINTS_KEY)?.trim();
    let (list, down) = match value.split_once(char::is_whitespace) {
        None => (value, false),
        Some((list, rest)) => match rest.trim() {
            "then down" => (list, true),
            "(steps)" => (list, false),
            _ => return None,
        },
    };
    let up: Vec<f64> = list
        .split(',')
        .map(|v| v.trim().parse::<f64>().ok().filter(|x| x.is_finite() && (0.0..=100.0).contains(x)))
        .collect::<Option<_>>()?;
    if up.is_empty() {
        return None;
    }
    let mut order = up.clone();
    if down {
        order.extend(up.iter().rev().skip(1));
    }
    Some(order)
}

/// How a session's setpoints are stated: visited up once each, or as listed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetpointForm {
    Up,
    Steps,
}

/// The `# rh_levels=` value stating `levels` in `form`, as [`stated_setpoints`] reads it back.
pub fn setpoints_text(levels: &[f64], form: SetpointForm) -> String {
    let list = levels.iter().map(|l| l.to_string()).collect::<Vec<_>>().join(",");
    match form {
        SetpointForm::Up => list,
        SetpointForm::Steps => format!("{list} (steps)"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(v: &str) -> Metadata {
        let mut m = Metadata::default();
        m.set(SETPOINTS_KEY, v);
        m
    }

    #[test]
    fn reads_the_three_forms() {
        assert_eq!(stated_setpoints(&with("38,40,45")), Some(vec![38.0, 40.0, 45.0]));
        assert_eq!(stated_setpoints(&with("38,40,45 then down")), Some(vec![38.0, 40.0, 45.0, 40.0, 38.0]));
        assert_eq!(stated_setpoints(&with("45,60,75,60,45 (steps)")), Some(vec![45.0, 60.0, 75.0, 60.0, 45.0]));
    }

    #[test]
    fn what_is_written_reads_back() {
        let levels = [45.0, 60.0, 72.5, 60.0, 45.0];
        assert_eq!(setpoints_text(&levels, SetpointForm::Steps), "45,60,72.5,60,45 (steps)");
        assert_eq!(stated_setpoints(&with(&setpoints_text(&levels, SetpointForm::Steps))), Some(levels.to_vec()));
        assert_eq!(stated_setpoints(&with(&setpoints_text(&levels[..3], SetpointForm::Up))), Some(levels[..3].to_vec()));
    }

    #[test]
    fn what_it_cannot_read_in_full_is_no_statement() {
        assert_eq!(stated_setpoints(&Metadata::default()), None);
        assert_eq!(stated_setpoints(&with("38,40,x")), None);
        assert_eq!(stated_setpoints(&with("38,40 then up")), None);
        assert_eq!(stated_setpoints(&with("38,140")), None);
        assert_eq!(stated_setpoints(&with("")), None);
    }
}
