//! The fault list of `simulate --faults`: `KIND@START[+DUR][xCOUNT]`,
//! comma-separated, times in seconds from the start of the run.
//!
//! - `imu-nan@4` one NaN sample at 4 s; `imu-nan@4x3` three in a row;
//! - `wheel-gap@4+0.5` the wheels silent from 4 s to 4.5 s;
//! - `flow-lowsqual@4+1` a one-second burst of low SQUAL;
//! - `stuck@5+2` the robot stuck from 5 s to 7 s.
//!
//! A kind with a window takes `+DUR` (a default otherwise); a kind of single
//! samples takes `xCOUNT` (1 by default).

use super::kind::FaultKind;
use std::fmt;

/// One fault of the list.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultSpec {
    /// What.
    pub kind: FaultKind,
    /// When it starts, seconds from the start of the run.
    pub start: f64,
    /// How long, seconds (0 for a count of single samples).
    pub duration: f64,
    /// How many samples (reads, frames) for a kind without a window.
    pub count: u32,
}

impl FaultSpec {
    /// A fault of `kind` at `start` with its defaults.
    pub fn new(kind: FaultKind, start: f64) -> Self {
        FaultSpec {
            kind,
            start,
            duration: kind.default_duration(),
            count: 1,
        }
    }

    /// The same with a window of `duration` seconds.
    pub fn lasting(mut self, duration: f64) -> Self {
        self.duration = duration;
        self
    }

    /// The same with `count` samples.
    pub fn times(mut self, count: u32) -> Self {
        self.count = count;
        self
    }

    /// Start, nanoseconds.
    pub fn start_ns(&self) -> u64 {
        (self.start * 1e9).round() as u64
    }

    /// End of the window, nanoseconds (the start for a count).
    pub fn end_ns(&self) -> u64 {
        ((self.start + self.duration) * 1e9).round() as u64
    }

    /// Whether `t_ns` lies in the window `[start, start + duration)`.
    pub fn covers(&self, t_ns: u64) -> bool {
        t_ns >= self.start_ns() && t_ns < self.end_ns()
    }
}

impl fmt::Display for FaultSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}@{}", self.kind.name(), self.start)?;
        if self.kind.has_window() {
            write!(f, "+{}", self.duration)
        } else if self.count != 1 {
            write!(f, "x{}", self.count)
        } else {
            Ok(())
        }
    }
}

/// Why a fault list was refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SpecError(pub String);

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SpecError {}

fn number(item: &str, what: &str, s: &str) -> Result<f64, SpecError> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v >= 0.0)
        .ok_or_else(|| {
            SpecError(format!(
                "fault `{item}`: {what} `{s}` is not a number of seconds >= 0"
            ))
        })
}

impl std::str::FromStr for FaultSpec {
    type Err = SpecError;

    fn from_str(item: &str) -> Result<Self, SpecError> {
        let item = item.trim();
        let (name, when) = item.split_once('@').ok_or_else(|| {
            SpecError(format!("fault `{item}`: expected KIND@START[+DUR][xCOUNT]"))
        })?;
        let kind = FaultKind::from_name(name).ok_or_else(|| {
            SpecError(format!(
                "unknown fault kind `{name}`; `host-sim simulate --help` lists them"
            ))
        })?;
        let (when, count) = match when.split_once('x') {
            Some((w, c)) => {
                let c: u32 = c.parse().ok().filter(|c| *c > 0).ok_or_else(|| {
                    SpecError(format!(
                        "fault `{item}`: count `{c}` is not a positive integer"
                    ))
                })?;
                (w, Some(c))
            }
            None => (when, None),
        };
        let (start, duration) = match when.split_once('+') {
            Some((s, d)) => (s, Some(number(item, "duration", d)?)),
            None => (when, None),
        };
        let mut spec = FaultSpec::new(kind, number(item, "start", start)?);
        match (kind.has_window(), duration, count) {
            (true, _, Some(_)) => {
                return Err(SpecError(format!(
                    "fault `{item}`: {name} takes a window (+DUR), not a count"
                )));
            }
            (false, Some(_), _) => {
                return Err(SpecError(format!(
                    "fault `{item}`: {name} takes a count (xCOUNT), not a window"
                )));
            }
            (true, Some(d), None) if d > 0.0 => spec.duration = d,
            (true, Some(_), None) => {
                return Err(SpecError(format!("fault `{item}`: the window must be > 0")));
            }
            (_, _, Some(c)) => spec.count = c,
            _ => {}
        }
        Ok(spec)
    }
}

/// A whole fault list.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FaultPlan {
    /// The faults, in the order given.
    pub faults: Vec<FaultSpec>,
}

impl FaultPlan {
    /// No faults.
    pub fn none() -> Self {
        FaultPlan::default()
    }

    /// Whether there is no fault.
    pub fn is_empty(&self) -> bool {
        self.faults.is_empty()
    }

    /// One fault.
    pub fn single(spec: FaultSpec) -> Self {
        FaultPlan { faults: vec![spec] }
    }

    /// The faults of `kind`s that satisfy `pred`, with their index in the list.
    pub fn select(
        &self,
        pred: impl Fn(&FaultSpec) -> bool,
    ) -> impl Iterator<Item = (usize, &FaultSpec)> {
        self.faults.iter().enumerate().filter(move |(_, f)| pred(f))
    }
}

impl std::str::FromStr for FaultPlan {
    type Err = SpecError;

    fn from_str(s: &str) -> Result<Self, SpecError> {
        let faults = s
            .split(',')
            .filter(|x| !x.trim().is_empty())
            .map(str::parse)
            .collect::<Result<Vec<_>, _>>()?;
        Ok(FaultPlan { faults })
    }
}

impl fmt::Display for FaultPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let items: Vec<String> = self.faults.iter().map(ToString::to_string).collect();
        f.write_str(&items.join(","))
    }
}

/// The help text of `--faults`: the syntax and every kind.
pub fn kinds_help() -> String {
    let mut s = String::from(
        "Faults: KIND@START[+DUR][xCOUNT], comma-separated, seconds from the start.\n\
         Each line: kind, what it does -> the outcome every spoiled sample must end in.\n",
    );
    for k in FaultKind::ALL {
        s += &format!("  {:<17} {}\n", k.name(), k.help());
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::faults::kind::Sensor;

    #[test]
    fn parses_the_documented_forms() {
        let p: FaultPlan = "imu-nan@4x3, wheel-gap@4+5,flow-lowsqual@4,stuck@5+2"
            .parse()
            .unwrap();
        assert_eq!(
            p.faults,
            vec![
                FaultSpec::new(FaultKind::ImuNan, 4.0).times(3),
                FaultSpec::new(FaultKind::Gap(Sensor::Wheel), 4.0).lasting(5.0),
                FaultSpec::new(FaultKind::FlowLowSqual, 4.0).lasting(0.5),
                FaultSpec::new(FaultKind::Stuck, 5.0).lasting(2.0),
            ]
        );
        assert_eq!(p.to_string().parse::<FaultPlan>().unwrap(), p);
    }

    #[test]
    fn refuses_what_it_cannot_read() {
        for bad in [
            "imu-nan",
            "imu-nan@",
            "imu-nan@x",
            "imu-nan@-1",
            "imu-nan@4+1",
            "wheel-gap@4x2",
            "wheel-gap@4+0",
            "imu-nan@4x0",
            "nope@1",
        ] {
            assert!(bad.parse::<FaultPlan>().is_err(), "{bad}");
        }
    }

    #[test]
    fn every_kind_has_a_unique_name_and_help() {
        for (i, k) in FaultKind::ALL.iter().enumerate() {
            assert_eq!(FaultKind::from_name(&k.name()), Some(*k));
            assert!(kinds_help().contains(&k.name()));
            for o in &FaultKind::ALL[i + 1..] {
                assert_ne!(k.name(), o.name());
            }
        }
    }
}
