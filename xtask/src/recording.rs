//! Reads time-series recordings (shared/recording-format.md §2): the columns the replay needs
//! (`t_s`, `current_a`, `rh_pct`) and the `# fs_hz=N` metadata.

use std::{collections::HashMap, path::Path};

use crate::Result;

pub struct Recording {
    pub fs_hz: f64,
    pub t_s: Vec<f64>,
    pub current_a: Vec<f64>,
    pub rh_pct: Vec<f64>,
}

pub fn read(path: &Path) -> Result<Recording> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse(&text, &path.display().to_string())
}

pub fn parse(text: &str, name: &str) -> Result<Recording> {
    let mut metadata = HashMap::new();
    let mut header: Option<Vec<String>> = None;
    let mut cols = [0usize; 3];
    let mut rec = Recording { fs_hz: f64::NAN, t_s: vec![], current_a: vec![], rh_pct: vec![] };
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(comment) = line.strip_prefix('#') {
            if let Some((k, v)) = comment.trim().split_once('=') {
                metadata.insert(k.trim().to_string(), v.trim().to_string());
            }
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some(names) = &header else {
            let names: Vec<String> = fields.iter().map(|s| s.to_string()).collect();
            for (slot, want) in cols.iter_mut().zip(["t_s", "current_a", "rh_pct"]) {
                *slot = names
                    .iter()
                    .position(|n| n == want)
                    .ok_or_else(|| format!("{name}:{line_no}: missing required column `{want}`"))?;
            }
            for n in &names {
                if !["t_s", "current_a", "rh_pct", "base_m", "tip_m", "temp_c"].contains(&n.as_str()) {
                    eprintln!("warning: {name}: unknown column `{n}` ignored");
                }
            }
            header = Some(names);
            continue;
        };
        if fields.len() != names.len() {
            return Err(format!("{name}:{line_no}: {} fields, header has {}", fields.len(), names.len()));
        }
        let mut values = [0.0f64; 3];
        for (v, &c) in values.iter_mut().zip(cols.iter()) {
            *v = fields[c]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("{name}:{line_no}: column `{}`: not a finite number: `{}`", names[c], fields[c]))?;
        }
        rec.t_s.push(values[0]);
        rec.current_a.push(values[1]);
        rec.rh_pct.push(values[2]);
    }
    if header.is_none() {
        return Err(format!("{name}: no header line"));
    }
    rec.fs_hz = match metadata.get("fs_hz") {
        Some(v) => v.parse().map_err(|_| format!("{name}: metadata fs_hz=`{v}` is not a number"))?,
        // No metadata: the rate of the first burst.
        None if rec.t_s.len() >= 2 && rec.t_s[1] > rec.t_s[0] => 1.0 / (rec.t_s[1] - rec.t_s[0]),
        None => return Err(format!("{name}: no `# fs_hz=N` metadata and too few samples to infer it")),
    };
    Ok(rec)
}

#[cfg(test)]
mod tests {
    use super::parse;

    #[test]
    fn columns_by_name_and_metadata() {
        let r = parse("# fs_hz=2000\n# sample=X\nrh_pct,t_s,base_m,current_a\n45,0,1e-3,1e-7\n45.5,0.0005,0,-2e-7\n", "m").unwrap();
        assert_eq!(r.fs_hz, 2000.0);
        assert_eq!(r.t_s, vec![0.0, 0.0005]);
        assert_eq!(r.current_a, vec![1e-7, -2e-7]);
        assert_eq!(r.rh_pct, vec![45.0, 45.5]);
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = parse("t_s,current_a\n0,1\n", "f.csv").err().unwrap();
        assert!(e.contains("f.csv:1") && e.contains("rh_pct"), "{e}");
        let e = parse("t_s,current_a,rh_pct\n0,nan,45\n", "f.csv").err().unwrap();
        assert!(e.contains("f.csv:2") && e.contains("current_a"), "{e}");
        let e = parse("t_s,current_a,rh_pct\n0,1\n", "f.csv").err().unwrap();
        assert!(e.contains("f.csv:2"), "{e}");
    }
}

/// One column of a CSV in the interchange conventions (`#` comments, header names the columns),
/// by name; `None` if the header has no such column. A row whose field is not a finite number is
/// an error naming file, line and column.
pub fn read_column(path: &Path, name: &str) -> Result<Option<Vec<f64>>> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut col = None;
    let mut out = vec![];
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some(c) = col else {
            match fields.iter().position(|f| *f == name) {
                Some(c) => col = Some(c),
                None => return Ok(None),
            }
            continue;
        };
        let v = fields
            .get(c)
            .and_then(|f| f.parse::<f64>().ok())
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{}:{}: column {} (`{name}`): not a finite number", path.display(), i + 1, c + 1))?;
        out.push(v);
    }
    Ok(Some(out))
}

/// A column that must be there.
pub fn require_column(path: &Path, name: &str) -> Result<Vec<f64>> {
    read_column(path, name)?.ok_or_else(|| format!("{}: no {name} column", path.display()))
}
