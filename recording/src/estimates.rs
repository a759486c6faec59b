//! Estimate files (`t_s,base_est_m,rh_pct,rh_strip_pct,rh_read_pct,rel_err,flags`, and the strip's
//! own hygrometer's `rh_strip_sd_pct,rh_own_pct,rh_own_sd_pct,rh_fused_pct,rh_fused_sd_pct`): what `ipmc compensate` and the firmware
//! (through `cargo xtask qemu`) write and `ipmc score`, the plot and the equivalence test read.
//! The f32 columns are parsed as f32 directly so values the firmware printed compare bit for bit.

use crate::{Error, Format, Metadata, Rule, Table, Warning};
use std::fmt::Write as _;

const COLUMNS: [&str; 12] = [
    "t_s",
    "base_est_m",
    "rh_pct",
    "rh_strip_pct",
    "rh_read_pct",
    "rel_err",
    "flags",
    HYGROMETER_COLUMNS[0],
    HYGROMETER_COLUMNS[1],
    HYGROMETER_COLUMNS[2],
    HYGROMETER_COLUMNS[3],
    HYGROMETER_COLUMNS[4],
];
/// In the order of [`Hygrometer::columns`].
pub const HYGROMETER_COLUMNS: [&str; 5] = ["rh_strip_sd_pct", "rh_own_pct", "rh_own_sd_pct", "rh_fused_pct", "rh_fused_sd_pct"];

/// Per sample, the strip's own hygrometer at the block [%RH] (the stream's, version 4).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Hygrometer {
    /// 1σ of the reading through the humidity path (`rh_strip_pct`).
    pub read_sd_pct: Vec<f32>,
    /// The strip's humidity from its own current, and its 1σ (NaN: refused, or no fit yet).
    pub own_pct: Vec<f32>,
    pub own_sd_pct: Vec<f32>,
    /// The reading and the strip's estimate fused, and its 1σ.
    pub fused_pct: Vec<f32>,
    pub fused_sd_pct: Vec<f32>,
}

impl Hygrometer {
    pub fn columns(&self) -> [&Vec<f32>; 5] {
        [&self.read_sd_pct, &self.own_pct, &self.own_sd_pct, &self.fused_pct, &self.fused_sd_pct]
    }

    pub fn columns_mut(&mut self) -> [&mut Vec<f32>; 5] {
        [&mut self.read_sd_pct, &mut self.own_pct, &mut self.own_sd_pct, &mut self.fused_pct, &mut self.fused_sd_pct]
    }
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Estimates {
    pub metadata: Metadata,
    pub t_s: Vec<f64>,
    pub base_est_m: Vec<f32>,
    /// Per sample: the humidity the block's active design is for [%], if written.
    pub rh_pct: Option<Vec<f32>>,
    /// Per sample: the strip's humidity at the block (the reading through the calibration's
    /// humidity path, before clamping) [%], if written.
    pub rh_strip_pct: Option<Vec<f32>>,
    /// Per sample: the humidity sensor's reading as read [%], if written.
    pub rh_read_pct: Option<Vec<f32>>,
    /// Per sample: the block's expected relative rms error in the band, 1σ (a fraction), if
    /// written (files from before it have none).
    pub rel_err: Option<Vec<f32>>,
    /// Per sample: the block's flag bits, if written.
    pub flags: Option<Vec<u16>>,
    /// The strip's own hygrometer, if written (all its columns or none).
    pub hygrometer: Option<Hygrometer>,
}

impl Format for Estimates {
    fn from_table(t: &Table) -> Result<(Self, Vec<Warning>), Error> {
        let t_s = t.numbers(t.require("t_s")?, Rule::Finite)?;
        let bc = t.require("base_est_m")?;
        let base_est_m: Vec<f32> = t.parsed(bc, "a number")?;
        // A NaN estimate is a firmware fault to report, not a row to skip.
        if let Some(i) = base_est_m.iter().position(|v| !v.is_finite()) {
            return Err(t.error_at(i, bc, format!("expected a finite number, found `{}`", t.field(i, bc))));
        }
        let rh_pct = t.find("rh_pct").map(|c| t.parsed::<f32>(c, "a number")).transpose()?;
        let rh_strip_pct = t.find("rh_strip_pct").map(|c| t.parsed::<f32>(c, "a number")).transpose()?;
        let rh_read_pct = t.find("rh_read_pct").map(|c| t.parsed::<f32>(c, "a number")).transpose()?;
        let rel_err = t.find("rel_err").map(|c| t.parsed::<f32>(c, "a number")).transpose()?;
        let flags = t.find("flags").map(|c| t.parsed::<u16>(c, "an integer 0..=65535")).transpose()?;
        let hygrometer = match HYGROMETER_COLUMNS.map(|name| t.find(name)) {
            [Some(a), Some(b), Some(c), Some(d), Some(e)] => {
                let col = |c| t.parsed::<f32>(c, "a number");
                Some(Hygrometer { read_sd_pct: col(a)?, own_pct: col(b)?, own_sd_pct: col(c)?, fused_pct: col(d)?, fused_sd_pct: col(e)? })
            }
            _ => None,
        };
        Ok((
            Estimates { metadata: t.metadata.clone(), t_s, base_est_m, rh_pct, rh_strip_pct, rh_read_pct, rel_err, flags, hygrometer },
            t.unknown_columns(&COLUMNS),
        ))
    }
}

impl Estimates {
    /// The file as CSV; `{:e}` of an f32 is the shortest text that reads back as the same f32.
    pub fn to_csv(&self) -> Result<String, Error> {
        let n = self.t_s.len();
        let bad = |len: usize| len != n;
        if bad(self.base_est_m.len())
            || self.rh_pct.as_ref().is_some_and(|v| bad(v.len()))
            || self.rh_strip_pct.as_ref().is_some_and(|v| bad(v.len()))
            || self.rh_read_pct.as_ref().is_some_and(|v| bad(v.len()))
            || self.rel_err.as_ref().is_some_and(|v| bad(v.len()))
            || self.flags.as_ref().is_some_and(|v| bad(v.len()))
            || self.hygrometer.as_ref().is_some_and(|h| h.columns().iter().any(|v| bad(v.len())))
        {
            return Err(Error::file("(writer)", "columns of different lengths"));
        }
        let mut s = String::with_capacity(n * 40 + 128);
        self.metadata.write(&mut s, &[]);
        s.push_str("t_s,base_est_m");
        if self.rh_pct.is_some() {
            s.push_str(",rh_pct");
        }
        if self.rh_strip_pct.is_some() {
            s.push_str(",rh_strip_pct");
        }
        if self.rh_read_pct.is_some() {
            s.push_str(",rh_read_pct");
        }
        if self.rel_err.is_some() {
            s.push_str(",rel_err");
        }
        if self.flags.is_some() {
            s.push_str(",flags");
        }
        if self.hygrometer.is_some() {
            for name in HYGROMETER_COLUMNS {
                s.push(',');
                s.push_str(name);
            }
        }
        s.push('\n');
        for i in 0..n {
            let _ = write!(s, "{},{:e}", self.t_s[i], self.base_est_m[i]);
            if let Some(v) = &self.rh_pct {
                let _ = write!(s, ",{}", v[i]);
            }
            if let Some(v) = &self.rh_strip_pct {
                let _ = write!(s, ",{}", v[i]);
            }
            if let Some(v) = &self.rh_read_pct {
                let _ = write!(s, ",{}", v[i]);
            }
            if let Some(v) = &self.rel_err {
                let _ = write!(s, ",{:e}", v[i]);
            }
            if let Some(v) = &self.flags {
                let _ = write!(s, ",{}", v[i]);
            }
            if let Some(h) = &self.hygrometer {
                for v in h.columns() {
                    let _ = write!(s, ",{}", v[i]);
                }
            }
            s.push('\n');
        }
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_columns_round_trip_bit_for_bit() {
        let mut e = Estimates {
            t_s: vec![0.0, 0.0005],
            base_est_m: vec![1.0f32 / 3.0, -7.1e-38],
            rh_pct: Some(vec![40.35, 40.1f32.next_up()]),
            rh_strip_pct: Some(vec![f32::NAN, 40.2]),
            rh_read_pct: Some(vec![43.35, 43.1f32.next_down()]),
            rel_err: Some(vec![0.0625, 0.1f32.next_up()]),
            flags: Some(vec![0, 8]),
            hygrometer: Some(Hygrometer {
                read_sd_pct: vec![1.5, 2.25f32.next_up()],
                own_pct: vec![f32::NAN, 77.3],
                own_sd_pct: vec![f32::NAN, 0.31],
                fused_pct: vec![78.1, 77.4f32.next_down()],
                fused_sd_pct: vec![1.5, 0.3],
            }),
            ..Default::default()
        };
        e.metadata.set("fs_hz", 2000);
        let (back, w) = Estimates::parse("e.csv", &e.to_csv().unwrap()).unwrap();
        assert!(w.is_empty());
        // A strip humidity before the first reading is NaN, which no `==` equals: compared by bits.
        let bits = |v: &Option<Vec<f32>>| v.as_ref().map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>());
        assert_eq!(bits(&back.rh_strip_pct), bits(&e.rh_strip_pct));
        let h = |x: &Estimates| x.hygrometer.as_ref().map(|h| h.columns().map(|v| bits(&Some(v.clone()))));
        assert_eq!(h(&back), h(&e));
        let finite = |x: Estimates| Estimates { rh_strip_pct: None, hygrometer: None, ..x };
        assert_eq!(finite(back), finite(e));
    }

    /// Files from before the expected-error column still read, without it.
    #[test]
    fn files_without_the_error_column_read() {
        let (e, w) = Estimates::parse("e.csv", "t_s,base_est_m,rh_pct,rh_strip_pct,rh_read_pct,flags\n0,1e-6,40,41,42,0\n").unwrap();
        assert!(w.is_empty());
        assert_eq!((e.rel_err, e.flags), (None, Some(vec![0])));
        let err = Estimates::parse("e.csv", "t_s,base_est_m,rel_err\n0,1e-6,wide\n").unwrap_err();
        assert!(err.to_string().contains("`rel_err`"), "{err}");
    }

    #[test]
    fn bad_flags_and_nan_are_named() {
        let err = Estimates::parse("e.csv", "t_s,base_est_m,flags\n0,1e-6,70000\n").unwrap_err();
        assert_eq!(err.to_string(), "e.csv:2:8: column 3 (`flags`): expected an integer 0..=65535, found `70000`");
        let err = Estimates::parse("e.csv", "t_s,base_est_m\n0,NaN\n").unwrap_err();
        assert!(err.to_string().starts_with("e.csv:2:3: column 2 (`base_est_m`)"), "{err}");
    }
}
