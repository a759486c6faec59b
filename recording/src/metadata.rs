//! `# key=value` comment lines: kept in file order, unknown keys included.

/// The metadata of a recording, in the order it appeared.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Metadata(pub Vec<(String, String)>);

impl Metadata {
    /// The value of `key` (the last one if repeated: a later line overrides).
    pub fn get(&self, key: &str) -> Option<&str> {
        self.0.iter().rev().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// Sets `key`, replacing an existing entry in place or appending.
    pub fn set(&mut self, key: &str, value: impl ToString) {
        let value = value.to_string();
        match self.0.iter_mut().find(|(k, _)| k == key) {
            Some(e) => e.1 = value,
            None => self.0.push((key.into(), value)),
        }
    }

    /// The comment lines of the writers: `# key=value\n` each, except the keys in `skip`.
    pub(crate) fn write(&self, out: &mut String, skip: &[&str]) {
        for (k, v) in &self.0 {
            if !skip.contains(&k.as_str()) {
                out.push_str(&format!("# {k}={v}\n"));
            }
        }
    }

    /// Parses one comment line's text after `#`; `None` if it is not `key=value`.
    pub(crate) fn parse_comment(comment: &str) -> Option<(String, String)> {
        let (k, v) = comment.trim().split_once('=')?;
        let k = k.trim();
        (!k.is_empty() && !k.contains(char::is_whitespace)).then(|| (k.to_string(), v.trim().to_string()))
    }
}
