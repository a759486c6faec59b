//! What goes wrong reading a recording, said so a person can find it: file, line, column.

use std::fmt;

/// Where in a row a problem is: the field's column name and 1-based index in the header, and
/// the 1-based character column in the line (absent when quoting makes it ambiguous).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldRef {
    pub name: Option<String>,
    pub index: Option<usize>,
    pub char: Option<usize>,
}

/// A bad file: `file:line:char: column N (`name`): message`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    pub source: String,
    /// 1-based line of the file.
    pub line: Option<usize>,
    pub field: Option<FieldRef>,
    /// What was found and what was expected.
    pub message: String,
}

impl Error {
    /// An error about a whole file (no line): also for analyses of a recording read here.
    pub fn file(source: &str, message: impl Into<String>) -> Self {
        Error { source: source.into(), line: None, field: None, message: message.into() }
    }
    pub(crate) fn line(source: &str, line: usize, message: impl Into<String>) -> Self {
        Error { source: source.into(), line: Some(line), field: None, message: message.into() }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.source)?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
            if let Some(c) = self.field.as_ref().and_then(|c| c.char) {
                write!(f, ":{c}")?;
            }
        }
        write!(f, ": ")?;
        if let Some(FieldRef { name, index, .. }) = &self.field {
            match (index, name) {
                (Some(i), Some(n)) => write!(f, "column {i} (`{n}`): ")?,
                (Some(i), None) => write!(f, "column {i}: ")?,
                (None, Some(n)) => write!(f, "column `{n}`: ")?,
                (None, None) => {}
            }
        }
        write!(f, "{}", self.message)
    }
}

impl std::error::Error for Error {}

/// Something a reader accepted but the user should hear about (an unknown column, say).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    pub source: String,
    pub line: Option<usize>,
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{l}: {}", self.source, self.message),
            None => write!(f, "{}: {}", self.source, self.message),
        }
    }
}
