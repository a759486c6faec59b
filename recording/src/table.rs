//! The layer under every format: `#` comments and `# key=value` metadata, the header naming the
//! columns, rows of fields with their line and character positions, and number checks whose
//! errors say where and what was expected. The csv crate's core parser splits each line's fields
//! (quotes, escapes); lines, comments and positions are handled here so every line number is exact.

use crate::{Error, FieldRef, Metadata, Warning};
use std::path::Path;
use std::str::FromStr;

/// What a numeric field must be, beyond parsing as a number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// Any finite number (NaN and infinities are refused).
    Finite,
    /// Finite and ≥ 0 (gains, amplitudes).
    NonNegative,
    /// Finite and > 0 (frequencies, rates).
    Positive,
    /// A relative humidity in percent: 0–100 with `RH_OVERSHOOT_PCT` of sensor overshoot either
    /// side. Anything further out is a unit mix-up or a dead sensor, and refusing it at its line
    /// beats a fit that fails later without saying why.
    Humidity,
}

/// How far outside 0–100 % a humidity reading may lie and still be a reading: capacitive sensors
/// overshoot near saturation and read a little below zero when dry (HTS221, SHT4x: ±few %RH).
pub const RH_OVERSHOOT_PCT: f64 = 5.0;

impl Rule {
    fn accepts(self, v: f64) -> bool {
        v.is_finite()
            && match self {
                Rule::Finite => true,
                Rule::NonNegative => v >= 0.0,
                Rule::Positive => v > 0.0,
                Rule::Humidity => (-RH_OVERSHOOT_PCT..=100.0 + RH_OVERSHOOT_PCT).contains(&v),
            }
    }
    fn expected(self) -> &'static str {
        match self {
            Rule::Finite => "a finite number",
            Rule::NonNegative => "a finite number ≥ 0",
            Rule::Positive => "a finite number > 0",
            Rule::Humidity => "a relative humidity in −5…105 % (0–100 % and the sensor's overshoot)",
        }
    }
}

/// A CSV in the interchange conventions, split into fields but not yet interpreted.
#[derive(Debug)]
pub struct Table {
    /// The file name errors are reported under.
    pub source: String,
    pub metadata: Metadata,
    /// Column names as in the header, trimmed.
    pub header: Vec<String>,
    /// 1-based line of the header.
    pub header_line: usize,
    text: String,
    /// Per data row: its 1-based line and the byte offset of that line in `text`.
    rows: Vec<(usize, usize)>,
    /// Every data field's trimmed text, concatenated; field k of the table (row-major) is
    /// `fields[ends[k-1]..ends[k]]`. One buffer instead of a String per field.
    fields: String,
    ends: Vec<usize>,
}

/// Splits one line into trimmed fields with the csv crate's core parser (quotes, `""` escapes).
fn split_line(reader: &mut csv_core::Reader, line: &str, out: &mut Vec<String>) {
    use csv_core::ReadRecordResult as R;
    out.clear();
    // No field is longer than the line and there is at most one more field than commas: neither
    // buffer fills, and memory stays proportional to the line whatever it holds.
    let commas = line.bytes().filter(|&b| b == b',').count();
    let (mut buf, mut ends) = (vec![0u8; line.len() + 1], vec![0usize; commas + 2]);
    let (mut input, mut nout, mut nend) = (line.as_bytes(), 0, 0);
    // The line, then an empty input (the end of data) completes the record.
    for _ in 0..4 {
        let (result, nin, o, e) = reader.read_record(input, &mut buf[nout..], &mut ends[nend..]);
        (input, nout, nend) = (&input[nin..], nout + o, nend + e);
        if matches!(result, R::Record | R::End) {
            break;
        }
    }
    reader.reset();
    let mut start = 0;
    for &end in &ends[..nend] {
        out.push(String::from_utf8_lossy(&buf[start..end]).trim().to_string());
        start = end;
    }
}

impl Table {
    pub fn read(path: &Path) -> Result<Table, Error> {
        let text = crate::read_text(path)?;
        Table::parse(&path.display().to_string(), text)
    }

    /// `source` names the text in errors. An empty text or one with only comments is an error
    /// (no header); a header with no rows is a valid empty table. Lines end in LF or CRLF, the
    /// last one too (a last row without its line end is refused as maybe truncated); a quoted
    /// field cannot span lines (the formats hold numbers and names).
    pub fn parse(source: &str, text: impl Into<String>) -> Result<Table, Error> {
        let mut text: String = text.into();
        if text.starts_with('\u{feff}') {
            // A byte-order mark (spreadsheet exports) is not part of the first column's name.
            text.replace_range(..3, "");
        }
        let mut metadata = Metadata::default();
        let mut reader = csv_core::Reader::new();
        let mut header: Option<(Vec<String>, usize)> = None;
        let (mut rows, mut fields, mut ends) = (Vec::new(), String::new(), Vec::new());
        let mut record = Vec::new();
        let mut byte = 0;
        for (i, raw) in text.split_inclusive('\n').enumerate() {
            let (line_no, line_byte) = (i + 1, byte);
            byte += raw.len();
            let line = raw.trim_end_matches(['\n', '\r']);
            if let Some(comment) = line.strip_prefix('#') {
                if let Some(kv) = Metadata::parse_comment(comment) {
                    metadata.0.push(kv);
                }
                continue;
            }
            split_line(&mut reader, line, &mut record);
            if record.iter().all(String::is_empty) {
                continue; // a blank line (or one of only commas/spaces) carries nothing
            }
            if !raw.ends_with('\n') {
                // Every writer ends its lines; a copy or a download cut short ends inside a row,
                // whose last field (`-13` of `-132.501`) still parses as a number.
                return Err(Error::line(
                    source,
                    line_no,
                    "the last line has no line end: the file may be truncated (cut inside this row); \
                     if it is whole, end it with a newline",
                ));
            }
            match &header {
                None => {
                    for (k, n) in record.iter().enumerate() {
                        if record[..k].contains(n) {
                            return Err(Error::line(source, line_no, format!("column `{n}` appears twice in the header")));
                        }
                    }
                    header = Some((std::mem::take(&mut record), line_no));
                }
                Some((names, _)) => {
                    if record.len() != names.len() {
                        return Err(Error::line(
                            source,
                            line_no,
                            format!("{} fields, expected {} as in the header ({})", record.len(), names.len(), names.join(",")),
                        ));
                    }
                    for f in &record {
                        fields.push_str(f);
                        ends.push(fields.len());
                    }
                    rows.push((line_no, line_byte));
                }
            }
        }
        let (header, header_line) = header.ok_or_else(|| Error::file(source, "no header line (the file is empty or only comments)"))?;
        Ok(Table { source: source.into(), metadata, header, header_line, text, rows, fields, ends })
    }

    /// Number of data rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// 1-based line of data row `row`.
    pub fn line_of(&self, row: usize) -> usize {
        self.rows[row].0
    }

    /// Index of the column named `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|n| n == name)
    }

    /// Index of a required column; the error names it and the header line.
    pub fn require(&self, name: &str) -> Result<usize, Error> {
        self.find(name).ok_or_else(|| {
            Error::line(
                &self.source,
                self.header_line,
                format!("missing required column `{name}` (the header has: {})", self.header.join(",")),
            )
        })
    }

    /// A warning for each header column not in `known`.
    pub fn unknown_columns(&self, known: &[&str]) -> Vec<Warning> {
        self.header
            .iter()
            .filter(|n| !known.contains(&n.as_str()))
            .map(|n| Warning {
                source: self.source.clone(),
                line: Some(self.header_line),
                message: format!("unknown column `{n}` ignored"),
            })
            .collect()
    }

    /// Where field `col` of data row `row` is, for errors.
    fn field_ref(&self, row: usize, col: usize) -> FieldRef {
        let raw = self.text[self.rows[row].1..].lines().next().unwrap_or("");
        let pieces: Vec<&str> = raw.split(',').collect();
        // Character column only when quoting did not change how the line splits.
        let char = (pieces.len() == self.header.len()).then(|| {
            let before: usize = pieces[..col].iter().map(|p| p.chars().count() + 1).sum();
            let lead = pieces[col].chars().take_while(|c| c.is_whitespace()).count();
            before + lead + 1
        });
        FieldRef { name: Some(self.header[col].clone()), index: Some(col + 1), char }
    }

    /// An error at field `col` of row `row`.
    pub fn error_at(&self, row: usize, col: usize, message: impl Into<String>) -> Error {
        Error { source: self.source.clone(), line: Some(self.rows[row].0), field: Some(self.field_ref(row, col)), message: message.into() }
    }

    /// The raw text of field `col` of row `row`, trimmed.
    pub fn field(&self, row: usize, col: usize) -> &str {
        let k = row * self.header.len() + col;
        let start = if k == 0 { 0 } else { self.ends[k - 1] };
        &self.fields[start..self.ends[k]]
    }

    /// Column `col` as numbers obeying `rule`; the first bad field is an error.
    pub fn numbers(&self, col: usize, rule: Rule) -> Result<Vec<f64>, Error> {
        (0..self.rows.len())
            .map(|r| {
                let f = self.field(r, col);
                f.parse::<f64>()
                    .ok()
                    .filter(|&v| rule.accepts(v))
                    .ok_or_else(|| self.error_at(r, col, format!("expected {}, found `{f}`", rule.expected())))
            })
            .collect()
    }

    /// Column `col` parsed as `T` directly (e.g. f32 without a detour through f64, or u16 flags);
    /// `expected` says what a field must be.
    pub fn parsed<T: FromStr>(&self, col: usize, expected: &str) -> Result<Vec<T>, Error> {
        (0..self.rows.len())
            .map(|r| {
                let f = self.field(r, col);
                f.parse::<T>().map_err(|_| self.error_at(r, col, format!("expected {expected}, found `{f}`")))
            })
            .collect()
    }

    /// A required metadata value as a number obeying `rule`.
    pub fn metadata_number(&self, key: &str, rule: Rule) -> Result<Option<f64>, Error> {
        match self.metadata.get(key) {
            None => Ok(None),
            Some(v) => v
                .parse::<f64>()
                .ok()
                .filter(|&x| rule.accepts(x))
                .map(Some)
                .ok_or_else(|| Error::file(&self.source, format!("metadata `# {key}={v}`: expected {}", rule.expected()))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_metadata_crlf_and_positions() {
        let t = Table::parse("a.csv", "# fs_hz=2000\r\n# a comment\r\n# sample = X-1\r\nb , a\r\n\r\n1, 2\r\n3,x\r\n").unwrap();
        assert_eq!(t.metadata.get("fs_hz"), Some("2000"));
        assert_eq!(t.metadata.get("sample"), Some("X-1"));
        assert_eq!(t.header, vec!["b", "a"]);
        assert_eq!(t.header_line, 4);
        assert_eq!(t.len(), 2);
        assert_eq!(t.line_of(1), 7);
        let e = t.numbers(1, Rule::Finite).unwrap_err();
        assert_eq!((e.line, e.field.as_ref().unwrap().char, e.field.as_ref().unwrap().index), (Some(7), Some(3), Some(2)));
        assert_eq!(e.to_string(), "a.csv:7:3: column 2 (`a`): expected a finite number, found `x`");
        // The leading space of ` 2` moves the character column, not the value.
        assert_eq!(t.numbers(1, Rule::Finite).err().map(|e| e.line), Some(Some(7)));
        assert_eq!(t.numbers(0, Rule::Finite).unwrap(), vec![1.0, 3.0]);
    }

    /// A file cut inside its last number (`-13` of `-132.501`) parses as numbers throughout:
    /// only the missing line end tells.
    #[test]
    fn a_last_row_without_its_line_end_is_refused_as_maybe_truncated() {
        use crate::{Format as _, TimeSeries};
        let whole = "# fs_hz=2000\nt_s,rh_pct,current_a\n0,45,1e-9\n0.0005,45,-132.501\n";
        assert!(TimeSeries::parse("ts.csv", whole).is_ok());
        let cut = &whole[..whole.find("2.501").unwrap()];
        let e = TimeSeries::parse("ts.csv", cut).expect_err("refused");
        assert_eq!(e.line, Some(4), "{e}");
        assert!(e.to_string().starts_with("ts.csv:4: ") && e.message.contains("truncated"), "{e}");
        assert!(Table::parse("h.csv", "t_s,current_a").is_err(), "a header cut short");
        // Comments and blank lines carry no data: a last one without its line end loses none.
        assert_eq!(Table::parse("c.csv", "x\n1\n\n# end").unwrap().len(), 1);
        assert_eq!(Table::parse("c.csv", "x\r\n1\r\n").unwrap().len(), 1);
    }

    #[test]
    fn empty_and_header_only() {
        assert!(Table::parse("e.csv", "").unwrap_err().to_string().contains("no header"));
        assert!(Table::parse("e.csv", "# fs_hz=1\n\n").unwrap_err().to_string().contains("no header"));
        let t = Table::parse("h.csv", "t_s,current_a\n").unwrap();
        assert!(t.is_empty());
    }

    #[test]
    fn wrong_field_count_and_duplicates() {
        let e = Table::parse("w.csv", "a,b\n1,2\n1,2,3\n").err().unwrap();
        assert_eq!(e.line, Some(3));
        assert!(e.message.contains("3 fields, expected 2"), "{e}");
        assert!(Table::parse("d.csv", "a,b,a\n").err().unwrap().message.contains("twice"));
    }

    #[test]
    fn rules_refuse_nan_infinity_and_signs() {
        let t = Table::parse("r.csv", "x\nNaN\n").unwrap();
        assert!(t.numbers(0, Rule::Finite).is_err());
        let t = Table::parse("r.csv", "x\ninf\n").unwrap();
        assert!(t.numbers(0, Rule::Finite).is_err());
        let t = Table::parse("r.csv", "x\n-1e-9\n").unwrap();
        assert!(t.numbers(0, Rule::NonNegative).unwrap_err().message.contains("≥ 0"));
        let t = Table::parse("r.csv", "x\n0\n").unwrap();
        assert!(t.numbers(0, Rule::Positive).is_err());
        assert_eq!(t.numbers(0, Rule::NonNegative).unwrap(), vec![0.0]);
        assert!(t.numbers(0, Rule::Humidity).is_ok());
        let t = Table::parse("r.csv", "rh_pct\n102.5\n-4\n155\n").unwrap();
        let e = t.numbers(0, Rule::Humidity).unwrap_err();
        assert_eq!(e.line, Some(4), "{e}");
        assert!(e.message.contains("relative humidity") && e.message.contains("`155`"), "{e}");
    }

    #[test]
    fn quoted_header_and_bom() {
        let t = Table::parse("q.csv", "\u{feff}\"freq_hz\",rh_pct\n10,\"45\"\n").unwrap();
        assert_eq!(t.header, vec!["freq_hz", "rh_pct"]);
        assert_eq!(t.numbers(1, Rule::Finite).unwrap(), vec![45.0]);
    }

    #[test]
    fn not_utf8_names_the_line() {
        let dir = std::env::temp_dir().join(format!("ipmc-recording-utf8-{}", std::process::id()));
        std::fs::write(&dir, b"a\n1\n\xff\n").unwrap();
        let e = Table::read(&dir).unwrap_err();
        std::fs::remove_file(&dir).ok();
        assert_eq!(e.line, Some(3), "{e}");
    }

    #[test]
    fn long_garbage_is_linear() {
        // 4 MB of one line of commas and quotes: parsed in linear time and memory, then refused.
        let line: String = ",\"".repeat(2_000_000);
        let t = Table::parse("big.csv", format!("a\n{line}\n"));
        assert!(t.is_err());
        let mut many = String::from("x\n");
        for _ in 0..200_000 {
            many.push_str("1e-3\n");
        }
        assert_eq!(Table::parse("many.csv", many).unwrap().numbers(0, Rule::Finite).unwrap().len(), 200_000);
    }

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        for text in ["\"", "\"a\nb", ",,,\n\"", "a\n\"1", "#\n#=\n#x=\n", "a,b\n\"1,2\"\n"] {
            let _ = Table::parse("g.csv", text).map(|t| t.numbers(0, Rule::Finite));
        }
    }
}
