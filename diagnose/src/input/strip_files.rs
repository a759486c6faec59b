//! The files of one strip a diagnosis reads: its primary recordings and their follow-ups
//! (recording-format.md, "Follow-up recordings"), each read once and checked against the others.

use anyhow::{Context, Result, bail};
use ipmc_fit::recordings::{Responses, responses};
use ipmc_recording::{Followup, Format, HumidityReference, Table};
use std::path::{Path, PathBuf};

/// What a file holds: the strip's response (a frequency response, or a time series estimated
/// into one) or the humidity sensor at references.
pub enum Content {
    Response(Responses),
    Reference(HumidityReference),
}

pub struct StripFile {
    pub path: PathBuf,
    /// `None` for a primary recording.
    pub followup: Option<Followup>,
    pub content: Content,
}

impl StripFile {
    pub fn name(&self) -> String {
        self.path.display().to_string()
    }
}

/// The follow-ups one diagnosis reads.
pub const MAX_FOLLOWUPS: usize = 2;

/// Reads every file (at most [`MAX_FOLLOWUPS`] follow-ups, no protocol twice). A follow-up's `# strip=` must name (by file name) a primary given with it,
/// and at least one file must be a response: a reference says nothing of the strip alone.
pub fn read(paths: &[PathBuf]) -> Result<Vec<StripFile>> {
    let mut files = Vec::with_capacity(paths.len());
    for path in paths {
        let table = Table::read(path)?;
        let source = path.display().to_string();
        let followup = Followup::of(&table.metadata, &source)?;
        let content = if table.find("reference_rh_pct").is_some() {
            let (r, warnings) = HumidityReference::from_table(&table)?;
            for w in warnings {
                eprintln!("warning: {w}");
            }
            Content::Reference(r)
        } else {
            Content::Response(responses(path).with_context(|| format!("reading {source}"))?)
        };
        files.push(StripFile { path: path.clone(), followup, content });
    }
    let primaries: Vec<&Path> = files.iter().filter(|f| f.followup.is_none()).map(|f| f.path.as_path()).collect();
    for f in &files {
        if let Some(up) = &f.followup
            && !primaries.iter().any(|p| up.names(p))
        {
            bail!(
                "{}: `# strip={}` (a {} follow-up) names no primary recording given with it ({})",
                f.name(),
                up.strip,
                up.protocol,
                if primaries.is_empty() {
                    "every file given is a follow-up".to_string()
                } else {
                    format!("given: {}", primaries.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "))
                }
            );
        }
    }
    // A plan takes at most two follow-ups, each protocol once: a protocol taken again would be
    // the same question asked twice, and the engine's layout offers each once.
    let ups: Vec<&Followup> = files.iter().filter_map(|f| f.followup.as_ref()).collect();
    if ups.len() > MAX_FOLLOWUPS {
        bail!("{} follow-ups given: a diagnosis takes at most {MAX_FOLLOWUPS}", ups.len());
    }
    for (k, up) in ups.iter().enumerate() {
        if ups[..k].iter().any(|u| u.protocol == up.protocol) {
            bail!("the {} protocol is given twice among the follow-ups: each protocol decides its question once", up.protocol);
        }
    }
    if !files.iter().any(|f| matches!(f.content, Content::Response(_))) {
        bail!("no recording of the strip's response among {}: a reference recording alone says nothing of the strip", paths.len());
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// A follow-up naming a primary not given is refused, naming both files; a reference is read
    /// as a reference.
    #[test]
    fn follow_ups_must_name_a_primary_given() {
        let dir = std::env::temp_dir().join(format!("ipmc-strip-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fr = "freq_hz,rh_pct,tip_gain,tip_phase_deg\n10,40,1.0,0\n20,40,1.1,-1\n";
        let a = write(&dir, "a.csv", fr);
        let up = write(&dir, "b.csv", &format!("# followup=wideband\n# strip=other.csv\n{fr}"));
        let e = read(&[a.clone(), up]).err().unwrap().to_string();
        assert!(e.contains("b.csv") && e.contains("other.csv") && e.contains("a.csv"), "{e}");
        let reference = write(
            &dir,
            "r.csv",
            "# followup=reference\n# strip=a.csv\n# reference=salts\n# reference_uncertainty_pct=0.3\nreference_rh_pct,rh_pct\n32.8,33\n75.3,76\n",
        );
        let files = read(&[a, reference.clone()]).unwrap();
        assert!(matches!(files[1].content, Content::Reference(_)));
        assert!(read(&[reference]).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
