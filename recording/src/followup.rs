//! The follow-up of a recording (recording-format.md, "Follow-up recordings"): `# followup=` names
//! the protocol a diagnosis asked for, `# strip=` the primary recording whose strip was measured
//! again in a new session.

use crate::{Error, Metadata};

/// The measurements a diagnosis can ask for when one recording cannot decide.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Protocol {
    /// A frequency response to 2 kHz: amplifier pole, electrodes' RC line, delay, the second
    /// mode (tip mass, clamp, viscoelastic law, air loading).
    Wideband,
    /// Humidity steps with bursts while each level settles: a hydration lag against a constant
    /// offset of the reading.
    Step,
    /// The primary session repeated with the room at another temperature.
    Temperature,
    /// The humidity sensor at references of known humidity: its offset and gain.
    Reference,
}

impl Protocol {
    pub const ALL: [Protocol; 4] = [Protocol::Wideband, Protocol::Step, Protocol::Temperature, Protocol::Reference];

    pub fn as_str(self) -> &'static str {
        match self {
            Protocol::Wideband => "wideband",
            Protocol::Step => "step",
            Protocol::Temperature => "temperature",
            Protocol::Reference => "reference",
        }
    }

    pub fn parse(s: &str) -> Option<Protocol> {
        Protocol::ALL.into_iter().find(|p| p.as_str() == s.trim())
    }
}

impl core::fmt::Display for Protocol {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What makes a recording a follow-up: its protocol and the primary it measures again.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Followup {
    pub protocol: Protocol,
    /// The primary recording's file name as written in `# strip=` (compared by file name).
    pub strip: String,
}

impl Followup {
    /// `None` for a primary recording (no `# followup=`); an error naming `source` when only one
    /// of the two keys is given or the protocol is unknown.
    pub fn of(metadata: &Metadata, source: &str) -> Result<Option<Followup>, Error> {
        match (metadata.get("followup"), metadata.get("strip")) {
            (None, None) => Ok(None),
            (Some(p), Some(strip)) => {
                let protocol = Protocol::parse(p).ok_or_else(|| {
                    Error::file(source, format!("metadata `# followup={p}`: expected wideband, step, temperature or reference"))
                })?;
                if strip.is_empty() {
                    return Err(Error::file(source, "metadata `# strip=` is empty: expected the primary recording's file name"));
                }
                Ok(Some(Followup { protocol, strip: strip.to_string() }))
            }
            (Some(_), None) => Err(Error::file(
                source,
                "metadata `# followup=` without `# strip=`: a follow-up names the primary recording whose strip it measures",
            )),
            (None, Some(_)) => Err(Error::file(source, "metadata `# strip=` without `# followup=`: name the follow-up's protocol")),
        }
    }

    /// Whether `path` is the primary this follow-up names (by file name: the follow-up may sit in
    /// another folder).
    pub fn names(&self, path: &std::path::Path) -> bool {
        let own = std::path::Path::new(&self.strip);
        own.file_name().is_some() && own.file_name() == path.file_name()
    }

    pub fn write(&self, metadata: &mut Metadata) {
        metadata.set("followup", self.protocol);
        metadata.set("strip", &self.strip);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_keys_or_neither() {
        let m = |pairs: &[(&str, &str)]| Metadata(pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect());
        assert_eq!(Followup::of(&m(&[]), "f.csv").unwrap(), None);
        let f = Followup::of(&m(&[("followup", "step"), ("strip", "case07.csv")]), "f.csv").unwrap().unwrap();
        assert_eq!(f.protocol, Protocol::Step);
        assert!(f.names(std::path::Path::new("../data/case07.csv")));
        assert!(!f.names(std::path::Path::new("case08.csv")));
        let e = Followup::of(&m(&[("followup", "soak"), ("strip", "a.csv")]), "f.csv").unwrap_err();
        assert!(e.to_string().contains("followup=soak"), "{e}");
        assert!(Followup::of(&m(&[("followup", "step")]), "f.csv").unwrap_err().to_string().contains("strip"));
        assert!(Followup::of(&m(&[("strip", "a.csv")]), "f.csv").unwrap_err().to_string().contains("followup"));
        for p in Protocol::ALL {
            assert_eq!(Protocol::parse(p.as_str()), Some(p));
        }
    }
}
