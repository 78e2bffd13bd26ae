//! Plot geometry shared by the SVG plots: the data range a plot area shows,
//! the mapping to pixels, "nice" tick steps (1, 2, 5 x 10^k), and the SVG
//! text helpers (escaping, numbers without `NaN`).

use std::fmt::Write as _;

/// A closed range of data values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// Low end.
    pub lo: f64,
    /// High end.
    pub hi: f64,
}

impl Range {
    /// The smallest range holding every finite value of `v`, or `None`.
    pub fn of(v: impl IntoIterator<Item = f64>) -> Option<Range> {
        v.into_iter()
            .filter(|x| x.is_finite())
            .fold(None, |r: Option<Range>, x| {
                Some(match r {
                    None => Range { lo: x, hi: x },
                    Some(r) => Range {
                        lo: r.lo.min(x),
                        hi: r.hi.max(x),
                    },
                })
            })
    }

    /// Both ranges together.
    pub fn union(self, o: Range) -> Range {
        Range {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    /// Widened by `pad` on each side.
    pub fn pad(self, pad: f64) -> Range {
        Range {
            lo: self.lo - pad,
            hi: self.hi + pad,
        }
    }

    /// Width.
    pub fn span(self) -> f64 {
        self.hi - self.lo
    }

    /// Widened about its centre to at least `span`.
    pub fn at_least(self, span: f64) -> Range {
        if self.span() >= span {
            return self;
        }
        let c = 0.5 * (self.lo + self.hi);
        Range {
            lo: c - 0.5 * span,
            hi: c + 0.5 * span,
        }
    }

    /// Whether `x` is inside.
    pub fn contains(self, x: f64) -> bool {
        x >= self.lo && x <= self.hi
    }
}

/// A tick step of 1, 2 or 5 x 10^k giving about `target` intervals over `span`.
pub fn nice_step(span: f64, target: f64) -> f64 {
    if !(span.is_finite() && span > 0.0 && target > 0.0) {
        return 1.0;
    }
    let raw = span / target;
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let m = if f < 1.5 {
        1.0
    } else if f < 3.5 {
        2.0
    } else if f < 7.5 {
        5.0
    } else {
        10.0
    };
    m * mag
}

/// The multiples of `step` inside `r`.
pub fn ticks(r: Range, step: f64) -> Vec<f64> {
    if !(step > 0.0 && r.span().is_finite()) {
        return Vec::new();
    }
    let first = (r.lo / step).ceil() as i64;
    let last = (r.hi / step).floor() as i64;
    (first..=last.min(first + 200))
        .map(|i| i as f64 * step)
        .collect()
}

/// A tick label: as many decimals as `step` needs, and `0` never `-0`.
pub fn label(v: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10()).ceil().max(0.0) as usize
    };
    let s = format!("{v:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// A plot area on the page (pixels) showing `x` by `y` (data units), y up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Left edge, px.
    pub left: f64,
    /// Top edge, px.
    pub top: f64,
    /// Width, px.
    pub width: f64,
    /// Height, px.
    pub height: f64,
    /// Data range across.
    pub x: Range,
    /// Data range up.
    pub y: Range,
}

impl Frame {
    /// Pixel column of data `x`.
    pub fn px(&self, x: f64) -> f64 {
        self.left + (x - self.x.lo) / self.x.span() * self.width
    }

    /// Pixel row of data `y`.
    pub fn py(&self, y: f64) -> f64 {
        self.top + self.height - (y - self.y.lo) / self.y.span() * self.height
    }

    /// Whether the data point is inside the shown ranges.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        self.x.contains(x) && self.y.contains(y)
    }

    /// A frame of `width` px showing `x` by `y` at one scale on both axes:
    /// the height follows (clamped to `min_h..=max_h` px), and the range of
    /// the axis with room to spare widens about its centre.
    pub fn equal(
        left: f64,
        top: f64,
        width: f64,
        min_h: f64,
        max_h: f64,
        x: Range,
        y: Range,
    ) -> Frame {
        let x = x.at_least(1e-3);
        let y = y.at_least(1e-3);
        let k = (width / x.span()).min(max_h / y.span());
        let height = (y.span() * k).clamp(min_h, max_h);
        Frame {
            left,
            top,
            width,
            height,
            x: x.at_least(width / k),
            y: y.at_least(height / k),
        }
    }

    /// The plot area as a white rectangle `id="{id}-area"` (tests find the
    /// frame by it), and a clip path `id` for what is drawn inside.
    pub fn area_svg(&self, s: &mut String, id: &str) {
        let _ = writeln!(
            s,
            r##"<rect id="{id}-area" x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="white" stroke="#444"/>"##,
            self.left, self.top, self.width, self.height
        );
        let _ = writeln!(
            s,
            r#"<clipPath id="{id}"><rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}"/></clipPath>"#,
            self.left, self.top, self.width, self.height
        );
    }

    /// Grid lines, tick marks and labels on the left and bottom edges, with
    /// the axis titles.
    pub fn axes_svg(&self, s: &mut String, x_step: f64, y_step: f64, x_title: &str, y_title: &str) {
        let (bottom, right) = (self.top + self.height, self.left + self.width);
        for v in ticks(self.x, x_step) {
            let x = self.px(v);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{bottom:.1}" stroke="#e4e4e4"/><line x1="{x:.1}" y1="{bottom:.1}" x2="{x:.1}" y2="{:.1}" stroke="#444"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                self.top,
                bottom + 5.0,
                bottom + 18.0,
                label(v, x_step)
            );
        }
        for v in ticks(self.y, y_step) {
            let y = self.py(v);
            let _ = writeln!(
                s,
                r##"<line x1="{:.1}" y1="{y:.1}" x2="{right:.1}" y2="{y:.1}" stroke="#e4e4e4"/><line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#444"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
                self.left,
                self.left - 5.0,
                self.left,
                self.left - 8.0,
                y + 4.0,
                label(v, y_step)
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            self.left + 0.5 * self.width,
            bottom + 36.0,
            escape(x_title)
        );
        let _ = writeln!(
            s,
            r#"<text transform="translate({:.1} {:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
            self.left - 44.0,
            self.top + 0.5 * self.height,
            escape(y_title)
        );
    }
}

/// Text for SVG and HTML.
pub fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `points="…"` of a polyline through the finite points, in pixels.
pub fn points(frame: &Frame, pts: impl IntoIterator<Item = (f64, f64)>) -> String {
    let mut d = String::new();
    for (x, y) in pts {
        if x.is_finite() && y.is_finite() {
            let _ = write!(d, "{:.1},{:.1} ", frame.px(x), frame.py(y));
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps_and_labels() {
        assert_eq!(nice_step(13.5, 10.0), 1.0);
        assert_eq!(nice_step(40.0, 10.0), 5.0);
        assert_eq!(nice_step(0.3, 6.0), 0.05);
        assert_eq!(nice_step(f64::NAN, 6.0), 1.0);
        assert_eq!(label(-0.0001, 0.5), "0.0");
        assert_eq!(label(2.0, 1.0), "2");
        assert_eq!(label(0.25, 0.05), "0.25");
        assert_eq!(
            ticks(Range { lo: -1.2, hi: 2.7 }, 1.0),
            vec![-1.0, 0.0, 1.0, 2.0]
        );
    }

    #[test]
    fn an_equal_frame_keeps_one_scale_on_both_axes() {
        let f = Frame::equal(
            0.0,
            0.0,
            800.0,
            200.0,
            600.0,
            Range { lo: 0.0, hi: 10.0 },
            Range { lo: 0.0, hi: 1.0 },
        );
        let kx = f.width / f.x.span();
        let ky = f.height / f.y.span();
        assert!((kx - ky).abs() < 1e-9, "{kx} {ky}");
        assert_eq!(f.height, 200.0, "a flat path gets the least height");
        assert!(f.contains(5.0, 0.5) && !f.contains(11.0, 0.5));
        let tall = Frame::equal(
            0.0,
            0.0,
            800.0,
            200.0,
            600.0,
            Range { lo: 0.0, hi: 1.0 },
            Range { lo: 0.0, hi: 10.0 },
        );
        assert_eq!(tall.height, 600.0);
        assert!((tall.width / tall.x.span() - tall.height / tall.y.span()).abs() < 1e-9);
        assert!(tall.x.contains(0.0) && tall.x.contains(1.0));
    }

    #[test]
    fn ranges_skip_non_finite_values() {
        assert_eq!(
            Range::of([f64::NAN, 1.0, f64::INFINITY, -2.0]),
            Some(Range { lo: -2.0, hi: 1.0 })
        );
        assert_eq!(Range::of([f64::NAN]), None);
    }
}
